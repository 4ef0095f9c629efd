"""The accuracy suites at tiny sizes: ``benchmarks/stability.py``, ``time_vs_error.py`` and
``paper_tests.py``.

The timings themselves are not tested (a loaded machine makes any bound flaky); what is
tested is that every answer is checked, that a wrong answer is reported as wrong, and that
each suite's figure, drawn from its record as read back from JSON, draws only series of
``style.STYLES``, in one colour each, with the legend off the data and no negative tick.
"""

import json
import types

import numpy as np
import pytest

from benchmarks.harness import _run, answers, report, style
from benchmarks.harness.timing import Timing
from jaxcontact.scenes import cutting_scene, paper_scene


def _stored_form(run_result, suite="suite"):
    """``run``'s result as a record read back from its JSON, as ``draw`` receives it."""
    rec = report.record(
        suite,
        run_result["title"],
        run_result["tables"],
        data=run_result.get("data"),
        notes=run_result.get("notes", ()),
        argv=[],
    )
    return json.loads(json.dumps(rec, allow_nan=True))


@pytest.fixture
def plt():
    """pyplot on Agg; the figures drawn are closed afterwards (not written: encoding PNGs
    is most of a figure's time)."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot

    yield pyplot
    pyplot.close("all")


def _check_figure(figure):
    """Every labelled series a key of ``style.STYLES`` and drawn in one colour that no other
    series has; every legend clear of every axes; no negative tick in view."""
    from matplotlib.colors import to_hex

    figure.canvas.draw()
    colours = {}
    for axes in figure.axes:
        for line in axes.lines:
            label = line.get_label()
            if not label.startswith("_"):
                assert style.canonical(label) in style.STYLES, label
                colours.setdefault(style.canonical(label), set()).add(to_hex(line.get_color()))
    assert colours, "no labelled series"
    assert all(len(found) == 1 for found in colours.values()), colours
    assert len({found.pop() for found in colours.values()}) == len(colours)
    legends = [axes.get_legend() for axes in figure.axes if axes.get_legend()]
    assert legends, "no legend"
    for legend in legends:
        for axes in figure.axes:
            assert not legend.get_window_extent().overlaps(axes.bbox), axes.get_title()
    for axes in figure.axes:
        for axis, limits in ((axes.xaxis, axes.get_xlim()), (axes.yaxis, axes.get_ylim())):
            low, high = sorted(limits)
            ticks = [*axis.get_majorticklocs(), *axis.get_minorticklocs()]
            shown = [t for t in ticks if low <= t <= high]
            assert all(t >= 0 for t in shown), (axes.get_title(), shown)


def _rows(table):
    return [dict(zip(table["columns"], row, strict=True)) for row in table["rows"]]


# --- stability -----------------------------------------------------------------------------


@pytest.fixture
def stability(monkeypatch):
    """The stability suite with two points a sweep."""
    from benchmarks import stability

    monkeypatch.setattr(stability, "OFFSETS", (0.0, 1e7))
    monkeypatch.setattr(stability, "LENGTHS", (1e-9, 1.0))
    monkeypatch.setattr(stability, "ANGLES", (1e-7, 1.0))
    monkeypatch.setattr(stability, "DELTAS", (1e-12, 1e-2))
    return stability


@pytest.mark.x64  # the float64 studies
def test_stability_record_and_figure(stability, plt):
    found = stability.run(types.SimpleNamespace(quick=True, seed=0))
    assert [t["title"] for t in found["tables"]] == [t for t, _ in stability.STUDIES.values()]
    offset, length, angle, ties = (_rows(t) for t in found["tables"])
    assert len(offset) == len(length) == len(angle) == 4 and len(ties) == 8
    for row in offset:
        assert 0 <= row[stability.IN_EPS] <= stability.ULPS, row
    # float32 rounds a segment of 1e-9 at 0.5 from the origin to a point: no error to show.
    short = [row for row in length if row["length"] == 1e-9]
    assert short[0]["collapsed"] == 2 and short[0][stability.ERROR] is None
    assert short[1]["collapsed"] == 0 and short[1][stability.ERROR] is not None
    for row in angle:
        assert row[stability.T_IN_EPS] <= 1 and row["unexplained"] == 0, row
    assert all(row["unexplained"] == 0 and 0 <= row[stability.RATE] <= 1 for row in ties)
    assert "within the bound 8" in found["notes"][1] and "No differing" in found["notes"][1]

    figure = stability.draw(_stored_form(found, "stability"), plt)
    _check_figure(figure)
    assert len(figure.axes) == 4
    assert figure.axes[3].get_ylim()[0] == 0  # a rate: from 0
    assert figure.axes[0].xaxis.get_ticklabels()[0].get_text() == "0"  # 0 drawn at 0.1


@pytest.mark.x64
def test_stability_reports_a_wrong_gap_and_a_wrong_choice(stability, monkeypatch):
    """A gap off by 1e-3 is far above the bound; a segment choice swapped far from any tie
    is not explained by rounding: both come out in the verdict."""
    right = stability.contact

    def off(x, surface):
        found = right(x, surface)
        if surface.segments.shape[0] == 2:  # a tie scene: the other segment chosen
            return found._replace(segment=1 - found.segment)
        return found._replace(gap=found.gap + 1e-3)

    monkeypatch.setattr(stability, "contact", off)
    rng = np.random.default_rng(0)
    studies = {
        "offset": stability.study_offset(rng, 1, (0.0,)),
        "length": [],
        "angle": [],
        "ties": stability.study_ties(rng, 1, (1e-2,)),
    }
    assert all(row[stability.IN_EPS] > stability.ULPS for row in studies["offset"])
    assert sum(row["unexplained"] for row in studies["ties"]) > 0
    text = stability.verdict(studies)
    assert "**above the bound 8**" in text and "the float bound does not explain" in text


# --- time_vs_error -------------------------------------------------------------------------


@pytest.mark.x64  # the reference is all_to_all in float64
def test_time_vs_error_counts_sizes_too_small_and_draws(monkeypatch, plt):
    """Sizes too small for the scene set ``overflow`` and miss contacts, and the row says so;
    the float32 error grows with the offset while its own arithmetic's does not."""
    import jax.numpy as jnp

    from benchmarks import time_vs_error
    from benchmarks.harness.internals import measure

    def two(scene64, quick):
        scene = time_vs_error._cast(scene64, jnp.float32)
        args = (scene.x, scene.surface)
        sizes = measure(scene.x, scene.surface, radius=scene64.radius)
        small = time_vs_error._shrunk(sizes, block_capacity=0.25)
        assert small.block_capacity == max(1, int(sizes.block_capacity * 0.25))
        return {
            "bucket_sort (sized) f32": (_run.sized_contact(scene64.radius, sizes), args),
            "bucket_sort (sized) f32, blocks x0.25": (
                _run.sized_contact(scene64.radius, small),
                args,
            ),
        }

    monkeypatch.setattr(time_vs_error, "variants", two)
    scene = cutting_scene(2_000, 18.0, dtype=jnp.float64)
    timed = time_vs_error.run_tradeoff("cutting", scene, repeats=2, quick=True)
    right, small = timed
    assert not right["overflow"] and right["missed"] == right["false"] == 0, right
    assert right["wrong segment"] == 0 and 0 < right["max gap error"] < 1e-5
    assert small["overflow"] and small["missed"] > 0, small
    assert all(row["median ms"] > 0 and row["runs"] == 2 for row in timed)

    shifted = time_vs_error.run_offsets(500, (0.0, 1e5), with_bucket=False)
    near, far = shifted
    assert far["max gap error"] > 100 * near["max gap error"]
    assert far["own max gap error"] < 1e-6 and near["own max gap error"] < 1e-6

    found = {
        "title": "t",
        "tables": [
            report.table(time_vs_error.TRADEOFF, timed, title=time_vs_error.TITLES[0]),
            report.table(time_vs_error.OFFSET, shifted, title=time_vs_error.TITLES[1]),
        ],
    }
    figure = time_vs_error.draw(_stored_form(found, "time_vs_error"), plt)
    _check_figure(figure)
    counts = [axes for axes in figure.axes if "wrong rows" in axes.get_ylabel()]
    assert len(counts) == 1 and min(counts[0].get_yticks()) >= 0


