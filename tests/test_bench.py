"""The benchmarks' shared code at tiny sizes: their reference, checker, rows and files.

The timings themselves are not tested (a loaded machine makes any bound
flaky); what is tested is that every answer is checked, and that a wrong
answer is reported as wrong.
"""

import csv
import functools
import pathlib

import numpy as np
import pytest

from benchmarks import peers, swept_peers
from benchmarks.harness import _run, answers
from benchmarks.harness.timing import time_interleaved
from benchmarks.peer_codes import baselines
from jaxcontact import Surface, swept
from jaxcontact._cli import _parser
from jaxcontact.scenes import cutting_scene, paper_scene, rough_die_scene
from tests.oracle import oracle_contact


def _scene_arrays(scene):
    start, end = _run.endpoints(scene.surface)
    return np.asarray(scene.x), start, end


@pytest.mark.x64  # the reference is all_to_all in float64
@pytest.mark.parametrize("build", [lambda: paper_scene(9), lambda: cutting_scene(300, 18.0)])
def test_reference_equals_exact_oracle(build):
    """The reference, searched in chunks of slaves against the segments near each
    chunk, agrees with the exact-fraction oracle, ties included."""
    scene = build()
    x, _, _ = _scene_arrays(scene)
    reference = answers.reference_contact(x, scene.surface, scene.radius, chunk=16)
    exact = oracle_contact(x, scene.surface.nodes, scene.surface.segments, radius=scene.radius)
    np.testing.assert_array_equal(reference.segment, exact.segment)
    np.testing.assert_allclose(reference.gap[exact.found], exact.gap[exact.found], atol=1e-12)


@pytest.mark.x64
def test_reference_gives_a_shared_vertex_to_the_face_the_slave_is_outside_of():
    # Segments 0: (1, 1) -> (0, 0) and 1: (0, 0) -> (1, -1); a convex corner at the origin.
    surface = Surface(np.array([[1.0, 1.0], [0.0, 0.0], [1.0, -1.0]]), np.array([[0, 1], [1, 2]]))
    start, end = _run.endpoints(surface)
    # Equally far from both faces: outside segment 1 only (its normal (-1, -1)/sqrt 2).
    x = np.array([[-0.1, -0.2]])
    distance, gap = answers.evaluate(x, start, end, [1])
    assert gap[0] > 0
    assert answers.reference_contact(x, surface, 1.0).segment.tolist() == [1]


@pytest.mark.x64
def test_compare_reports_every_kind_of_wrong_answer():
    scene = cutting_scene(2_000, 18.0)
    x, start, end = _scene_arrays(scene)
    reference = answers.reference_contact(x, scene.surface, scene.radius)
    assert reference.found.sum() > 5
    right = baselines.numpy_dense(x, start, end, scene.radius)
    assert answers.compare(*right, x, start, end, reference).wrong_segment == 0

    segment, gap, found = (part.copy() for part in right)
    rows = np.flatnonzero(found)
    segment[rows[0]] = (segment[rows[0]] + 5) % len(start)  # a farther segment
    found[rows[1]] = False  # a missed contact
    gap[rows[2]] += 0.01  # a gap error
    far = np.argmax(np.abs(x - start[0]).sum(axis=1))
    segment[far], found[far] = 0, True  # a false contact
    wrong = answers.compare(segment, gap, found, x, start, end, reference)
    assert (wrong.missed, wrong.false, wrong.wrong_segment) == (1, 1, 1)
    assert wrong.max_gap_error >= 0.01
    assert wrong.wrong_by > 0
    assert "1 missed" in answers.describe(wrong) and "1 wrong segment" in answers.describe(wrong)


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


def _path_arrays(scene):
    start, end = _run.endpoints(scene.surface)
    return np.asarray(scene.x_prev), np.asarray(scene.x), start, end


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
        assert float(fields["max_t_error"]) < 1e-5


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
    np.testing.assert_allclose(t, np.asarray(library.t), atol=1e-15)
    assert crossed.tolist() == [True, True, True, True, False, False, True, False]


def test_numba_closest_with_no_slaves():
    pytest.importorskip("numba")
    from benchmarks.peer_codes import numba_grid

    segment, gap, found = numba_grid.closest(
        np.zeros((0, 2), np.float32), np.zeros((1, 2), np.float32), np.ones((1, 2), np.float32), 1
    )
    assert segment.shape == gap.shape == found.shape == (0,) and gap.dtype == np.float32


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
    assert float(fields["max_t_error"]) >= 0.01


@pytest.mark.x64
def test_swept_peer_rows(monkeypatch):
    # The NumPy peer only (CI has no numba or ipctk), and the skip path.
    monkeypatch.setattr(
        swept_peers, "SWEPT_PEERS", {"NumPy dense": swept_peers.SWEPT_PEERS["NumPy dense"]}
    )
    monkeypatch.setattr(swept_peers, "PAIR_BUDGET", 5_000)  # 9,900 pairs: skipped
    kind = swept_peers.QUICK_SCENES[0][0]
    rows = swept_peers.run_scene(kind, 500, (18.0, 19.5), repeats=2, slow_s=60)
    by_method = {row["method"]: row for row in rows}
    assert set(by_method) == {"swept", swept_peers.LIBRARY, swept_peers.COMPACT, "NumPy dense"}
    assert by_method["NumPy dense"]["note"].startswith("skipped")
    for method in ("swept", swept_peers.LIBRARY, swept_peers.COMPACT):
        row = by_method[method]
        assert row["median_ms"] > 0 and row["runs"] == 2
        assert row["missed"] == row["false"] == row["wrong_segment"] == 0, row
    assert by_method[swept_peers.LIBRARY]["ratio"] == "1.00"


