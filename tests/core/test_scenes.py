"""The reference scenes: shapes, the cutting tool's outline, the paper scene's crossings."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact.scenes import cutting_scene, cutting_tool_outline, paper_scene, rough_die_scene
from tests.support import helpers
from tests.support.tolerances import FLOAT32_SUM_ATOL, FLOAT64_RTOL

DTYPES = pytest.mark.parametrize("dtype", helpers.FLOAT_DTYPES, ids=lambda d: np.dtype(d).name)


def outline_of(surface) -> np.ndarray:
    """f64[M, 2]: the start point of each segment, in segment order."""
    return np.asarray(surface.nodes, np.float64)[np.asarray(surface.segments)[:, 0]]


def signed_area(polygon: np.ndarray) -> float:
    """Shoelace formula: positive for a counter-clockwise polygon."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


@DTYPES
@pytest.mark.parametrize("n", [1, 4])
def test_paper_scene_shapes(n, dtype):
    scene = paper_scene(n, length=10.0, d=5.0, dtype=dtype)
    assert scene.x.shape == scene.x_prev.shape == ((n + 1) ** 2, 2)
    assert scene.surface.nodes.shape == (3, 2) and scene.surface.segments.shape == (2, 2)
    assert scene.x.dtype == scene.x_prev.dtype == scene.surface.nodes.dtype == np.dtype(dtype)
    assert scene.radius == 1.0
    x_prev = np.asarray(scene.x_prev, np.float64)
    np.testing.assert_array_equal(x_prev.min(axis=0), [0.0, 0.0])
    np.testing.assert_array_equal(x_prev.max(axis=0), [50.0, 9.0])
    np.testing.assert_allclose(
        np.asarray(scene.x, np.float64) - x_prev, [[5.0, 0.0]] * (n + 1) ** 2
    )


@pytest.mark.parametrize("num_nodes", [8, 100, 999])
def test_cutting_scene_shapes(num_nodes):
    scene = cutting_scene(num_nodes, 18.0, x_tip_prev=18.5)
    # The grid's documented sizing.
    ny = max(2, round(math.sqrt(num_nodes / 4)))
    nx = max(2, round(num_nodes / ny))
    assert scene.x.shape == scene.x_prev.shape == (nx * ny, 2)
    assert scene.surface.segments.shape == (20, 2) and scene.surface.nodes.shape == (20, 2)
    assert scene.radius == 0.1
    # The tool moved by -0.5 in x: seen from it, the nodes were 0.5 further left.
    np.testing.assert_allclose(
        np.asarray(scene.x) - np.asarray(scene.x_prev),
        [[0.5, 0.0]] * (nx * ny),
        atol=FLOAT32_SUM_ATOL,
    )
    assert not np.any(np.asarray(cutting_scene(num_nodes, 18.0).x) - np.asarray(scene.x))


@pytest.mark.x64  # float64 scenes, compared to 1e-12 or exactly
@pytest.mark.parametrize("num_nodes, num_segments", [(80, 4), (1000, 50)])
def test_rough_die_scene_shapes_and_upward_normals(num_nodes, num_segments):
    scene = rough_die_scene(num_nodes, num_segments, dtype=jnp.float64)
    ny = max(2, round(math.sqrt(num_nodes / 40)))
    nx = max(2, round(num_nodes / ny))
    assert scene.x.shape == scene.x_prev.shape == (nx * ny, 2)
    np.testing.assert_array_equal(scene.x, scene.x_prev)
    assert scene.surface.segments.shape == (num_segments, 2)
    assert scene.surface.nodes.shape == (num_segments + 1, 2)
    assert scene.radius == 0.02
    nodes = np.asarray(scene.surface.nodes)
    np.testing.assert_allclose(
        nodes[:, 1], 0.1 * np.sin(2 * np.pi * nodes[:, 0]), atol=FLOAT64_RTOL
    )
    segments = np.asarray(scene.surface.segments)
    tangent = nodes[segments[:, 1]] - nodes[segments[:, 0]]
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=-1)
    assert np.all(normal[:, 1] > np.abs(normal[:, 0]))  # outward normals point up


@pytest.mark.x64  # float64 scenes, compared to 1e-12 or exactly
@pytest.mark.parametrize("x_tip", [2.0, 18.0])
def test_cutting_tool_outline_is_closed_counter_clockwise_with_20_segments(x_tip):
    surface = cutting_scene(100, x_tip, dtype=jnp.float64).surface
    segments = np.asarray(surface.segments)
    assert segments.shape == (20, 2)
    # Closed: each segment starts where the previous one ends, all the way round.
    np.testing.assert_array_equal(segments[:, 0], np.roll(segments[:, 1], 1))
    assert sorted(segments[:, 0]) == list(range(20))
    assert signed_area(outline_of(surface)) > 0
    np.testing.assert_array_equal(outline_of(surface), cutting_tool_outline(x_tip))
    # The tip is rounded: the outline passes within 0.1 of the sharp tip (x_tip, 4).
    nodes = np.asarray(surface.nodes)
    assert np.min(np.hypot(nodes[:, 0] - x_tip, nodes[:, 1] - 4.0)) < 0.1
    assert len(cutting_tool_outline(x_tip, arc_segments=8)) == 12


