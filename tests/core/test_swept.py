"""Each special case of docs/contract.md for ``swept``, checked against the brute-force oracle.

The random scenes, masks, padding and offsets run for both queries in tests/core/test_oracle.py,
through this file's ``checked_scene``.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from tests.support import helpers

# All of this file runs again with x64 off (tests/test_x64_off.py).
pytestmark = pytest.mark.x64_off

# Jitted once at module level so scenes of equal shapes share one compilation.
swept = jax.jit(jaxcontact.swept)

DTYPES = pytest.mark.parametrize("dtype", helpers.FLOAT_DTYPES, ids=lambda d: np.dtype(d).name)

# A vertical wall from (1, 0) to (1, 2).
WALL_NODES, WALL_SEGMENTS = [[1.0, 0.0], [1.0, 2.0]], [[0, 1]]


def checked_scene(scene: helpers.Scene, **tolerance):
    """Runs ``swept`` on ``scene`` as it is, checks every field against the oracle."""
    crossing = swept(
        jnp.asarray(scene.x_prev),
        jnp.asarray(scene.x),
        helpers.surface_of(scene),
        mask=helpers.slave_mask_of(scene),
    )
    expected = helpers.crossing_oracle(scene)
    helpers.assert_crossing_matches(crossing, expected, scene.x.dtype, **tolerance)
    return crossing


def checked_crossing(x_prev, x, nodes, segments, *, dtype=helpers.FLOAT):
    """Runs ``swept`` on a hand-made scene (padded to ``helpers.CAPACITY``),
    checks every field against the oracle and returns the rows of the real slaves."""
    crossing = checked_scene(helpers.padded_scene(x_prev, x, nodes, segments, dtype=dtype))
    num_slaves = len(np.asarray(x).reshape(-1, 2))
    assert not crossing.crossed[num_slaves:].any()
    return jax.tree.map(lambda field: field[:num_slaves] if field.ndim else field, crossing)


def assert_crossings(crossing, segment, t, point):
    """Exactly these rows: ``t`` and ``point`` rounded to the crossing's dtype."""
    np.testing.assert_array_equal(crossing.segment, segment)
    np.testing.assert_array_equal(crossing.crossed, np.asarray(segment) >= 0)
    np.testing.assert_array_equal(crossing.t, np.asarray(t, crossing.t.dtype))
    np.testing.assert_array_equal(crossing.point, np.asarray(point, crossing.point.dtype))


@DTYPES
def test_path_through_segment_interior_crosses_both_ways(dtype):
    crossing = checked_crossing(
        [[0.0, 1.0], [4.0, 1.0]], [[4.0, 1.0], [0.0, 1.0]], WALL_NODES, WALL_SEGMENTS, dtype=dtype
    )
    assert_crossings(crossing, [0, 0], [0.25, 0.75], [[1.0, 1.0], [1.0, 1.0]])


@DTYPES
def test_path_touching_an_end_point_crosses(dtype):
    # Grazing the top end, passing through the bottom end diagonally, and
    # arriving exactly on the bottom end at t = 1.
    crossing = checked_crossing(
        [[0.0, 2.0], [0.0, -1.0], [0.0, 0.0]],
        [[2.0, 2.0], [2.0, 1.0], [1.0, 0.0]],
        WALL_NODES,
        WALL_SEGMENTS,
        dtype=dtype,
    )
    assert_crossings(crossing, [0, 0, 0], [0.5, 0.5, 1.0], [[1.0, 2.0], [1.0, 0.0], [1.0, 0.0]])


@DTYPES
def test_path_ending_or_starting_exactly_on_segment_crosses(dtype):
    crossing = checked_crossing(
        [[0.0, 1.0], [1.0, 1.5]], [[1.0, 1.0], [3.0, 1.5]], WALL_NODES, WALL_SEGMENTS, dtype=dtype
    )
    assert_crossings(crossing, [0, 0], [1.0, 0.0], [[1.0, 1.0], [1.0, 1.5]])


def test_paths_that_miss_do_not_cross():
    # Parallel off the line (twice), passing beyond the end, stopping short.
    crossing = checked_crossing(
        [[0.0, 0.0], [2.0, -1.0], [0.0, 3.0], [0.0, 1.0]],
        [[0.0, 2.0], [2.0, 5.0], [2.0, 3.0], [0.5, 1.0]],
        WALL_NODES,
        WALL_SEGMENTS,
    )
    assert not crossing.crossed.any()
    np.testing.assert_array_equal(crossing.segment, [-1] * 4)


