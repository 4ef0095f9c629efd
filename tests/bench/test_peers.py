"""benchmarks/peers.py and benchmarks/swept_peers.py at tiny sizes: their peers, their checks,
their records and the figures drawn from them.

Each suite's ``run`` goes through one tiny scene once (a module fixture: the library's
programs compile once per suite), with NumPy peers only, one of them skipped by its budget,
one wrong on purpose and one not installed. The timings themselves are not tested (a loaded
machine makes any bound flaky); what is tested is that every answer is checked, that a wrong
answer is reported as wrong, and that the record and its figure say so.
"""

import argparse

import numpy as np
import pytest

from benchmarks import peers, swept_peers
from benchmarks.harness import _run, answers, report, style
from benchmarks.peer_codes import baselines
from jaxcontact import Surface, swept
from jaxcontact.scenes import cutting_scene, paper_scene, rough_die_scene
from tests.support.tolerances import FLOAT64_EXACT_ATOL

WRONG = "a peer that misses a contact"  # a test's own peer, in no figure's table
NOWHERE = "a peer that is not installed"


def _scene_arrays(scene):
    start, end = _run.endpoints(scene.surface)
    return np.asarray(scene.x), start, end


def _path_arrays(scene):
    start, end = _run.endpoints(scene.surface)
    return np.asarray(scene.x_prev), np.asarray(scene.x), start, end


# jax-md is left to the benchmark's own check: importing it takes 15 s (flax, pymatgen).
@pytest.mark.x64
@pytest.mark.parametrize("name", [name for name in baselines.PEERS if name != "jax-md cell list"])
def test_every_peer_agrees_with_the_reference_up_to_ties(name):
    if baselines.unavailable(name):
        pytest.skip(baselines.unavailable(name))
    for scene in (cutting_scene(500, 18.0), rough_die_scene(1_000, 100)):
        x, start, end = _scene_arrays(scene)
        reference = answers.reference_contact(x, scene.surface, scene.radius)
        fn, args = baselines.PEERS[name][1](x, start, end, scene.radius)
        mismatch = _run.check(fn(*args), x, start, end, reference)
        assert (mismatch.missed, mismatch.false, mismatch.wrong_segment) == (0, 0, 0), mismatch
        assert mismatch.max_gap_error < 1e-5


def test_a_missing_peer_is_reported_not_raised(monkeypatch):
    monkeypatch.setitem(baselines.PEERS, "nowhere", ("no_such_module_xyz", None))
    assert baselines.unavailable("nowhere").startswith("not installed")


@pytest.mark.x64  # the reference is swept in float64
@pytest.mark.parametrize("name", list(swept_peers.SWEPT_PEERS))
def test_every_swept_peer_agrees_with_float64_swept(name):
    module = swept_peers.SWEPT_PEERS[name][0]
    if baselines.unavailable_module(module):
        pytest.skip(baselines.unavailable_module(module))
    for scene in (cutting_scene(500, 18.0, x_tip_prev=19.5), paper_scene(9)):
        x_prev, x, start, end = _path_arrays(scene)
        reference = swept_peers.reference_crossing(scene)
        assert reference[2].sum() >= 3
        fn, args = swept_peers.SWEPT_PEERS[name][1](x_prev, x, start, end)
        fields = swept_peers.compare_crossing(fn(*args), reference, x_prev, x, start, end)
        assert (fields["missed"], fields["false"], fields["wrong_segment"]) == (0, 0, 0), fields
        assert fields["max_t_error"] < 1e-5