# The paper's tool: tip T, rake face to R (segment 0), clearance face to C (segment 1).
TIP = np.array([50.9, 7.0])
RAKE_SLOPE = math.tan(math.radians(7))  # dx / dy along the rake face
CLEARANCE_SLOPE = math.tan(math.radians(2))  # dy / dx along the clearance face


def paper_crossings_in_closed_form(x_prev: np.ndarray, x: np.ndarray):
    """``(crossed, segment, t)`` of horizontal paths ``x_prev -> x`` against the paper's tool.

    A path at height y from x0 to x1 meets the rake face (y in [7, 17]) at
    x_r = 50.9 + (y - 7) tan 7 deg, and the clearance face (y in [7, 7 + 10 tan 2 deg])
    at x_c = 50.9 + (y - 7) / tan 2 deg. For y >= 7, x_r <= x_c (equal at the tip),
    so moving in +x a path that meets the rake meets it first or together.
    """
    x0, x1, y = x_prev[:, 0], x[:, 0], x_prev[:, 1]
    np.testing.assert_array_equal(x[:, 1], y)  # horizontal paths
    x_rake = TIP[0] + (y - TIP[1]) * RAKE_SLOPE
    x_clearance = TIP[0] + (y - TIP[1]) / CLEARANCE_SLOPE
    meets_rake = (y >= 7) & (y <= 17) & (x0 <= x_rake) & (x_rake <= x1)
    meets_clearance = (y >= 7) & (y <= 7 + 10 * CLEARANCE_SLOPE)
    meets_clearance &= (x0 <= x_clearance) & (x_clearance <= x1)
    crossed = meets_rake | meets_clearance
    segment = np.where(meets_rake, 0, np.where(meets_clearance, 1, -1))
    x_hit = np.where(meets_rake, x_rake, x_clearance)
    t = np.where(crossed, (x_hit - x0) / (x1 - x0), 0.0)
    # Well posed: no path ends within 1e-3 of a face (so the float32 rounding of
    # the scene cannot flip a decision), and no path passes within 1e-3 of the
    # tip's height unless it is exactly at it.
    band = (y >= 7) & (y <= 17)
    assert np.min(np.abs(np.stack([x_rake - x0, x_rake - x1])[:, band]), initial=1) > 1e-3
    assert np.all((y == 7) | (np.abs(y - 7) > 1e-3))
    return crossed, segment, t


def paper_crossings(n, dtype):
    """swept on the paper's scene, the exact oracle's answer on the same
    (rounded) arrays, and the closed form of the paper's geometry."""
    scene = paper_scene(n, length=10.0, d=5.0, dtype=dtype)
    crossing = jax.jit(jaxcontact.swept)(scene.x_prev, scene.x, scene.surface)
    x_prev, x = np.asarray(scene.x_prev, np.float64), np.asarray(scene.x, np.float64)
    surface = scene.surface
    expected = helpers.crossing_oracle(
        helpers.Scene(
            np.asarray(scene.x_prev), np.asarray(scene.x), np.asarray(surface.nodes),
            np.asarray(surface.segments), None, None, scene.radius,
        )
    )  # fmt: skip
    return crossing, expected, paper_crossings_in_closed_form(x_prev, x)


@DTYPES
@pytest.mark.parametrize("n", [30, 99])
def test_paper_scene_crossings_match_closed_form(n, dtype):
    # The detector against the oracle; the oracle, on the rounded scene,
    # against the paper's geometry in closed form.
    crossing, expected, (crossed, _, t) = paper_crossings(n, dtype)
    np.testing.assert_array_equal(crossing.crossed, expected.crossed)
    np.testing.assert_array_equal(expected.crossed, crossed)
    assert crossed.sum() > 10
    # t is 1 / |path| of the tool's size 10; the float32 tool nodes are rounded
    # near 50, which moves a face by ~1 ulp of 50 (< 8 ulps of 10).
    atol = helpers.local_atol(dtype, 10.0)
    np.testing.assert_allclose(expected.t, t, rtol=0, atol=atol)
    np.testing.assert_allclose(crossing.t, expected.t, rtol=0, atol=atol)
    atol = helpers.local_atol(dtype, 10.0) * 5 + helpers.coordinate_ulp(dtype, 50.0)
    np.testing.assert_allclose(crossing.point, expected.point, rtol=0, atol=atol)


@DTYPES
# At n = 99 the grid has a row exactly at the tip's height y = 7: those paths
# meet both faces at the tip, at the same t, and the tie goes to the rake face.
# (A regression test: this once went to the clearance face.)
@pytest.mark.parametrize("n", [30, 99])
def test_paper_scene_crossings_are_on_the_rake_face_where_it_is_met_first(n, dtype):
    crossing, expected, (crossed, segment, _) = paper_crossings(n, dtype)
    assert np.all(segment[crossed] == 0)  # the closed form: the rake is always met first
    np.testing.assert_array_equal(expected.segment, segment)
    np.testing.assert_array_equal(crossing.segment, expected.segment)
