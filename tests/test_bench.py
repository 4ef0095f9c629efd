"""The benchmarks' shared code at tiny sizes: their reference, checker, rows and files.

The timings themselves are not tested (a loaded machine makes any bound
flaky); what is tested is that every answer is checked, and that a wrong
answer is reported as wrong.
"""

import functools

import numpy as np
import pytest

from benchmarks.harness import _run, answers
from benchmarks.harness.timing import time_interleaved
from benchmarks.peer_codes import baselines
from jaxcontact import Surface
from jaxcontact._cli import _parser
from jaxcontact.scenes import cutting_scene, paper_scene
from tests.support.oracle import oracle_contact
from tests.support.tolerances import FLOAT64_ATOL


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
    np.testing.assert_allclose(
        reference.gap[exact.found], exact.gap[exact.found], atol=FLOAT64_ATOL
    )


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
