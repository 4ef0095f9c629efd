"""The cutting demo's progress: a bar redrawn in place on a terminal, whole lines in a log."""

import io

from jaxcontact.problems.cutting import demo as cutting_demo


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _report(stream, total: int = 1000, calls: int = 40) -> str:
    progress = cutting_demo._Progress(stream)
    for call in range(calls + 1):
        progress(total * call // calls, total)
    return stream.getvalue()


def test_off_a_terminal_the_progress_is_whole_lines_one_each_tenth():
    written = _report(io.StringIO())
    assert "\r" not in written
    lines = written.splitlines()
    assert written.endswith("\n") and len(lines) == 11  # 0 %, every tenth, 100 %
    assert [line.split("]")[1].split()[0] for line in lines] == [f"{10 * k}%" for k in range(11)]
    assert "(compiling)" in lines[0] and "1000/1000 steps" in lines[-1]


def test_fewer_calls_than_tenths_write_a_line_each():
    lines = _report(io.StringIO(), total=616, calls=4).splitlines()
    assert [line.split("]")[1].split()[0] for line in lines] == ["0%", "25%", "50%", "75%", "100%"]


def test_on_a_terminal_the_bar_is_redrawn_in_place():
    written = _report(_Terminal())
    assert written.count("\r") == 41 and written.count("\n") == 1 and written.endswith("\n")