def test_numba_swept_follows_the_contract_at_its_edge_cases():
    """Touching an end, arriving at t = 1, starting on the segment, along its line, parallel."""
    pytest.importorskip("numba")
    from benchmarks.peer_codes import numba_grid

    start, end = np.array([[0.0, 0.0]]), np.array([[2.0, 0.0]])
    paths = np.array(
        [
            [[-1.0, 1.0], [1.0, -1.0]],  # through the start point a: t = 1/2
            [[1.0, 1.0], [1.0, 0.0]],  # arrives on the segment: t = 1
            [[1.0, 0.0], [1.0, 1.0]],  # starts on it: t = 0
            [[-2.0, 0.0], [1.0, 0.0]],  # along its line, entering at t = 2/3
            [[4.0, 0.0], [3.0, 0.0]],  # along its line, never reaching it
            [[0.0, 1.0], [2.0, 1.0]],  # parallel, off the line
            [[1.0, 0.0], [1.0, 0.0]],  # no motion, on it: t = 0
            [[3.0, 1.0], [3.0, -1.0]],  # passes beyond the end
        ]
    )
    x_prev, x = paths[:, 0], paths[:, 1]
    segment, t, crossed = numba_grid.swept(x_prev, x, start, end)
    library = swept(x_prev, x, Surface(np.concatenate([start, end]), np.array([[0, 1]])))
    np.testing.assert_array_equal(crossed, np.asarray(library.crossed))
    np.testing.assert_array_equal(segment, np.asarray(library.segment))
    np.testing.assert_allclose(t, np.asarray(library.t), atol=FLOAT64_EXACT_ATOL)
    assert crossed.tolist() == [True, True, True, True, False, False, True, False]


def test_numba_closest_with_no_slaves():
    pytest.importorskip("numba")
    from benchmarks.peer_codes import numba_grid

    segment, gap, found = numba_grid.closest(
        np.zeros((0, 2), np.float32), np.zeros((1, 2), np.float32), np.ones((1, 2), np.float32), 1
    )
    assert segment.shape == gap.shape == found.shape == (0,) and gap.dtype == np.float32


@pytest.mark.parametrize("self_contact", [False, True])
def test_numba_closest_applies_the_pair_rule_as_the_library_does(self_contact):
    # The chip's outline against itself: with no rule every node finds its own segments;
    # with the rule (own node; self-contact's window along the outline) the numba grid must
    # find exactly what all_to_all finds.
    pytest.importorskip("numba")
    from benchmarks.peer_codes import numba_grid
    from jaxcontact import Pairs, all_to_all
    from jaxcontact.scenes import curling_chip

    scene = curling_chip(1_500)
    pairs = Pairs(scene.slave_node, self_contact=self_contact)
    want = all_to_all(scene.x, scene.surface, radius=scene.radius, pairs=pairs)
    start, end = _run.endpoints(scene.surface)
    rule = (scene.slave_node, scene.surface.segments, len(scene.surface.nodes), self_contact)
    args = (np.asarray(scene.x), start, end, scene.radius)
    segment, gap, found = numba_grid.closest(*args, pairs=tuple(np.asarray(v) for v in rule))
    np.testing.assert_array_equal(found, np.asarray(want.found))
    # Exact vertex ties may go either way (the two tie rules differ, and so may the sign at
    # the vertex): equally far.
    other = found & (segment != np.asarray(want.segment))
    assert other.sum() <= 0.01 * found.sum()
    far = np.abs(np.asarray(want.gap)[other])
    np.testing.assert_allclose(np.abs(gap[other]), far, atol=1e-6 * scene.radius)
    ends = np.asarray(scene.surface.segments)[segment[found]]
    assert not np.any(ends == np.asarray(scene.slave_node)[found, None])
    plain = numba_grid.closest(*args)[2]
    assert plain.all() and 0 < found.sum() and (found.sum() < len(found)) == self_contact


@pytest.mark.x64
def test_a_wrong_crossing_is_counted():
    scene = cutting_scene(500, 18.0, x_tip_prev=19.5)
    x_prev, x, start, end = _path_arrays(scene)
    reference = swept_peers.reference_crossing(scene)
    segment, t, crossed = (part.copy() for part in reference)
    rows = np.flatnonzero(crossed)
    crossed[rows[0]] = False  # a missed crossing
    segment[rows[1]] = (segment[rows[1]] + 5) % len(start)  # another segment
    t[rows[2]] += 0.01
    far = np.flatnonzero(~reference[2])[0]
    segment[far], crossed[far] = 0, True  # a false crossing
    fields = swept_peers.compare_crossing((segment, t, crossed), reference, x_prev, x, start, end)
    assert (fields["missed"], fields["false"], fields["wrong_segment"]) == (1, 1, 1)
    assert fields["max_t_error"] >= 0.01


