"""The benchmark figures read at a glance: one look per method, legends off the data, no
impossible ticks (issue 25).

Each plot function draws from the rows stored in ``benchmarks/results/*.csv`` (nothing is
run or timed); ``pyplot.close`` and ``Figure.savefig`` are caught so the figures can be
examined after drawing.
"""

import csv
import importlib.util
import pathlib

import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_hex  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from benchmarks.harness import style  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


def _stored(name):
    path = RESULTS / f"{name}.csv"
    if not path.exists():
        pytest.skip(f"{path} is not in this checkout")
    return style.read_rows(path)


def _benchmark(name):
    """``benchmarks/<name>.py``, a script, loaded from its path (jax's x64 flag kept as it
    was: benchmarks/stability.py turns it on when loaded)."""
    import jax

    x64 = jax.config.jax_enable_x64
    path = ROOT / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"figures_{name}", path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    finally:
        jax.config.update("jax_enable_x64", x64)
    return module


@pytest.fixture
def drawn(monkeypatch):
    """The figures ``pyplot.close`` was asked to close, kept open to be examined (and not
    written: encoding the PNGs would take most of this file's time)."""
    figures = []
    monkeypatch.setattr(plt, "close", lambda figure=None: figures.append(figure))
    monkeypatch.setattr(Figure, "savefig", lambda figure, *args, **kwargs: None)
    yield figures
    monkeypatch.undo()
    for figure in figures:
        plt.close(figure)


def _series(figure, name=lambda label: label):
    """``series -> set of colours`` over every labelled line of ``figure``; ``name(label)``
    the series a line's label belongs to."""
    colours = {}
    for axes in figure.axes:
        for line in axes.lines:
            if not line.get_label().startswith("_"):
                series = name(line.get_label())
                colours.setdefault(series, set()).add(to_hex(line.get_color()))
    return colours


def _check(figure, count_axes=(), name=lambda label: label):
    """No colour on two series (``name(label)``: a line's series); every legend clear of
    every axes' data area; no negative tick in view (every value drawn is 0 or more); no
    negative tick at all on ``count_axes``."""
    figure.canvas.draw()
    colours = _series(figure, name)
    assert colours, "no labelled series"
    for label, looks in colours.items():
        assert len(looks) == 1, f"{label} drawn in {looks}"
    owners = {}
    for label, (colour,) in colours.items():
        assert owners.setdefault(colour, label) == label, f"{label} and {owners[colour]}: {colour}"
    legends = [axes.get_legend() for axes in figure.axes if axes.get_legend()]
    legends += figure.legends
    assert legends, "no legend"
    for legend in legends:
        box = legend.get_window_extent()
        for axes in figure.axes:
            assert not box.overlaps(axes.bbox), f"legend over {axes.get_title()!r}"
    for axes in figure.axes:
        for axis, (low, high) in ((axes.xaxis, axes.get_xlim()), (axes.yaxis, axes.get_ylim())):
            low, high = min(low, high), max(low, high)
            ticks = [*axis.get_majorticklocs(), *axis.get_minorticklocs()]
            shown = [t for t in ticks if low <= t <= high]
            assert all(t >= 0 for t in shown), f"{axes.get_title()!r}: ticks {shown}"
    for axes in count_axes:
        assert axes.get_yscale() != "symlog" or axes.get_ylim()[0] > -1
        assert min(axes.get_yticks()) >= 0, axes.get_yticks()


def test_the_table_gives_each_series_its_own_look():
    pairs = [(colour, marker) for colour, marker in style.STYLES.values()]
    assert len(set(pairs)) == len(pairs)
    for name in style.JAXCONTACT:
        looks = style.style(name)
        assert looks["linestyle"] == "-" and looks["markerfacecolor"] == looks["color"], name
    for name in style.PEERS:
        looks = style.style(name)
        assert looks["linestyle"] == "--" and looks["markerfacecolor"] == "none", name
    own = {colour for colour, _ in style.JAXCONTACT.values()}
    assert not own & {colour for colour, _ in style.PEERS.values()}


def test_every_stored_series_is_in_the_table():
    for path in sorted(RESULTS.glob("**/*.csv")):
        with open(path, newline="") as stream:
            rows = list(csv.DictReader(stream))
        for row in rows:
            if "method" in row:
                assert style.canonical(row["method"]) in style.STYLES, (path.name, row["method"])
            if "dtype" in row and "tie" in row:
                assert f"{row['dtype']} {row['tie']}" in style.STYLES


def test_unknown_names_never_share_a_colour_in_a_figure():
    used = {}
    names = [f"peer {k}" for k in range(30)] + [f"bucket_sort x{k}" for k in range(30)]
    names += list(style.STYLES) + ["bucket_sort (sized)", "jaxcontact all_to_all"]
    colours = {}
    for name in names:
        colours.setdefault(style.canonical(name), set()).add(style.style(name, used)["color"])
    assert all(len(found) == 1 for found in colours.values())
    assert len({found.pop() for found in colours.values()}) == len(colours)
    again = {}
    assert [style.style(n, again) for n in names] == [style.style(n, used) for n in names]


def test_time_vs_error_figures(tmp_path, drawn):
    from benchmarks import time_vs_error

    rows = _stored("time_vs_error")
    paths = time_vs_error.plot(rows, str(tmp_path))
    assert [pathlib.Path(p).name for p in paths] == ["time_vs_error.png", "gap_error_vs_offset.png"]
    tradeoff, offsets = drawn
    counts = [axes for axes in tradeoff.axes if "wrong rows" in axes.get_ylabel()]
    assert len(counts) == 2
    _check(tradeoff, counts)
    _check(offsets)
    assert offsets.axes[0].xaxis.get_ticklabels()[0].get_text() == "0"  # 0 drawn at 0.1


def test_peers_figure(tmp_path, drawn):
    from benchmarks import peers

    peers.plot(_stored("peers"), str(tmp_path))
    (figure,) = drawn
    _check(figure)
    assert len(_series(figure)) >= 12


def test_paper_tests_figures(tmp_path, drawn):
    from benchmarks import paper_tests

    paper_tests.plot(_stored("paper_tests"), str(tmp_path))
    assert len(drawn) == 2
    for figure in drawn:
        _check(figure)
        assert len(_series(figure)) == 6  # four methods, the paper's two averages


def test_stability_figures(tmp_path, drawn):
    stability = _benchmark("stability")
    for name, x_key, y_keys in (
        ("offset", "offset", [("max_gap_error", "o-")]),
        ("angle", "angle", [("max_t_error", "o-"), ("eps_over_sin_angle", "k:")]),
    ):
        rows = _stored(f"stability_{name}")
        stability._plot(rows, x_key, y_keys, tmp_path / f"{name}.png", name, x_key, "error")
    rows = _stored("stability_ties")
    ties = [dict(row, group=f"{row['dtype']} {row['tie']}") for row in rows]
    stability._plot(
        ties, "delta", [("wrong_choice_rate", "o-")], tmp_path / "ties.png", "ties", "delta",
        "rate", group="group", log_y=False,
    )  # fmt: skip
    assert len(drawn) == 3
    for figure in drawn:
        _check(figure)
    assert drawn[2].axes[0].get_ylim()[0] == 0  # a rate: from 0
    assert len(_series(drawn[1])) == 4  # each precision's error and its bound, four colours
