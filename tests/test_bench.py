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


def test_size_scaling_rows_slopes_and_figure(tmp_path, monkeypatch):
    """One tiny rough die through the library's two programs (all_to_all over its pair
    budget), then a sweep made up from its rows: the slopes, tables, CSV and figure."""
    scaling = _benchmark_module("size_scaling")
    monkeypatch.setattr(scaling, "PAIR_BUDGET", 1_000)
    names = (scaling.LIBRARY, scaling.SEARCH, scaling.DENSE)
    rows = scaling.run_scene(400, 40, repeats=2, slow_s=60, names=names)
    by_method = {row["method"]: row for row in rows}
    assert by_method[scaling.DENSE]["note"].startswith("not run: N*M too large")
    for name in (scaling.LIBRARY, scaling.SEARCH):
        row = by_method[name]
        assert row["median_ms"] > 0 and row["runs"] == 2 and row["compile_s"] > 0
        assert row["temp_mib"] > 0 and row["out_mib"] > 0  # XLA's account of the program
        assert row["missed"] == row["false"] == row["wrong_segment"] == 0, row
    assert "found again 0 times" in by_method[scaling.SEARCH]["note"]  # the state was reused

    def grown(by_nodes, by_segments):  # the same rows at a larger size, time as size**0.75
        factor = (by_nodes * by_segments) ** 0.75
        return [
            {
                **row,
                "nodes": row["nodes"] * by_nodes,
                "segments": row["segments"] * by_segments,
                "median_ms": row["median_ms"] and row["median_ms"] * factor,
            }
            for row in rows
        ]

    by_scene = {(400, 40): rows, (4_000, 40): grown(10, 1), (40_000, 40): grown(100, 1)}
    by_scene[400, 400] = grown(1, 10)
    sweeps = scaling.Sweeps((400, 4_000, 40_000), 40, (40, 400), 400)
    text = scaling.report(by_scene, sweeps, names, str(tmp_path), quick=True, elapsed_s=1.0)
    assert f"| {scaling.LIBRARY} | 0.75 | 0.75 | 0.75 | 0.75 | 3, 2 | 0.00 |" in text  # memory kept
    assert f"| {scaling.DENSE} | — | — | — | — | 0, 0 | — |" in text
    assert (tmp_path / "size_scaling.csv").exists()
    if _run.pyplot(str(tmp_path)) is not None:
        assert (tmp_path / "size_scaling.png").exists()


def test_compile_ops_sorts_a_programs_kernels_by_kind():
    """benchmarks/compile_ops.py's census: a reduction, a gather and a sort, each found."""
    import jax
    import jax.numpy as jnp

    compile_ops = _benchmark_module("compile_ops")
    x, index = np.linspace(0.0, 1.0, 64, dtype=np.float32), np.arange(64, dtype=np.int32)[::-1]

    def program(x, index):
        return jnp.max(x * 2.0), x[index] * 3.0, jnp.sort(x[:40])

    text = jax.jit(program).lower(x, index).compile().as_text()
    found, bodies = compile_ops.kernel_lines(text)
    kinds = {compile_ops.kind_of(line, bodies) for line in found}
    assert {"gather + elementwise", "sort"} <= kinds, kinds
    assert kinds & {"reduction to a scalar", compile_ops.WINDOW}, kinds