def test_a_missing_peer_is_reported_not_raised(monkeypatch):
    monkeypatch.setitem(baselines.PEERS, "nowhere", ("no_such_module_xyz", None))
    assert baselines.unavailable("nowhere").startswith("not installed")


def test_peer_rows_and_csv(tmp_path, monkeypatch):
    # Only the dense NumPy peer and the skip path, to stay fast.
    monkeypatch.setattr(
        baselines, "PEERS", {k: baselines.PEERS[k] for k in ("NumPy dense", "NumPy box-then-dense")}
    )
    monkeypatch.setattr(peers, "PAIR_BUDGET", 5_000)  # dense (19,840 pairs) skipped, box not
    rows = peers.run_scene("cutting, tool in (x_tip=18)", 1_000, 18.0, repeats=2, slow_s=60)
    by_method = {row["method"]: row for row in rows}
    ours = {"all_to_all", peers.LIBRARY, peers.COMPACT}
    assert set(by_method) == ours | {"NumPy dense", "NumPy box-then-dense"}
    assert by_method["NumPy dense"]["note"].startswith("skipped")
    assert by_method["NumPy dense"]["median_ms"] == ""
    for method in (*ours, "NumPy box-then-dense"):
        row = by_method[method]
        assert row["median_ms"] > 0 and row["runs"] == 2
        assert row["missed"] == row["false"] == row["wrong_segment"] == 0, row
    assert by_method[peers.LIBRARY]["ratio"] == "1.00"
    _run.write(str(tmp_path), "peers", rows, "text")
    with open(tmp_path / "peers.csv") as stream:
        written = list(csv.DictReader(stream))
    assert len(written) == len(rows) == 5 and list(written[0]) == list(_run.COLUMNS)


def test_time_interleaved_runs_each_call_round_robin():
    order = []

    def tagged(tag, x):
        order.append(tag)
        return x

    x = np.zeros(3)
    calls = {
        "a": (functools.partial(tagged, "a"), (x,)),
        "b": (functools.partial(tagged, "b"), (x,)),
    }
    timings = time_interleaved(calls, repeats=3, warmup=0)
    assert list(timings) == ["a", "b"] and timings["b"].runs == 3
    assert order == ["a", "b"] + ["a", "b"] * 3  # first calls, then three rounds


def test_cli_registers_bench():
    args = _parser().parse_args(["bench", "--quick", "--out", "somewhere"])
    assert args.quick and args.out == "somewhere" and callable(args.run)


def _benchmark_module(name):
    """``benchmarks/<name>.py``, a script rather than a package module, loaded from its path."""
    import importlib.util

    path = pathlib.Path(__file__).resolve().parent.parent / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_results_assembles_stored_sections(tmp_path):
    results = _benchmark_module("results")
    stored = tmp_path / "results"
    stored.mkdir()
    (stored / "peers.md").write_text("## Peers\n\ntable\n\n![peers.png](peers.png)\n")
    (stored / "bucket.md").write_text("```\n# bucket.py: a comment line\n```\n")
    notes = tmp_path / "notes.md"
    notes.write_text("Hand-written headline.")
    output = tmp_path / "RESULTS.md"
    results.assemble(str(stored), str(output), str(notes))
    text = output.read_text()
    assert text.startswith("# Benchmark results\n\n- Machine:")
    assert "Hand-written headline." in text
    assert "#### Peers" in text and "![peers.png](results/peers.png)" in text
    assert "\n# bucket.py: a comment line\n" in text  # code blocks are left as they are
    assert "Not run yet: `python benchmarks/results.py --sections dense`" in text
    if not (pathlib.Path(results.HERE) / "stability.py").exists():
        assert "`benchmarks/stability.py` is not in this checkout." in text


@pytest.mark.x64
def test_sizes_too_small_are_counted_as_missed_contacts():
    from benchmarks import time_vs_error
    from jaxcontact._pipeline.sizes import measure

    scene = cutting_scene(2_000, 18.0)
    x, start, end = _scene_arrays(scene)
    reference = answers.reference_contact(x, scene.surface, scene.radius)
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    right = _run.sized_contact(scene.radius, sizes)(scene.x, scene.surface)
    assert not bool(right.overflow)
    assert _run.check(right, x, start, end, reference).missed == 0
    small = time_vs_error._shrunk(sizes, block_capacity=0.25)
    assert small.block_capacity == max(1, int(sizes.block_capacity * 0.25))
    contact = _run.sized_contact(scene.radius, small)(scene.x, scene.surface)
    mismatch = _run.check(contact, x, start, end, reference)
    assert bool(contact.overflow) and mismatch.missed > 0


@pytest.mark.x64  # the reference is all_to_all in float64
def test_paper_test1_rows():
    from benchmarks import paper_tests

    rows = paper_tests.run_test1((1,), repeats=1)
    assert [row["method"] for row in rows] == list(paper_tests.METHODS)
    assert all(row["nodes"] == 4 and row["median_ms"] > 0 for row in rows)
    assert rows[0]["note"] == "same contacts"  # all_to_all against itself in float64
    assert "0 rows differ" in rows[2]["note"]  # swept against the float64 brute force
    assert "0 rows differ" in rows[3]["note"]  # bucket_swept (sized), likewise
    assert "| all_to_all |" in paper_tests.averages(rows)