# --- paper_tests ---------------------------------------------------------------------------


@pytest.mark.x64  # the reference is all_to_all in float64
def test_paper_test1_rows_tables_and_figure(plt):
    from benchmarks import paper_tests

    rows = paper_tests.run_test1((1,), repeats=1)
    assert [row["method"] for row in rows] == list(paper_tests.METHODS)
    assert all(row["nodes"] == 4 and row["median ms"] > 0 for row in rows)
    assert all(row["wrong"] == 0 for row in rows)
    assert rows[0]["check"] == "same contacts"  # all_to_all against itself in float64
    assert rows[2]["check"] == rows[3]["check"] == "1 crossed, 0 rows differ"
    assert paper_tests.verdict(rows).startswith("All 4 answers")

    # Test 2's rows made up from Test 1's: the tables and the figure, not its timing.
    moved = [
        {**row, "test": paper_tests.TESTS[1], "position": d} for d in (0.0, 10.0) for row in rows
    ]
    means = _rows(paper_tests.means_table(rows + moved))
    assert [row["paper's average ms"] for row in means] == [640.0, 20.0, 640.0, 20.0]
    first = paper_tests.position_table(rows + moved, paper_tests.TESTS[0], "n", "1", None)
    (only,) = _rows(first)
    assert only["closest points"] == "same contacts" and only["nodes"] == 4
    second = paper_tests.position_table(rows + moved, paper_tests.TESTS[1], "d mm", "2", None)
    assert [row["d mm"] for row in _rows(second)] == [0.0, 10.0]
    found = {
        "title": "t",
        "tables": [paper_tests.means_table(rows + moved), first, second],
        "data": {"paper average s": paper_tests.PAPER_AVERAGE_S},
    }
    figure = paper_tests.draw(_stored_form(found, "paper_tests"), plt)
    _check_figure(figure)
    for axes in figure.axes:
        assert len([line for line in axes.lines if not line.get_label().startswith("_")]) == 6


