"""Continuity: slaves sliding along and across a master outline, and segment order.

The signed gap of a closed, counter-clockwise outline is the signed distance
to it: 1-Lipschitz in the slave's position. So between two samples ``dx``
apart it may change by at most ``|dx|`` plus the rounding of both (the gap
bound of tests/exact_checks.py). Every sample is also checked against the
exact oracle there (``check_contact``), so the chosen segment changes only
where the oracle's does, or at a tie to within that bound.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import Sizes, Surface
from tests.support.exact_checks import ULPS, check_contact
from tests.support.helpers import Scene, sized_bucket_sort
from tests.support.tolerances import CORNER_OFFSET_ATOL, FLOAT32_RTOL

# An L, counter-clockwise: convex corners and one concave corner, at (1, 1).
L_NODES = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], np.float64)
L_SEGMENTS = np.array([[k, (k + 1) % 6] for k in range(6)], np.int32)
# A sharp tool tip (convex, 20 degrees) above a shelf: a blind spot below the tip.
TIP_NODES = np.array([[-1, 2], [0, 0], [0.364, 1], [3, 1], [3, 3], [-1, 3]], np.float64)

SAMPLES = 256  # per path; samples 1/64 apart, so vertices are hit exactly
DTYPES = pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["float32", "float64"])


def _paths():
    """f[4 * SAMPLES, 2]: lines through and along the corners, 1/128 steps."""
    s = -1 + np.arange(SAMPLES) / 64
    return np.concatenate(
        [
            np.stack([s, np.full_like(s, 1.0)], -1),  # along the face through the concave corner
            np.stack([np.full_like(s, 1.0), s], -1),  # along the other face through it
            np.stack([s, s], -1),  # the concave corner's bisector
            np.stack([s, 2 - s], -1),  # across the corners (2, 0) and (0, 2)
        ]
    )


PATHS = _paths()
STEPS = np.linalg.norm(np.diff(PATHS.reshape(4, SAMPLES, 2), axis=1), axis=-1)  # f64[4, S - 1]


def _sizes(use_cells):
    return Sizes(
        num_slaves=len(PATHS),
        block_size=32,
        block_capacity=len(PATHS) // 32,
        use_cells=use_cells,
        grid_shape=(8, 8) if use_cells else (1, 1),
        cell_size=0.5 if use_cells else 0.0,
        span=(8, 8) if use_cells else (1, 1),
        cell_capacity=6 if use_cells else 1,
    )


DETECTORS = {
    "all_to_all": jax.jit(lambda x, s: jaxcontact.all_to_all(x, s, radius=4.0)),
    "bucket_sort": jax.jit(lambda x, s: sized_bucket_sort(x, s, radius=4.0, sizes=_sizes(False))),
    "bucket_sort_cells": jax.jit(
        lambda x, s: sized_bucket_sort(x, s, radius=4.0, sizes=_sizes(True))
    ),
}
NAMES = pytest.mark.parametrize("name", sorted(DETECTORS))


def _scene(nodes, dtype, segments=L_SEGMENTS):
    return Scene(
        x_prev=PATHS.astype(dtype),
        x=PATHS.astype(dtype),
        nodes=nodes.astype(dtype),
        segments=segments,
        seg_mask=np.ones(len(segments), bool),
        slave_mask=None,
        radius=4.0,
    )


# Every outline is padded to the L's 6 nodes and 6 segments, the padding
# masked after the real ones, so that each detector compiles once per dtype.
CAPACITY = len(L_SEGMENTS)


def _detect(name, scene):
    segments = np.asarray(scene.segments, np.int32)
    nodes = np.zeros((CAPACITY, 2), scene.nodes.dtype)
    nodes[: len(scene.nodes)] = scene.nodes
    padded = np.zeros((CAPACITY, 2), np.int32)
    padded[: len(segments)] = segments
    mask = np.arange(CAPACITY) < len(segments)
    surface = Surface(jnp.asarray(nodes), jnp.asarray(padded), jnp.asarray(mask))
    return DETECTORS[name](jnp.asarray(scene.x), surface)


@DTYPES
@NAMES
@pytest.mark.parametrize("outline", ["L", "tip"])
def test_sliding_through_corners_gives_a_continuous_gap(outline, name, dtype):
    scene = _scene(L_NODES if outline == "L" else TIP_NODES, dtype)
    contact = _detect(name, scene)
    check_contact(contact, scene, dtype)
    gap = np.asarray(contact.gap, np.float64).reshape(4, SAMPLES)
    assert np.asarray(contact.found).all()
    # |gap| <= 4 and every coordinate is a few units: the rounding of each
    # gap is within ULPS eps times the 8 units of the scene's extent.
    tol = 2 * ULPS * float(np.finfo(dtype).eps) * 8
    jumps = np.abs(np.diff(gap, axis=-1))
    excess = jumps - STEPS
    assert excess.max() <= tol, (excess.max(), np.unravel_index(excess.argmax(), jumps.shape))


@DTYPES
@NAMES
def test_slave_on_a_face_extension_beyond_a_concave_corner_is_inside(name, dtype):
    # Regression: a slave on the extension of the face (2, 1) -> (1, 1) beyond
    # the concave corner (1, 1) has normal distance exactly 0 to that face and
    # -0.2 to the face (1, 1) -> (1, 2). The tie rule took the face with the
    # larger, zero, normal distance and "zero counts positive" reported +0.2:
    # outside, where the slaves just above and below are at -0.2 (inside).
    scene = _scene(L_NODES, dtype)
    scene = scene._replace(
        x=np.array([[0.8, 1.0 - 2**-10], [0.8, 1.0], [0.8, 1.0 + 2**-10]] * 4, dtype)
    )
    scene = scene._replace(x=np.resize(scene.x, PATHS.shape).astype(dtype))
    gap = np.asarray(_detect(name, scene).gap[:3])
    np.testing.assert_allclose(gap, [-0.2, -0.2, -0.2], atol=CORNER_OFFSET_ATOL)
    assert (gap < 0).all()


@DTYPES
@NAMES
@pytest.mark.parametrize("seed", [0, 1])
def test_segment_order_changes_nothing_but_exact_ties(name, dtype, seed):
    scene = _scene(TIP_NODES if seed else L_NODES, dtype)
    plain = _detect(name, scene)
    order = np.random.default_rng(seed).permutation(len(L_SEGMENTS))
    shuffled = _detect(name, scene._replace(segments=L_SEGMENTS[order]))
    # Each real segment keeps its ends, so the chosen pair is evaluated by the
    # same kernel on the same numbers: equal rows are bit-identical.
    segment = order[np.asarray(shuffled.segment)]
    same = segment == np.asarray(plain.segment)
    for field in ("gap", "xi", "point", "normal"):
        np.testing.assert_array_equal(
            np.asarray(getattr(shuffled, field))[same], np.asarray(getattr(plain, field))[same]
        )
    # Rows that differ: an exact tie (the tie rule's last resort is the index),
    # with the same gap.
    np.testing.assert_array_equal(np.asarray(shuffled.gap), np.asarray(plain.gap))
    check_contact(shuffled, scene._replace(segments=L_SEGMENTS[order]), dtype)


@NAMES
def test_slave_beyond_the_tip_of_a_spike_is_outside(name):
    # Found by the property tests (while fixing the case above): a spike out
    # and back, (0, 0) -> (0.375, 1.875) -> (0, 0), and a float32 slave in line
    # beyond its tip. Both faces' normal distances are zero to within rounding
    # and of opposite signs: either face may be chosen, but the gap must be
    # positive (the larger normal distance is >= 0), whichever it is.
    scene = _scene(np.array([[0, 0], [0.375, 1.875], [0, 0]]), np.float32, [[0, 1], [1, 2]])
    scene = scene._replace(x=np.resize(np.array([[0.91143656, 4.557183]], np.float32), PATHS.shape))
    gap = np.asarray(_detect(name, scene).gap)
    np.testing.assert_allclose(gap, 2.7353005, rtol=FLOAT32_RTOL)


@DTYPES
@NAMES
def test_slaves_inside_a_sharp_concave_notch_are_inside(name, dtype):
    # Regression: at a concave corner turning by more than 90 degrees, part of
    # the region whose closest point is the vertex lies inside one face and
    # outside the other. The master is locally the union of the two faces'
    # insides there, so such a slave is inside; the old rule (larger normal
    # distance wins) reported it outside at +|x - v|.
    nodes = np.array([[-2.0, 0.0], [0.0, 0.0], [-3.0, -1.0]])  # +x, then a right turn of 162 deg
    scene = _scene(nodes, dtype, [[0, 1], [1, 2]])
    slaves = np.array([[1.0, 2.0], [1.0, -0.5], [0.5, 1.0], [1.0, 0.0]])
    scene = scene._replace(x=np.resize(slaves, PATHS.shape).astype(dtype))
    contact = _detect(name, scene)
    check_contact(contact, scene, dtype)
    distance = np.linalg.norm(slaves, axis=-1)
    np.testing.assert_allclose(contact.gap[:4], -distance, rtol=FLOAT32_RTOL)
    assert contact.active[:4].all()


@pytest.mark.x64
@NAMES
def test_slaves_beyond_spike_tips_far_from_the_origin_are_outside(name):
    # Regression, found by the property tests: at a spike O -> P -> O the two
    # faces are antiparallel, the corner is straight back (convex) and a slave
    # beyond P is outside both: gap > 0. Computed as u0 v1 - u1 v0, the turn
    # cross(d, -d) came out as -1e-16 (a fused multiply-add) and made the
    # corner concave for about half of such slaves; its sign now comes from
    # comparing the two products, which rounding cannot reorder.
    rng = np.random.default_rng(0)
    for _ in range(4):
        origin = np.array([1024.0, 1024.0])
        tip = origin + rng.uniform(-3, 3, 2)
        along = (tip - origin) / np.linalg.norm(tip - origin)
        across = np.array([along[1], -along[0]])
        scene = _scene(np.stack([origin, tip, origin]), np.float64, [[0, 1], [1, 2]])
        offsets = rng.uniform(-1, 1, (len(PATHS), 1)) * 1e-13
        scene = scene._replace(x=tip + 1e-3 * along + offsets * across)
        contact = _detect(name, scene)
        assert (np.asarray(contact.gap) > 0).all()
        check_contact(jax.tree.map(lambda v: v[:64] if v.ndim else v, contact),
                      scene._replace(x=scene.x[:64]), np.float64)  # fmt: skip
