"""The benchmark figures read at a glance: one look per method, legends off the data, no
impossible ticks (issue 25).

Each plot function draws from the rows stored in ``benchmarks/results/*.csv`` (nothing is
run or timed); ``pyplot.close`` and ``Figure.savefig`` are caught so the figures can be
examined after drawing.
"""

import importlib
import importlib.util
import pathlib

import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_hex  # noqa: E402
from matplotlib.container import ErrorbarContainer  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from benchmarks.harness import report, style  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


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
    """``series -> set of colours`` over every labelled line of ``figure`` (an error bar's
    label is its container's, its colour its data line's); ``name(label)`` the series a
    line's label belongs to."""
    colours = {}
    for axes in figure.axes:
        labelled = [(line.get_label(), line) for line in axes.lines]
        errorbars = [bars for bars in axes.containers if isinstance(bars, ErrorbarContainer)]
        labelled += [(bars.get_label(), bars.lines[0]) for bars in errorbars]
        for label, line in labelled:
            if not label.startswith("_"):
                colours.setdefault(name(label), set()).add(to_hex(line.get_color()))
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


@pytest.mark.parametrize("path", report.stored(), ids=lambda p: str(p.relative_to(RESULTS)))
def test_every_stored_figure_draws_each_method_in_its_one_look(path, drawn):
    """Each stored record's figure, drawn again from its JSON: every labelled series is a
    method or guide of the style table, in that table's colour; and ``_check``'s rules (no two
    series share a colour, legends off the data, no negative tick)."""
    rec = report.load(path)
    figure = importlib.import_module(f"benchmarks.{rec['suite']}").draw(rec, plt)
    _check(figure, name=style.canonical)
    for name, (colour,) in _series(figure, style.canonical).items():
        assert name in style.STYLES, f"{path.name}: {name!r} is not in the style table"
        assert colour == style.STYLES[name][0], f"{path.name}: {name!r} drawn in {colour}"
    plt.close(figure)


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
