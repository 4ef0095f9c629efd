"""Each special case of docs/contract.md for ``all_to_all``, checked against the brute-force oracle.

The random scenes, masks, padding and offsets run for both queries in tests/core/test_oracle.py,
through this file's ``checked_scene``.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import Surface
from jaxcontact._pipeline.geometry import edge, squared_distance
from jaxcontact._pipeline.lowest import lowest_score
from jaxcontact.scenes import paper_scene
from tests.support import helpers
from tests.support.oracle import oracle_contact
from tests.support.tolerances import FLOAT32_RTOL, FLOAT32_SUM_RTOL

# All of this file runs again with x64 off (tests/test_x64_off.py).
pytestmark = pytest.mark.x64_off

# Jitted once at module level so scenes of equal shapes share one compilation.
all_to_all = jax.jit(jaxcontact.all_to_all)

DTYPES = pytest.mark.parametrize("dtype", helpers.FLOAT_DTYPES, ids=lambda d: np.dtype(d).name)

# A counter-clockwise unit square: normals point out of it.
SQUARE_NODES = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
SQUARE_SEGMENTS = [[0, 1], [1, 2], [2, 3], [3, 0]]


def checked_contact(x, nodes, segments, *, radius, dtype=helpers.FLOAT):
    """Runs ``all_to_all`` on a hand-made scene (padded to ``helpers.CAPACITY``),
    checks every field against the oracle and returns the rows of the real slaves."""
    scene = helpers.padded_scene(x, x, nodes, segments, radius=radius, dtype=dtype)
    contact = checked_scene(scene)
    num_slaves = len(np.asarray(x).reshape(-1, 2))
    assert not contact.found[num_slaves:].any()
    return jax.tree.map(lambda field: field[:num_slaves] if field.ndim else field, contact)


def checked_scene(scene: helpers.Scene, **tolerance):
    """Runs ``all_to_all`` on a random scene as it is, checks every field against the oracle."""
    contact = all_to_all(
        jnp.asarray(scene.x),
        helpers.surface_of(scene),
        radius=scene.radius,
        mask=helpers.slave_mask_of(scene),
    )
    helpers.assert_contact_matches(
        contact, helpers.contact_oracle(scene), scene.x.dtype, **tolerance
    )
    return contact


def test_first_index_wins_a_tie_across_segment_blocks():
    # Above ``unroll`` steps, lowest_score scans the segments in unrolled
    # blocks of ``block`` (32 and 8 in the detectors) inside a lax.scan.
    # Covering that path with M > 32 costs ~20 s of compilation, so the
    # reduction is run directly with ``unroll=4, block=4``: ten segments take
    # three blocks, the last one ragged. The second half repeats the first, so
    # every slave ties exactly between k and k + 5 and must get the lower index.
    scene = helpers.random_scene(7, 9, 5)
    doubled = np.concatenate([scene.segments, scene.segments])
    starts, ends = scene.nodes[doubled[:, 0]], scene.nodes[doubled[:, 1]]
    pair_value = jax.vmap(squared_distance, in_axes=(0, None))

    # With XLA's default code generation, as users compile it: without
    # LLVM's optimisation (the suite's) the unrolled steps were seen to round
    # the same pair two ways (``helpers.XLA_DEFAULTS``).
    @functools.partial(jax.jit, compiler_options=helpers.XLA_DEFAULTS)
    def lowest(x, starts, ends):
        def score(k):
            return pair_value(x, edge(starts[k], ends[k])), jnp.broadcast_to(k, x.shape[:1])

        every = jax.vmap(pair_value, in_axes=(None, 0))(x, edge(starts, ends))
        choice, _ = lowest_score(score, len(starts), len(x), x.dtype, unroll=4, block=4)
        return choice, every

    choice, every = map(np.asarray, lowest(scene.x, starts, ends))
    np.testing.assert_array_equal(every[:5], every[5:])  # exact ties
    np.testing.assert_array_equal(choice, np.argmin(every, axis=0))  # the first of each tie
    assert np.all(choice < 5)
    # And the detector on the doubled surface (one unrolled pass) as the oracle has it.
    surface = Surface(jnp.asarray(scene.nodes), jnp.asarray(doubled))
    contact = all_to_all(jnp.asarray(scene.x), surface, radius=10.0)
    expected = oracle_contact(scene.x, scene.nodes, doubled, radius=10.0)
    helpers.assert_contact_matches(contact, expected, helpers.FLOAT)
    assert np.all(expected.segment < 5)


def check_ties_at_random_shared_vertices(dtype, place):
    """Slaves placed by ``place(vertex, previous, following)`` at the shared
    vertices of random outlines, checked against the oracle (which decides ties
    exactly); returns how many of them were found."""
    found = 0
    for seed in range(6):
        scene = helpers.random_scene(seed, 9, 5, dtype, masked=True)
        slaves = [place(*corner) for corner in helpers.shared_vertices(scene)]
        if not slaves:
            continue
        x = scene.x.copy()
        x[: len(slaves)] = slaves
        scene = scene._replace(x=x, slave_mask=np.ones(9, bool), seg_mask=None)
        found += int(checked_scene(scene).found[: len(slaves)].sum())
    return found


def off_bisector(vertex, previous, following, distance=0.1, share=0.3):
    """f64[2]: a point ``distance`` from ``vertex`` in its blind spot (the closest
    point on both segments is the vertex), off the corner's bisector: the edge
    directions of the blind spot are the two segments' perpendiculars, and this
    mixes them ``share : 1 - share``."""
    vertex, previous, following = (np.asarray(p, np.float64) for p in (vertex, previous, following))
    back = (previous - vertex) / np.linalg.norm(previous - vertex)
    ahead = (following - vertex) / np.linalg.norm(following - vertex)
    edge_back = np.array([back[1], -back[0]])
    edge_back *= -1 if edge_back @ ahead > 0 else 1
    edge_ahead = np.array([ahead[1], -ahead[0]])
    edge_ahead *= -1 if edge_ahead @ back > 0 else 1
    away = share * edge_back + (1 - share) * edge_ahead
    return vertex + distance * away / np.linalg.norm(away)


@DTYPES
@pytest.mark.parametrize("share", [0.3, 0.7])
def test_slaves_in_blind_spots_tie_to_the_face_they_are_outside_of(dtype, share):
    # In the blind spot beside a shared vertex both segments' closest point is
    # the vertex itself: an exact tie in distance whatever the (non-dyadic)
    # coordinates. The larger signed normal distance decides (README: ties),
    # off the bisector by a clear margin, so the oracle's exact choice holds.
    def beside(vertex, previous, following):
        return off_bisector(vertex, previous, following, share=share)

    assert check_ties_at_random_shared_vertices(dtype, beside) >= 6


@DTYPES
def test_slave_on_the_bisector_beyond_a_sharp_convex_corner_is_outside(dtype):
    # The paper's tool tip: rake face R -> T, clearance face T -> C, an 81 degree
    # wedge. Below the tip, in its blind spot, a slave is outside the tool; with
    # ties to the lower index alone its gap would take the rake face's sign and
    # say penetration. On the bisector the two faces tie exactly in reals.
    tool = paper_scene(10, dtype=dtype).surface
    nodes = np.asarray(tool.nodes, np.float64)
    rake_end, tip, clearance_end = nodes
    for share in (0.0, 0.5, 0.9, 1.0):
        slave = off_bisector(tip, rake_end, clearance_end, distance=0.5, share=share)
        contact = all_to_all(jnp.asarray([slave], dtype), tool, radius=1.0)
        assert bool(contact.found[0]) and not bool(contact.active[0])
        np.testing.assert_allclose(contact.gap[0], 0.5, rtol=FLOAT32_SUM_RTOL)
        np.testing.assert_allclose(contact.point[0], tip, rtol=FLOAT32_RTOL)


# Regression (found by this suite): a slave exactly on the vertex V shared by
# segment k (ending at V) and k + 1 (starting at V) is at distance 0 from both
# and must get k. The clamp of xi used to come from the rounded ratio
# (x - a).d / d.d, which FMA contraction made 1 - 1 ulp, so k + 1 won by 1e-17.
# The clamps are now decided by sign. Dyadic coordinates hid it.
@DTYPES
def test_slaves_on_shared_vertices_of_random_outlines_tie_to_lower_index(dtype):
    def on(vertex, previous, following):
        return vertex

    assert check_ties_at_random_shared_vertices(dtype, on) >= 6


def test_slave_on_segment_interior_has_zero_gap_and_is_not_active():
    # Floor from (2, 0) to (0, 0): its outward normal points up.
    contact = checked_contact(
        [[0.5, 0.0], [0.5, 0.125], [0.5, -0.125]], [[2.0, 0.0], [0.0, 0.0]], [[0, 1]], radius=0.5
    )
    np.testing.assert_array_equal(contact.gap, [0.0, 0.125, -0.125])
    np.testing.assert_array_equal(contact.xi, [0.75, 0.75, 0.75])
    np.testing.assert_array_equal(contact.point, [[0.5, 0.0]] * 3)
    np.testing.assert_array_equal(contact.normal, [[0.0, 1.0]] * 3)
    np.testing.assert_array_equal(contact.active, [False, False, True])


@DTYPES
def test_slave_on_shared_vertex_goes_to_lower_index(dtype):
    # (1, 0) ends segment 0 and starts segment 1; (0, 0) starts segment 0 and
    # ends segment 3. Both tie exactly (distance 0), so both get segment 0.
    contact = checked_contact(
        [[1.0, 0.0], [0.0, 0.0], [1.0, 1.0]],
        SQUARE_NODES,
        SQUARE_SEGMENTS,
        radius=0.25,
        dtype=dtype,
    )
    np.testing.assert_array_equal(contact.segment, [0, 0, 1])
    np.testing.assert_array_equal(contact.xi, [1.0, 0.0, 1.0])
    np.testing.assert_array_equal(contact.gap, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(contact.point, [[1.0, 0.0], [0.0, 0.0], [1.0, 1.0]])


@DTYPES
def test_blind_spot_outside_convex_corner_picks_the_face_with_larger_normal_distance(dtype):
    # Outside the corner both segments' closest point is the vertex (a tie in
    # distance; the larger (x - p) . n decides, here the first face); the
    # distance 0.625 = |(0.375, 0.5)| is exact, and the gap is positive.
    contact = checked_contact(
        [[1.375, -0.5], [-0.375, -0.5], [1.5, 1.375]],
        SQUARE_NODES,
        SQUARE_SEGMENTS,
        radius=1.0,
        dtype=dtype,
    )
    np.testing.assert_array_equal(contact.segment, [0, 0, 1])
    np.testing.assert_array_equal(contact.gap, [0.625, 0.625, 0.625])
    np.testing.assert_array_equal(contact.xi, [1.0, 0.0, 1.0])
    np.testing.assert_array_equal(contact.normal, [[0.0, -1.0], [0.0, -1.0], [1.0, 0.0]])
    assert not contact.active.any()


@DTYPES
def test_concave_corner_picks_nearer_face_and_ties_on_bisector_to_lower_index(dtype):
    # The master fills {y < 0} u {x < 0}; its outline (2, 0) -> (0, 0) -> (0, 2)
    # has a concave corner at the origin.
    nodes, segments = [[2.0, 0.0], [0.0, 0.0], [0.0, 2.0]], [[0, 1], [1, 2]]
    slaves = [[0.5, 0.25], [0.25, 0.5], [0.25, 0.25], [0.5, -0.25], [-0.125, 0.5]]
    contact = checked_contact(slaves, nodes, segments, radius=1.0, dtype=dtype)
    np.testing.assert_array_equal(contact.segment, [0, 1, 0, 0, 1])
    np.testing.assert_array_equal(contact.gap, [0.25, 0.25, 0.25, -0.25, -0.125])
    np.testing.assert_array_equal(contact.xi, [0.75, 0.25, 0.875, 0.75, 0.25])
    np.testing.assert_array_equal(contact.active, [False, False, False, True, True])


def test_zero_length_segment_is_ignored():
    # Segment 0 and segment 2 have zero length (distinct nodes at one place,
    # and one node used twice); the slaves sit exactly on them.
    nodes = [[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [3.0, 0.0]]
    contact = checked_contact([[0.0, 0.0], [1.0, 0.0]], nodes, [[0, 1], [2, 3], [2, 2]], radius=2.0)
    np.testing.assert_array_equal(contact.segment, [1, 1])
    np.testing.assert_array_equal(contact.gap, [1.0, 0.0])


def test_only_zero_length_segments_find_nothing():
    contact = checked_contact([[0.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]], [[0, 1], [1, 1]], radius=5.0)
    assert not contact.found.any()
    np.testing.assert_array_equal(contact.segment, [-1])


@DTYPES
def test_radius_boundary_is_inclusive(dtype):
    beyond = np.nextafter(dtype(0.25), dtype(1))
    # Floor (2, 0) -> (0, 0), normal up: gaps of exactly +-0.25 and one ulp more.
    slaves = [[0.5, 0.25], [0.5, -0.25], [0.5, beyond], [0.5, -beyond]]
    contact = checked_contact(slaves, [[2.0, 0.0], [0.0, 0.0]], [[0, 1]], radius=0.25, dtype=dtype)
    np.testing.assert_array_equal(contact.found, [True, True, False, False])


@DTYPES
def test_radius_boundary_is_inclusive_at_a_corner(dtype):
    # Beyond the end (2, 0) the distance is |(0.375, 0.5)| = 0.625 exactly. Two
    # ulps more in y (not one) so that the rounded square root is surely larger.
    beyond = np.nextafter(np.nextafter(dtype(0.5), dtype(1)), dtype(1))
    slaves = [[2.375, 0.5], [2.375, beyond]]
    contact = checked_contact(slaves, [[2.0, 0.0], [0.0, 0.0]], [[0, 1]], radius=0.625, dtype=dtype)
    np.testing.assert_array_equal(contact.found, [True, False])


@DTYPES
def test_zero_radius_finds_only_slaves_on_the_surface(dtype):
    # The smallest normal float above the floor, and one whose square
    # underflows too. (Not a subnormal: XLA on the CPU flushes subnormals to
    # zero, so no JAX program can see them.)
    off = np.finfo(dtype).tiny
    slaves = [[0.5, 0.0], [2.0, 0.0], [0.0, 0.0], [0.5, off], [0.5, off * 1e8]]
    contact = checked_contact(slaves, [[2.0, 0.0], [0.0, 0.0]], [[0, 1]], radius=0.0, dtype=dtype)
    np.testing.assert_array_equal(contact.found, [True, True, True, False, False])
    np.testing.assert_array_equal(contact.gap, np.zeros(5))