def _missing_one(peer):
    """``peer``'s answer with its first found row dropped: a missed contact or crossing."""

    def wrong(*args):
        segment, value, found = (np.array(part) for part in peer(*args)[:3])
        found[np.flatnonzero(found)[0]] = False
        return segment, value, found

    return wrong


def _suite_run(module, chosen, monkeypatch, tmp_path, **more):
    """``module.run`` on ``chosen`` (its --quick scenes for the run), twice timed."""
    monkeypatch.setattr(module, "QUICK_SCENES", chosen)
    args = argparse.Namespace(quick=True, out=str(tmp_path), repeats=2, slow=60.0, **more)
    return module.run(args)


def _record(name, found):
    return report.record(name, found["title"], found["tables"], data=found["data"], quick=True)


@pytest.fixture(scope="module")
def peers_found(tmp_path_factory):
    """``peers.run`` on the tool-in cutting scene at 1,000 nodes: the library's three
    programs, NumPy dense (over its pair budget: skipped), NumPy box-then-dense, a peer that
    misses a contact and one that is not installed."""
    chosen = {
        "NumPy dense": baselines.PEERS["NumPy dense"],
        "NumPy box-then-dense": baselines.PEERS["NumPy box-then-dense"],
        WRONG: (None, lambda *args: (_missing_one(baselines.numpy_dense), args)),
        NOWHERE: ("no_such_module_xyz", None),
    }
    with pytest.MonkeyPatch.context() as monkeypatch:
        monkeypatch.setattr(baselines, "PEERS", chosen)
        monkeypatch.setattr(peers, "PAIR_BUDGET", 5_000)  # dense (19,840 pairs) skipped, box not
        scenes = (("cutting, tool in (x_tip=18)", 1_000, 18.0),)
        yield _suite_run(peers, scenes, monkeypatch, tmp_path_factory.mktemp("peers"))


@pytest.mark.x64  # the reference is all_to_all in float64
def test_peers_record_checks_every_answer(peers_found):
    runs = {entry["method"]: entry for entry in peers_found["data"]["runs"]}
    ours = {"all_to_all", peers.LIBRARY, peers.COMPACT}
    assert set(runs) == ours | {"NumPy dense", "NumPy box-then-dense", WRONG, NOWHERE}
    assert runs["NumPy dense"]["note"].startswith("skipped")
    assert runs["NumPy dense"]["median_ms"] is None
    for method in (*ours, "NumPy box-then-dense", WRONG):
        entry = runs[method]
        assert entry["median_ms"] > 0 and entry["runs"] == 2
        assert entry["false"] == entry["wrong_segment"] == 0, entry
        assert entry["missed"] == (1 if method == WRONG else 0), entry
    for method in ours:
        assert runs[method]["compile_s"] > 0 and peers.memory_mib(runs[method]) > 0
    assert runs[peers.LIBRARY]["ratio"] == 1.0
    # Those run on no scene (not installed, or skipped on the one scene) are in the notes,
    # not in the tables.
    (note,) = peers_found["notes"]
    assert f"{NOWHERE} (not installed" in note and "NumPy dense (skipped" in note
    ratios, scene = peers_found["tables"]
    shown = [m for m in runs if m not in ("NumPy dense", NOWHERE)]
    assert [row[0] for row in ratios["rows"]] == shown
    assert ratios["columns"] == ["method", "tool in, N=992"]
    assert scene["title"].startswith("cutting, tool in (x_tip=18): N = 992 slave nodes, M = 20")
    by_method = {row[0]: dict(zip(scene["columns"], row, strict=True)) for row in scene["rows"]}
    assert list(by_method) == shown
    assert by_method[WRONG]["missed"] == 1 and by_method[peers.LIBRARY]["missed"] == 0
    assert by_method[peers.LIBRARY]["ratio"] == 1.0 and by_method[peers.LIBRARY]["compile s"] > 0
    assert "max gap error" in scene["columns"] and "memory MiB" in scene["columns"]


