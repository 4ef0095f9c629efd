"""Smooth normals (``normals=Smooth(corner)``): continuous over a faceted curve, sharp at corners.

One outline serves every test: a "D", counter-clockwise, whose right half
is a unit semicircle faceted into 24 segments (the outline turns by 7.5
degrees at each inner arc vertex, 3.75 degrees where the arc meets the
straight back) and whose back has two 90 degree corners. Every call of a
detector uses 400 slaves, so the tests share their compiled programs.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from jaxcontact import Search, Smooth, Surface, all_to_all, bucket_sort
from jaxcontact.forces import penalty
from tests.support.helpers import FLOAT, assert_same_contact, local_atol

TURN = 7.5  # degrees: the turn at each inner vertex of the arc
ARC = 24  # arc segments: 0..23; then the top (24), the back (25), the bottom (26), padding
RADIUS = 0.3
DEPTH = 0.01  # the sliding slaves run this far inside the circle
STEP = 0.5  # degrees between consecutive sliding slaves
NUM_SLAVES = 400


def d_outline(dtype=FLOAT) -> Surface:
    angle = np.radians(-90 + TURN * np.arange(ARC + 1))
    arc = np.stack([np.cos(angle), np.sin(angle)], -1)
    arc[0], arc[-1] = (0, -1), (0, 1)  # exact: the vertex at (1, 0) is exact too
    nodes = np.concatenate([arc, [[-1.0, 1.0], [-1.0, -1.0]]])
    start = np.arange(len(nodes))
    segments = np.stack([start, (start + 1) % len(nodes)], -1).astype(np.int32)
    # Padding: a masked segment of zero length at an arc node, which must
    # neither join that node's normal nor give a gradient NaN (0 / 0).
    segments = np.concatenate([segments, [[3, 3]]]).astype(np.int32)
    mask = np.arange(len(segments)) < len(nodes)
    return Surface(jnp.asarray(nodes, dtype), jnp.asarray(segments), jnp.asarray(mask))


SURFACE = d_outline()
# Sliding slaves: 320 along the arc from -80 to 79.5 degrees (crossing 21 of
# its vertices, all on inner facets 1..22), then 80 across the diagonal of
# the 90 degree corner at (-1, 1), from the top face's side to the back's.
ARC_ANGLES = np.radians(-80 + STEP * np.arange(320))
_ALONG = np.linspace(-0.02, 0.02, 80)[::-1]
SLIDING = np.concatenate(
    [
        (1 - DEPTH) * np.stack([np.cos(ARC_ANGLES), np.sin(ARC_ANGLES)], -1),
        np.stack([-0.97 + _ALONG, 0.97 + _ALONG], -1),
    ]
).astype(FLOAT)
ON_ARC = slice(0, 320)
AT_CORNER = slice(320, 400)
# Slaves scattered over the D and around it.
SCATTERED = np.random.default_rng(0).uniform(-1.3, 1.3, (NUM_SLAVES, 2)).astype(FLOAT)


SMOOTH = Smooth(corner=45.0)  # the default corner


def contact_of(x, normals=SMOOTH):
    return all_to_all(jnp.asarray(x), SURFACE, radius=RADIUS, normals=normals)


def turns(vectors) -> np.ndarray:
    """f64[K - 1]: the angle in degrees between consecutive rows of f[K, 2]."""
    v = np.asarray(vectors, np.float64)
    a, b = v[:-1], v[1:]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return np.degrees(np.abs(np.arctan2(cross, np.sum(a * b, -1))))


def test_normal_and_force_turn_without_jumps_over_the_arc_but_jump_at_the_corner():
    smooth, flat = contact_of(SLIDING), contact_of(SLIDING, None)
    assert bool(smooth.active.all()) and bool(flat.active.all())
    # Flat: constant on a facet, a jump of the full turn at each vertex.
    assert turns(flat.normal[ON_ARC]).max() >= 0.95 * TURN
    # Smooth: on a facet of turn a, xi moves by at most r / (2 sin(a/2)) per
    # radian of the slave's angle (r = 1 - DEPTH) and the normal's angle by
    # at most 2 tan(a/2) per unit of xi, so at most r / cos(a/2) < 1 per
    # radian. Across a vertex's bisector a slave inside projects to xi =
    # (1 + r) / 2 on one facet and (1 - r) / 2 on the next, not to the vertex:
    # the xi it skips, DEPTH in all, leaves a step of DEPTH 2 tan(a/2) radians
    # (0.075 degrees: 1% of the flat jump).
    half = math.radians(TURN / 2)
    step = STEP * (1 - DEPTH) / math.cos(half) + math.degrees(DEPTH * 2 * math.tan(half))
    bound = step + 1e-3
    assert bound < TURN / 10
    assert turns(smooth.normal[ON_ARC]).max() <= bound
    force = penalty(smooth, SURFACE, 100.0).on_slaves
    assert turns(force[ON_ARC]).max() <= bound
    assert turns(penalty(flat, SURFACE, 100.0).on_slaves[ON_ARC]).max() >= 0.95 * TURN
    # The gap follows: its rate is at most sin(a/2) (r + DEPTH) = sin(a/2) per radian.
    gap_bound = math.radians(STEP) * math.sin(math.radians(TURN / 2)) * 1.0
    assert np.abs(np.diff(np.asarray(smooth.gap[ON_ARC], np.float64))).max() <= gap_bound
    # The 90 degree corner keeps its jump, in the normal and in the force.
    for contact in (smooth, flat):
        assert turns(contact.normal[AT_CORNER]).max() >= 80
        assert turns(penalty(contact, SURFACE, 100.0).on_slaves[AT_CORNER]).max() >= 80


def test_gap_is_measured_along_the_smooth_normal_with_the_flat_sign():
    smooth, flat = contact_of(SCATTERED), contact_of(SCATTERED, None)
    found = np.asarray(flat.found)
    assert 100 <= found.sum() < NUM_SLAVES
    # What the flat search found stays: only the normal and the gap change.
    for field in ("found", "segment", "vertex"):
        np.testing.assert_array_equal(getattr(smooth, field), getattr(flat, field))
    for field in ("xi", "point"):
        np.testing.assert_array_equal(getattr(smooth, field), getattr(flat, field))
    x, point, normal = (np.asarray(v, np.float64) for v in (SCATTERED, smooth.point, smooth.normal))
    along = np.sum((x - point) * normal, -1)
    # At the back's 90 degree corners (nodes 25, 26), kept sharp, the gap is the flat +-|x - v|.
    sharp = np.isin(np.asarray(flat.vertex), [ARC + 1, ARC + 2])
    assert sharp.sum() > 3
    along = np.where(sharp, np.asarray(flat.gap), along)
    atol = local_atol(FLOAT, 2.0)
    np.testing.assert_allclose(np.asarray(smooth.gap)[found], along[found], atol=atol)
    np.testing.assert_allclose(np.linalg.norm(normal[found], axis=-1), 1, atol=atol)
    gap, flat_gap = np.asarray(smooth.gap), np.asarray(flat.gap)
    assert (flat_gap[found] < 0).sum() > 10 and (flat_gap[found] > 0).sum() > 10
    np.testing.assert_array_equal(np.sign(gap[found]), np.sign(flat_gap[found]))
    np.testing.assert_array_equal(smooth.active, found & (gap < 0))
    # ... and the normals do differ from the flat ones (by under half a turn).
    angle = np.degrees(np.arccos(np.clip(np.sum(normal * np.asarray(flat.normal), -1), -1, 1)))
    assert (angle[found] > 0.1).sum() > found.sum() // 2
    assert angle[found].max() <= TURN / 2 + 1e-3


def test_compact_bucket_sort_and_search_give_all_to_all_smooth_normals():
    x = jnp.asarray(SCATTERED)
    dense, flat = contact_of(x), contact_of(x, None)
    assert np.abs(np.asarray(dense.normal - flat.normal)).max() > 1e-3  # the check can tell
    # The one-call compact form (a ContactList smoothed entry by entry) and the
    # binned Search's dense Contact; a dense Contact is smoothed as all_to_all's is.
    listed = bucket_sort(x, SURFACE, radius=RADIUS, normals=Smooth(), compact=True)
    search = Search(radius=RADIUS, method="binned", normals=Smooth())
    searched, _ = search.closest(search.allocate(x, SURFACE), x, SURFACE)
    for contact in (listed.to_contact(NUM_SLAVES), searched):
        assert_same_contact(contact, dense, radius=RADIUS)
        np.testing.assert_array_equal(contact.active, dense.active)


# Slaves where the search's choice is not smooth: on the bisector of the arc's
# vertex at (1, 0) inside (a tie of two facets) and outside (the vertex is the
# closest point), on that vertex, on the diagonal of the 90 degree corner and
# outside it; then three on facets' interiors.
_EDGY = [(0.99, 0), (1.05, 0), (1, 0), (-0.99, 0.99), (-1.05, 1.05)]
_EDGY += [(0.5, 0.8), (-0.5, 0.95), (-1.04, -0.3)]
_MID = np.radians(-90 + TURN * (np.array([2, 9, 15]) + 0.5))
_FACE = np.concatenate([np.stack([np.cos(_MID), np.sin(_MID)], -1) * r for r in (0.99, 1.05)])
GRAD_SLAVES = {
    "vertices": np.asarray(_EDGY, FLOAT),
    "faces": np.concatenate([_FACE, [(-0.5, 0.95), (-1.04, -0.3)]]).astype(FLOAT),
}


def gap_total(x, nodes, power=2):
    surface = SURFACE._replace(nodes=nodes)
    return jnp.sum(all_to_all(x, surface, radius=RADIUS, normals=Smooth()).gap ** power)


def contact_of_grad_slaves(x):
    return all_to_all(x, SURFACE, radius=RADIUS, normals=Smooth())


squared_gap_gradients = jax.jit(jax.grad(gap_total, argnums=(0, 1)))


@pytest.mark.parametrize("where", sorted(GRAD_SLAVES))
def test_gradients_of_smooth_gaps_are_finite(where):
    x = jnp.asarray(GRAD_SLAVES[where])
    assert bool(contact_of_grad_slaves(x).found.all())
    by_x, by_nodes = squared_gap_gradients(x, SURFACE.nodes)
    assert np.isfinite(np.asarray(by_x)).all() and np.isfinite(np.asarray(by_nodes)).all()
    assert np.abs(np.asarray(by_x)).sum() > 0 and np.abs(np.asarray(by_nodes)).sum() > 0


@pytest.mark.x64
def test_gap_gradient_matches_finite_differences_away_from_vertices():
    contact = contact_of_grad_slaves(jnp.asarray(GRAD_SLAVES["faces"]))
    assert bool(contact.found.all()) and bool(((contact.xi > 0.2) & (contact.xi < 0.8)).all())
    total = jax.jit(lambda x: gap_total(x, SURFACE.nodes, power=1))
    check_grads(total, (jnp.asarray(GRAD_SLAVES["faces"]),), order=1, modes=["rev"])


def test_corner_below_the_turn_keeps_those_vertices_sharp():
    sharp, flat = contact_of(SCATTERED, Smooth(corner=5.0)), contact_of(SCATTERED, None)
    segment, xi = np.asarray(flat.segment), np.asarray(flat.xi)
    atol = local_atol(FLOAT, 2.0)
    # The arc's inner facets turn by 7.5 degrees at both ends: flat normals and
    # flat gaps, at their vertices too (+-|x - v| there, not (x - v) . n).
    inner = (segment >= 1) & (segment <= ARC - 2)
    face = inner & (np.asarray(flat.vertex) < 0)
    assert face.sum() > 50 and (inner & ~face).sum() > 3
    np.testing.assert_allclose(sharp.normal[inner], flat.normal[inner], atol=atol)
    np.testing.assert_allclose(sharp.gap[inner], flat.gap[inner], atol=atol)
    # No corner smoothed at all: the flat search, every row.
    none = contact_of(SCATTERED, Smooth(corner=0))
    np.testing.assert_allclose(none.gap, flat.gap, atol=atol)
    np.testing.assert_allclose(none.normal, flat.normal, atol=atol)
    # Where the arc meets the top (a 3.75 degree turn) the normal still turns.
    top = (segment == ARC) & (xi < 0.5)
    assert top.sum() > 3
    tilt = np.abs(np.asarray(sharp.normal)[top, 0] - np.asarray(flat.normal)[top, 0])
    assert tilt.min() > 0.4 * math.sin(math.radians(TURN / 4))  # 1.875 (1 - xi) degrees


def test_smooth_is_the_one_way_to_ask_for_smooth_normals():
    x = jnp.asarray(SCATTERED[:3])
    assert Smooth() == Smooth(corner=45.0) and Smooth(corner=30).corner == 30.0
    for corner in (200, -1, float("nan"), "sharp"):
        with pytest.raises(ValueError, match="Smooth.corner must"):
            Smooth(corner=corner)
    assert Smooth(corner=0).corner == 0.0 and Smooth(corner=180).corner == 180.0  # the ends
    # 1.x's strings fail naming Smooth, in every form that takes normals=.
    for normals in ("smooth", "flat"):
        with pytest.raises(TypeError, match=r"normals=jaxcontact\.Smooth\(corner=45\.0\)"):
            all_to_all(x, SURFACE, radius=RADIUS, normals=normals)
        with pytest.raises(TypeError, match="Smooth"):
            bucket_sort(x, SURFACE, radius=RADIUS, normals=normals)
        with pytest.raises(TypeError, match="Smooth"):
            Search(radius=RADIUS, normals=normals)
    with pytest.raises(ValueError, match="normals must be None or a jaxcontact.Smooth; got int"):
        all_to_all(x, SURFACE, radius=RADIUS, normals=3)
    # corner= moved into Smooth: the old keyword is Python's own TypeError.
    with pytest.raises(TypeError, match="unexpected keyword argument 'corner'"):
        all_to_all(x, SURFACE, radius=RADIUS, normals=Smooth(), corner=30.0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'corner'"):
        Search(radius=RADIUS, normals=Smooth(), corner=30.0)