@DTYPES
def test_collinear_path_crosses_at_first_time_inside(dtype):
    # Along the wall's own line: entering from below, entering from above,
    # starting inside, arriving on the end point at t = 1.
    crossing = checked_crossing(
        [[1.0, -1.0], [1.0, 3.0], [1.0, 0.5], [1.0, -2.0]],
        [[1.0, 3.0], [1.0, -1.0], [1.0, 5.0], [1.0, 0.0]],
        WALL_NODES,
        WALL_SEGMENTS,
        dtype=dtype,
    )
    assert_crossings(
        crossing,
        [0, 0, 0, 0],
        [0.25, 0.25, 0.0, 1.0],
        [[1.0, 0.0], [1.0, 2.0], [1.0, 0.5], [1.0, 0.0]],
    )


def test_collinear_path_along_a_diagonal_crosses_at_first_time_inside():
    crossing = checked_crossing(
        [[-1.0, -1.0], [3.0, 3.0]], [[3.0, 3.0], [2.5, 2.5]], [[0.0, 0.0], [2.0, 2.0]], [[0, 1]]
    )
    assert_crossings(crossing, [0, -1], [0.25, 0.0], [[0.0, 0.0], [0.0, 0.0]])


def test_collinear_path_outside_the_segment_does_not_cross():
    crossing = checked_crossing(
        [[1.0, 3.0], [1.0, -1.0], [1.0, 5.0]],
        [[1.0, 5.0], [1.0, -0.5], [1.0, 2.5]],
        WALL_NODES,
        WALL_SEGMENTS,
    )
    assert not crossing.crossed.any()


def test_zero_motion_crosses_only_on_the_segment():
    # On the interior, on an end point, off the line, on the line beyond the end.
    still = [[1.0, 1.0], [1.0, 2.0], [0.0, 1.0], [1.0, 3.0]]
    crossing = checked_crossing(still, still, WALL_NODES, WALL_SEGMENTS)
    assert_crossings(
        crossing, [0, 0, -1, -1], [0.0] * 4, [[1.0, 1.0], [1.0, 2.0], [0.0, 0.0], [0.0, 0.0]]
    )


def test_earliest_crossing_wins_among_several_segments():
    # Walls at x = 2, 3, 1 (indices 0, 1, 2): moving right meets x = 1 first,
    # moving left meets x = 3 first.
    nodes = [[2.0, 0.0], [2.0, 2.0], [3.0, 0.0], [3.0, 2.0], [1.0, 0.0], [1.0, 2.0]]
    crossing = checked_crossing(
        [[0.0, 1.0], [4.0, 1.0], [2.5, 1.0]],
        [[4.0, 1.0], [0.0, 1.0], [0.0, 1.0]],
        nodes,
        [[0, 1], [2, 3], [4, 5]],
    )
    assert_crossings(crossing, [2, 1, 0], [0.25, 0.25, 0.2], [[1.0, 1.0], [3.0, 1.0], [2.0, 1.0]])


@DTYPES
def test_simultaneous_crossings_tie_to_lower_index(dtype):
    # Through the vertex (1, 1) shared by segments 0 and 1 (listed so that the
    # vertex is the start of 0 and the end of 1), and through two overlapping
    # walls 2 and 3 at the same time.
    nodes = [[1.0, 1.0], [2.0, 2.0], [0.0, 2.0], [3.0, 0.0], [3.0, 2.0], [3.0, 0.5], [3.0, 1.5]]
    crossing = checked_crossing(
        [[0.0, 1.5], [2.5, 1.0]],
        [[2.0, 0.5], [4.5, 1.0]],
        nodes,
        [[0, 1], [2, 0], [5, 6], [3, 4]],
        dtype=dtype,
    )
    assert_crossings(crossing, [0, 2], [0.5, 0.25], [[1.0, 1.0], [3.0, 1.0]])


# Regression (found by this suite): a path through the vertex shared by two
# segments meets both at the same t exactly, but each t used to come from
# orientations relative to that segment's own start, so the roundings differed
# and the higher index could win by one ulp of t. Where the path's line runs
# exactly through an end point, t now comes from that point alone.
def test_path_through_a_shared_vertex_mid_path_ties_to_lower_index():
    nodes = [[0.1, 0.9], [0.3, 0.5], [1.1, 0.1]]
    crossing = checked_crossing([[-0.3, 0.5]], [[2.7, 0.5]], nodes, [[0, 1], [1, 2]])
    np.testing.assert_array_equal(crossing.segment, [0])


def test_zero_length_segment_is_ignored():
    # The path runs through a zero-length segment (index 0) before the wall.
    nodes = [[1.0, 1.0], [1.0, 1.0], [3.0, 0.0], [3.0, 2.0]]
    crossing = checked_crossing([[0.0, 1.0]], [[4.0, 1.0]], nodes, [[0, 1], [2, 3]])
    assert_crossings(crossing, [1], [0.75], [[3.0, 1.0]])