@pytest.mark.x64
def test_a_method_skipped_on_some_scenes_keeps_its_row_and_reason(peers_found):
    runs = peers_found["data"]["runs"]
    larger = _grown(runs, runs[0]["scene"], 10)
    for entry in larger:
        if entry["method"] == "NumPy dense":  # as if run there
            entry.update(median_ms=1.0, ratio=2.0, note="", missed=0)
    ratios = peers.ratio_table(runs + larger, peers.LIBRARY, "note")
    assert ratios["columns"] == ["method", "tool in, N=992", "tool in, N=9,920"]
    assert ["NumPy dense", None, 2.0] in ratios["rows"]
    first, _ = peers.scene_tables(runs + larger, "max_gap_error", peers.scene_title)
    by_method = {row[0]: dict(zip(first["columns"], row, strict=True)) for row in first["rows"]}
    assert by_method["NumPy dense"]["median ms"] is None
    assert by_method["NumPy dense"]["note"].startswith("skipped")
    assert NOWHERE not in by_method


@pytest.mark.x64
def test_peers_record_and_figure_from_the_json(peers_found, tmp_path):
    pytest.importorskip("matplotlib")
    written = report.save(_record("peers", peers_found), tmp_path, peers.draw)
    assert [p.rsplit("/", 1)[1] for p in written] == ["peers.json", "peers.png"]
    stored = report.load(written[0])
    assert report.stamp(written[1]) == report.digest(stored)
    assert "| method | tool in, N=992 |" in report.markdown(stored, "peers.png")


def _grown(runs, scene, by):
    """``runs`` as if measured on ``scene`` at ``by`` times the nodes (time likewise)."""
    return [
        {
            **entry,
            "scene": scene,
            "nodes": entry["nodes"] * by,
            "median_ms": entry["median_ms"] and entry["median_ms"] * by,
        }
        for entry in runs
    ]


def _check_figure(figure, skip=()):
    """Every labelled series in ``style.STYLES`` (but ``skip``), one colour each and no two
    series in one colour; one legend, clear of every panel."""
    from matplotlib.colors import to_hex

    figure.canvas.draw()
    colours = {}
    for axes in figure.axes:
        for line in axes.lines:
            if not line.get_label().startswith("_"):
                colours.setdefault(line.get_label(), set()).add(to_hex(line.get_color()))
    assert colours
    for label, looks in colours.items():
        assert label in skip or style.canonical(label) in style.STYLES, label
        assert len(looks) == 1, (label, looks)
    assert len({colour for (colour,) in colours.values()}) == len(colours)
    legends = [axes.get_legend() for axes in figure.axes if axes.get_legend()]
    assert len(legends) == 1
    for axes in figure.axes:
        assert not legends[0].get_window_extent().overlaps(axes.bbox)
    return colours


@pytest.mark.x64
def test_peers_figure_has_a_panel_per_family_and_one_for_single_sizes(peers_found):
    """A family run at two sizes gets a panel of lines; the families run at one size share
    one panel, a marker per method beside its scene."""
    plt = report.pyplot()
    if plt is None:
        pytest.skip("matplotlib is not installed")
    runs = peers_found["data"]["runs"]
    scene = runs[0]["scene"]
    grown = runs + _grown(runs, scene, 10) + _grown(runs, "rough die", 1)
    record = {"title": "peers", "data": {"runs": grown}}
    figure = peers.draw(record, plt)
    try:
        lines, single = figure.axes[:2]
        assert lines.get_xscale() == "log" and lines.get_title() == scene
        assert single.get_title() == "scenes run at one size each"
        assert [t.get_text() for t in single.get_xticklabels()] == ["rough die\nN=992, M=20"]
        colours = _check_figure(figure, skip=(WRONG,))
        assert len(colours) == 5  # the library's three, box-then-dense and the wrong one
    finally:
        plt.close(figure)


def test_the_scene_names_in_column_heads():
    assert peers.short("cutting, tool in (x_tip=18)") == "tool in"
    assert peers.short("paper Test 2 (length 20, d=10)") == "paper Test 2"
    assert peers.short("rough die") == "rough die"