@pytest.mark.x64
def test_paper_tests_report_wrong_answers():
    """A missed contact and a path given another segment: each counted, and the verdict
    lists them."""
    from benchmarks import paper_tests
    from benchmarks.peer_codes import baselines

    scene = paper_scene(9)
    x = np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    reference = answers.reference_contact(x, scene.surface, scene.radius)
    arrays = [np.asarray(a, np.float64) for a in (scene.x_prev, x, start, end)]
    crossing = baselines.brute_crossing(np, *arrays)
    segment, gap, found = reference.segment.copy(), reference.gap.copy(), reference.found.copy()
    found[np.flatnonzero(found)[0]] = False
    moved = crossing[0].copy()
    row = np.flatnonzero(crossing[2])[0]
    moved[row] = (moved[row] + 1) % len(start)
    results = {
        "all_to_all": (reference.segment, reference.gap, reference.found),
        "bucket_sort (sized)": (segment, gap, found),
        "swept": types.SimpleNamespace(segment=crossing[0]),
        "bucket_swept (sized)": types.SimpleNamespace(segment=moved),
    }
    checks = paper_tests._checks(scene, results)
    assert checks["all_to_all"] == (0, "same contacts")
    assert checks["bucket_sort (sized)"] == (1, "1 missed")
    assert checks["swept"][0] == 0 and checks["bucket_swept (sized)"][0] == 1
    timing = Timing(0.1, 1e-3, 1e-3, 1e-3, 1)
    timings = dict.fromkeys(paper_tests.METHODS, timing)
    rows = paper_tests._rows(paper_tests.TESTS[0], scene, 9, timings, checks)
    text = paper_tests.verdict(rows)
    assert text.startswith("**2 answers differ")
    assert "bucket_sort (sized): 1 missed" in text and "1 rows differ" in text
    table = _rows(paper_tests.position_table(rows, paper_tests.TESTS[0], "n", "1", None))
    assert table[0]["closest points"] == "all_to_all: same contacts; bucket_sort (sized): 1 missed"