@pytest.fixture(scope="module")
def swept_found(tmp_path_factory):
    """``swept_peers.run`` on the tool-in cutting scene at 500 nodes: the library's three
    programs, NumPy dense (over its pair budget: skipped), a peer that misses a crossing and
    one that is not installed."""
    numpy_dense = swept_peers.SWEPT_PEERS["NumPy dense"]
    chosen = {
        "NumPy dense": numpy_dense,
        WRONG: (None, lambda *args: (_missing_one(swept_peers.numpy_dense), args)),
        NOWHERE: ("no_such_module_xyz", None),
    }
    with pytest.MonkeyPatch.context() as monkeypatch:
        monkeypatch.setattr(swept_peers, "SWEPT_PEERS", chosen)
        monkeypatch.setattr(swept_peers, "PAIR_BUDGET", 5_000)  # 9,900 pairs: skipped
        scenes = (("cutting, tool in (x_tip=18 from 19.5)", 500, (18.0, 19.5)),)
        out = tmp_path_factory.mktemp("swept")
        yield _suite_run(swept_peers, scenes, monkeypatch, out, scenes=None)


@pytest.mark.x64  # the reference is swept in float64
def test_swept_peers_record_checks_every_answer(swept_found):
    runs = {entry["method"]: entry for entry in swept_found["data"]["runs"]}
    ours = {"swept", swept_peers.LIBRARY, swept_peers.COMPACT}
    assert set(runs) == ours | {"NumPy dense", WRONG, NOWHERE}
    assert runs["NumPy dense"]["note"].startswith("skipped")
    for method in (*ours, WRONG):
        entry = runs[method]
        assert entry["median_ms"] > 0 and entry["runs"] == 2
        assert entry["false"] == entry["wrong_segment"] == 0, entry
        assert entry["missed"] == (1 if method == WRONG else 0), entry
        assert entry["max_t_error"] < 1e-5 and entry["crossed"] >= 3
    assert runs[swept_peers.LIBRARY]["ratio"] == 1.0
    assert runs[swept_peers.COMPACT]["compile_s"] > 0
    (note,) = swept_found["notes"]
    assert NOWHERE in note
    ratios, scene = swept_found["tables"]
    assert ratios["columns"] == ["method", "tool in, N=495"]
    assert "max t error" in scene["columns"] and scene["title"].endswith("paths cross")
    by_method = {row[0]: dict(zip(scene["columns"], row, strict=True)) for row in scene["rows"]}
    assert by_method[WRONG]["missed"] == 1 and NOWHERE not in by_method


@pytest.mark.x64
def test_swept_peers_figure_from_the_json(swept_found, tmp_path):
    pytest.importorskip("matplotlib")
    written = report.save(_record("swept_peers", swept_found), tmp_path, swept_peers.draw)
    stored = report.load(written[0])
    assert report.stamp(written[1]) == report.digest(stored)
    plt = report.pyplot()
    figure = swept_peers.draw(stored, plt)
    try:
        _check_figure(figure, skip=(WRONG,))
    finally:
        plt.close(figure)


@pytest.mark.x64
def test_swept_peers_keeps_each_scene_as_it_goes(swept_found, monkeypatch, tmp_path):
    """After each scene but the last, the record so far is written; ``--scenes`` picks the
    full run's scenes by number and refuses one that is not there."""
    monkeypatch.setattr(swept_peers, "run_scene", lambda *_: swept_found["data"]["runs"])
    scenes = swept_peers.FULL_SCENES
    args = argparse.Namespace(quick=False, out=str(tmp_path), repeats=1, slow=None, scenes="1,6")
    found = swept_peers.run(args)
    assert len(found["data"]["runs"]) == 2 * len(swept_found["data"]["runs"])
    partial = report.load(tmp_path / "swept_peers.json")
    assert partial["notes"][0] == "Partial: 1 of 2 scenes."
    assert len(partial["data"]["runs"]) == len(swept_found["data"]["runs"])
    assert len(scenes) == 7
    with pytest.raises(ValueError, match="from 1 to 7"):
        swept_peers.run(argparse.Namespace(**{**vars(args), "scenes": "8"}))
