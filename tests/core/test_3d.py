"""The 3D closest-point query of ``all_to_all``: slaves f[N, 3] against a surface of triangles.

Exact cases on float64 meshes (a tetrahedron, a cube split into triangles),
the float64 oracle (tests/support/oracle3d.py) on random closed meshes with
and without masks, the properties the contract names (rigid motions,
relabelling, continuity of the gap, padding), gradients against central
differences, and the forms that refuse 3D input. Every hand-made scene is
padded to one shape (``CAPACITY``), so the plain calls share one program.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

import jaxcontact
from jaxcontact import Pairs, Search, Smooth, Surface
from jaxcontact.scenes import box_surface, split_quads
from tests.support import helpers
from tests.support.oracle3d import oracle_contact_3d, winding_number
from tests.support.tolerances import (
    FD_ATOL,
    FD_RTOL,
    FD_STEP,
    FLOAT32_RADIUS_EDGE,
    FLOAT64_ATOL,
    LIPSCHITZ_SLACK,
    NEAR_TIE_3D,
)

pytestmark = pytest.mark.x64

# Slaves, nodes, triangles: every scene of this file is padded to these, so
# that the plain calls compile one program per dtype.
CAPACITY = (48, 32, 48)

# The tetrahedron of the unit corner, each face counter-clockwise seen from outside.
TETRA_NODES = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
TETRA_FACES = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]


def padded(x, nodes, triangles, *, slave_mask=None, face_mask=None, dtype=np.float64):
    """``(x, Surface, mask)`` padded to ``CAPACITY`` with masked rows that are not
    harmless: NaN and huge slaves, NaN nodes, faces naming them or no node."""
    x, nodes, triangles = np.asarray(x), np.asarray(nodes), np.asarray(triangles)
    rows, num_nodes, faces = CAPACITY
    big = np.full((rows, 3), np.nan)
    big[1::2] = 1e30
    big[: len(x)] = x
    mask = np.zeros(rows, bool)
    mask[: len(x)] = True if slave_mask is None else slave_mask
    all_nodes = np.full((num_nodes, 3), np.nan)
    all_nodes[: len(nodes)] = nodes
    all_faces = np.tile(np.array([[len(nodes), 0, -1]]), (faces, 1))
    all_faces[: len(triangles)] = triangles
    face_ok = np.zeros(faces, bool)
    face_ok[: len(triangles)] = True if face_mask is None else face_mask
    surface = Surface(
        jnp.asarray(all_nodes, dtype), jnp.asarray(all_faces, jnp.int32), jnp.asarray(face_ok)
    )
    return jnp.asarray(big, dtype), surface, jnp.asarray(mask)


def contact_of(x, nodes, triangles, *, radius, slave_mask=None, face_mask=None, dtype=np.float64):
    """``all_to_all`` of a hand-made or random scene, its real rows only."""
    xs, surface, mask = padded(
        x, nodes, triangles, slave_mask=slave_mask, face_mask=face_mask, dtype=dtype
    )
    contact = jaxcontact.all_to_all(xs, surface, radius=radius, mask=mask)
    helpers.assert_all_finite(contact)
    assert not contact.found[len(x) :].any()
    return jax.tree.map(lambda field: np.asarray(field[: len(x)] if field.ndim else field), contact)


def star_mesh(seed: int, subdivisions: int = 2, wobble: float = 0.15):
    """A closed, outward-oriented triangle mesh: the cube [-1, 1]^3 with each
    side split into ``subdivisions``^2 quads, its nodes moved radially at random
    (star-shaped about the origin, so it stays closed and oriented)."""
    box = box_surface((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0), subdivisions, dtype=np.float64)
    nodes, triangles = np.asarray(box.nodes), np.asarray(box.segments)
    rng = np.random.default_rng(seed)
    scale = 1 + wobble * rng.uniform(-1, 1, len(nodes))
    return nodes * scale[:, None], triangles


def random_slaves(seed: int, count: int = CAPACITY[0], extent: float = 1.6):
    return np.random.default_rng(seed + 1000).uniform(-extent, extent, (count, 3))


def assert_matches_oracle(contact, expected, *, clear: float = NEAR_TIE_3D):
    """Every field against the oracle; rows whose nearest face has a rival
    within ``clear`` (a near tie: either is right) compare by value only."""
    found = expected.found
    np.testing.assert_array_equal(contact.found, found)
    np.testing.assert_array_equal(contact.active, expected.active)
    atol = helpers.local_atol(np.float64, 4.0)
    np.testing.assert_allclose(contact.gap, expected.gap, rtol=0, atol=atol)
    np.testing.assert_allclose(contact.point, expected.point, rtol=0, atol=atol)
    margin = expected.second - np.where(found, expected.distance, 0)
    distinct = found & (margin > clear)
    np.testing.assert_array_equal(contact.segment[distinct], expected.segment[distinct])
    np.testing.assert_array_equal(contact.vertex[distinct], expected.vertex[distinct])
    np.testing.assert_allclose(contact.xi[distinct], expected.xi[distinct], rtol=0, atol=atol)
    np.testing.assert_allclose(
        contact.normal[distinct], expected.normal[distinct], rtol=0, atol=atol
    )


# -- exact cases -------------------------------------------------------------


def test_the_tetrahedron_on_faces_edges_and_vertices():
    x = [
        [0.25, 0.25, -0.5],  # below the bottom face's interior
        [0.125, 0.125, 0.25],  # inside, as near the faces y = 0 and x = 0: the lower index
        [0.5, -1.0, -1.0],  # beyond the edge 0-1 of the faces z = 0 and y = 0
        [-1.0, -1.0, -1.0],  # beyond vertex 0
        [0.25, 0.5, 0.0],  # on the bottom face
        [0.5, 0.0, 0.0],  # on the edge 0-1
        [0.0, 0.0, 1.0],  # on vertex 3
        [3.0, 3.0, 3.0],  # beyond the radius
    ]
    contact = contact_of(x, TETRA_NODES, TETRA_FACES, radius=2.0)
    sqrt2, sqrt3 = np.sqrt(2.0), np.sqrt(3.0)
    atol = helpers.local_atol(np.float64, 4.0)
    np.testing.assert_allclose(
        contact.gap, [0.5, -0.125, sqrt2, sqrt3, 0, 0, 0, 0], rtol=0, atol=atol
    )
    np.testing.assert_array_equal(contact.segment, [0, 1, 0, 0, 0, 0, 1, -1])
    np.testing.assert_array_equal(
        contact.vertex,
        [[-1, -1], [-1, -1], [0, 1], [0, -1], [-1, -1], [0, 1], [3, -1], [-1, -1]],
    )
    np.testing.assert_array_equal(contact.found, [True] * 7 + [False])
    np.testing.assert_array_equal(contact.active, [False, True] + [False] * 6)
    expected_points = [[0.25, 0.25, 0], [0.125, 0, 0.25], [0.5, 0, 0], [0, 0, 0]]
    np.testing.assert_allclose(contact.point[:4], expected_points, rtol=0, atol=atol)
    np.testing.assert_allclose(contact.point[4:7], np.asarray(x)[4:7], rtol=0, atol=atol)
    # xi: the barycentric weights of the face's vertices 1 and 2.
    np.testing.assert_allclose(
        contact.xi[:4], [[0.25, 0.25], [0.125, 0.25], [0.0, 0.5], [0, 0]], rtol=0, atol=atol
    )
    np.testing.assert_allclose(
        contact.normal[:4], [[0, 0, -1], [0, -1, 0], [0, 0, -1], [0, 0, -1]], rtol=0, atol=atol
    )
    assert contact.gap.dtype == np.float64 and contact.xi.shape == (8, 2)


def test_the_cube_split_in_triangles_signs_at_edges_and_corners():
    box = box_surface((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), dtype=np.float64)
    nodes, triangles = np.asarray(box.nodes), np.asarray(box.segments)
    assert triangles.shape == (12, 3)
    x = [
        [2.0, 2.0, 2.0],  # beyond a corner: sqrt(3)
        [0.5, 2.0, 2.0],  # beyond an edge: sqrt(2)
        [0.25, 0.5, 0.125],  # inside, nearest the bottom
        [0.5, 0.5, 0.5],  # the centre: all six sides tie at -1/2
        [0.9375, 0.9375, 0.875],  # inside near an edge: the sides x = 1 and y = 1 tie
        [0.5, 0.5, 1.5],  # above the top side's middle, on its diagonal
    ]
    contact = contact_of(x, nodes, triangles, radius=2.0)
    expected = oracle_contact_3d(x, nodes, triangles, 2.0)
    atol = helpers.local_atol(np.float64, 4.0)
    gaps = [np.sqrt(3.0), np.sqrt(2.0), -0.125, -0.5, -0.0625, 0.5]
    np.testing.assert_allclose(contact.gap, gaps, rtol=0, atol=atol)
    np.testing.assert_allclose(expected.gap, gaps, rtol=0, atol=atol)
    np.testing.assert_array_equal(contact.vertex[:2], expected.vertex[:2])
    assert contact.vertex[0, 1] == -1 and (contact.vertex[1] >= 0).all()
    # An exact tie of the twelve triangles (six sides): the lowest index.
    assert contact.segment[3] == 0
    np.testing.assert_array_equal(contact.active, [False, False, True, True, True, False])


def test_beyond_a_sharp_ridge_the_pseudo_normal_signs_the_gap():
    # A roof of two steep sides meeting at the ridge x = z = 0, each side two
    # triangles, normals out (up and away from the ridge). The normals meet
    # at more than 90 degrees, so a slave above the ridge, nearest the ridge
    # line, can be behind either side's plane: the face normal of the
    # chosen side alone would call it penetrating (the 2D tool tip's blind
    # spot); the edge's pseudo-normal (the sum of the sides' normals) does not.
    nodes = [
        [-1.0, -1.0, -2.0],
        [0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 1.0, -2.0],
        [1.0, -1.0, -2.0],
        [1.0, 1.0, -2.0],
    ]
    triangles = split_quads([[0, 1, 2, 3], [1, 4, 5, 2]])
    x = [[0.375, 0.5, 0.5], [-0.375, 0.5, 0.5], [0.0, 0.5, -0.25], [0.0, -0.5, 0.0]]
    contact = contact_of(x, nodes, triangles, radius=2.0)
    expected = oracle_contact_3d(x, nodes, triangles, 2.0)
    atol = helpers.local_atol(np.float64, 4.0)
    gaps = [0.625, 0.625, -0.25 / np.sqrt(5), 0.0]
    np.testing.assert_allclose(contact.gap, gaps, rtol=0, atol=atol)
    np.testing.assert_allclose(expected.gap, gaps, rtol=0, atol=atol)
    np.testing.assert_array_equal(contact.vertex[[0, 1, 3]], [[1, 2], [1, 2], [1, 2]])
    np.testing.assert_array_equal(contact.active, [False, False, True, False])


# -- the oracle ---------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("masked", [False, True], ids=["whole", "masked"])
def test_random_closed_meshes_against_the_oracle(seed, masked):
    nodes, triangles = star_mesh(seed)
    x = random_slaves(seed)
    rng = np.random.default_rng(seed + 7)
    slave_mask = rng.uniform(size=len(x)) < 0.8 if masked else None
    face_mask = rng.uniform(size=len(triangles)) < 0.8 if masked else None
    radius = 0.6
    contact = contact_of(
        x, nodes, triangles, radius=radius, slave_mask=slave_mask, face_mask=face_mask
    )
    expected = oracle_contact_3d(x, nodes, triangles, radius, slave_mask, face_mask)
    assert expected.found.sum() > 10 and expected.active.sum() > 3
    assert_matches_oracle(contact, expected)
    if not masked:
        # On a closed mesh the pseudo-normal's sign is the inside test's.
        inside = np.array([winding_number(p, nodes, triangles) > 0.5 for p in x])
        np.testing.assert_array_equal(contact.active, inside & contact.found)


def test_a_radius_per_slave_and_every_slave_out_of_reach():
    nodes, triangles = star_mesh(3)
    x = random_slaves(3)
    radius = np.random.default_rng(4).uniform(0, 1, len(x))
    xs, surface, mask = padded(x, nodes, triangles)
    radii = np.zeros(CAPACITY[0])
    radii[: len(x)] = radius
    contact = jaxcontact.all_to_all(xs, surface, radius=radii, mask=mask)
    assert_matches_oracle(
        jax.tree.map(np.asarray, contact), oracle_contact_3d(x, nodes, triangles, radius)
    )
    nothing = jaxcontact.all_to_all(xs + 10.0, surface, radius=0.5, mask=mask)
    assert not nothing.found.any() and (np.asarray(nothing.segment) == -1).all()


# -- properties -----------------------------------------------------------------


def _rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def test_a_rigid_motion_moves_the_answer_with_it():
    nodes, triangles = star_mesh(5)
    x = random_slaves(5)
    rotation, shift = _rotation(5), np.array([0.5, -2.0, 1.25])
    plain = contact_of(x, nodes, triangles, radius=0.6)
    moved = contact_of(x @ rotation.T + shift, nodes @ rotation.T + shift, triangles, radius=0.6)
    atol = helpers.local_atol(np.float64, 16.0)
    # Off a face's interior, the faces sharing the feature tie (to rounding):
    # the feature, the gap and the point are the answer there, not the face.
    interior = plain.found & (plain.vertex[:, 0] == -1)
    np.testing.assert_array_equal(moved.segment[interior], plain.segment[interior])
    np.testing.assert_array_equal(moved.vertex, plain.vertex)
    np.testing.assert_allclose(moved.gap, plain.gap, rtol=0, atol=atol)
    np.testing.assert_allclose(moved.xi[interior], plain.xi[interior], rtol=0, atol=atol)
    found = plain.found
    np.testing.assert_allclose(
        moved.point[found], plain.point[found] @ rotation.T + shift, rtol=0, atol=atol
    )
    np.testing.assert_allclose(
        moved.normal[interior], plain.normal[interior] @ rotation.T, rtol=0, atol=atol
    )


def test_relabelling_faces_and_their_vertices_keeps_the_answer():
    nodes, triangles = star_mesh(6)
    x = random_slaves(6)
    order = np.random.default_rng(6).permutation(len(triangles))
    turned = np.roll(triangles[order], 1, axis=1)  # (a, b, c) -> (c, a, b): same orientation
    plain = contact_of(x, nodes, triangles, radius=0.6)
    relabelled = contact_of(x, nodes, turned, radius=0.6)
    found = plain.found
    # Exact ties off a face's interior go to the lower index, which the
    # relabelling changes: there the feature, gap and point are the answer.
    interior = found & (plain.vertex[:, 0] == -1)
    np.testing.assert_array_equal(relabelled.found, found)
    np.testing.assert_array_equal(order[relabelled.segment[interior]], plain.segment[interior])
    np.testing.assert_array_equal(relabelled.vertex, plain.vertex)
    atol = helpers.local_atol(np.float64, 16.0)
    np.testing.assert_allclose(relabelled.gap, plain.gap, rtol=0, atol=atol)
    np.testing.assert_allclose(relabelled.point, plain.point, rtol=0, atol=atol)
    # The weights turn with the vertices: (w_b, w_c) -> (w_a, w_b) of (c, a, b).
    weights_a = 1 - plain.xi[:, 0] - plain.xi[:, 1]
    np.testing.assert_allclose(relabelled.xi[interior, 0], weights_a[interior], rtol=0, atol=atol)
    np.testing.assert_allclose(relabelled.xi[interior, 1], plain.xi[interior, 0], rtol=0, atol=atol)
    assert interior.sum() > 10 and (found & ~interior).sum() > 5


@pytest.mark.parametrize("through", ["edge", "vertex"])
def test_the_gap_is_continuous_across_edges_and_vertices(through):
    # The signed distance is 1-Lipschitz: slaves a step h apart on a line
    # through a feature of the mesh, from outside to inside, have gaps at
    # most h apart, and the sign changes once.
    nodes, triangles = star_mesh(8)
    if through == "vertex":
        target = nodes[0]
    else:
        target = 0.5 * (nodes[triangles[0, 0]] + nodes[triangles[0, 1]])
    direction = target / np.linalg.norm(target) + np.array([0.05, -0.03, 0.02])
    steps = np.linspace(-0.3, 0.3, CAPACITY[0])
    x = target + steps[:, None] * direction / np.linalg.norm(direction)
    contact = contact_of(x, nodes, triangles, radius=1.0)
    assert contact.found.all()
    h = steps[1] - steps[0]
    assert np.abs(np.diff(contact.gap)).max() <= h * (1 + LIPSCHITZ_SLACK)
    assert np.count_nonzero(np.diff(np.sign(contact.gap))) == 1


def test_padding_never_changes_a_real_row():
    nodes, triangles = star_mesh(9)
    x = random_slaves(9, 20)
    plain = contact_of(x, nodes, triangles, radius=0.6)
    # The padding interleaved: a NaN slave before each real one, masked faces
    # between real ones naming NaN nodes, and the real ones renumbered.
    xs = np.full((2 * len(x), 3), np.nan)
    xs[1::2] = x
    more_nodes = np.concatenate([nodes, np.full((4, 3), np.nan)])
    faces = np.tile(np.array([[len(nodes), 1, len(nodes) + 1]]), (len(triangles), 1))
    faces[::2] = triangles[: len(triangles) // 2]
    face_mask = np.zeros(len(faces), bool)
    face_mask[::2] = True
    half = contact_of(x, nodes, triangles[: len(triangles) // 2], radius=0.6)
    both = contact_of(
        xs,
        more_nodes,
        faces,
        radius=0.6,
        slave_mask=np.arange(len(xs)) % 2 == 1,
        face_mask=face_mask,
    )
    real = jax.tree.map(lambda field: field[1::2] if field.ndim else field, both)
    mapped = np.where(half.segment >= 0, 2 * half.segment, -1)
    np.testing.assert_array_equal(real.segment, mapped)
    for field in ("gap", "xi", "point", "normal", "vertex", "found", "active"):
        np.testing.assert_array_equal(getattr(real, field), getattr(half, field), field)
    assert not both.found[::2].any()
    assert plain.found.any()


def test_zero_area_and_masked_triangles_are_ignored():
    # A zero-area triangle (a repeated node, and three nodes on a line)
    # nearest every slave is no face: the answer is the tetrahedron's alone.
    nodes = TETRA_NODES + [[0.5, 0.5, -0.25], [0.25, 0.25, -0.25], [0.75, 0.75, -0.25]]
    faces = TETRA_FACES + [[4, 4, 5], [4, 5, 6]]
    x = [[0.5, 0.5, -0.25], [0.25, 0.25, -0.375], [0.5, 0.5, 2.0]]
    contact = contact_of(x, nodes, faces, radius=3.0)
    expected = contact_of(x, TETRA_NODES, TETRA_FACES, radius=3.0)
    for field in ("gap", "segment", "point", "vertex"):
        np.testing.assert_array_equal(getattr(contact, field), getattr(expected, field))


def test_float32_keeps_its_dtype_and_matches_the_oracle():
    nodes, triangles = star_mesh(10)
    x = random_slaves(10)
    contact = contact_of(x, nodes, triangles, radius=0.6, dtype=np.float32)
    for field in ("gap", "xi", "point", "normal"):
        assert getattr(contact, field).dtype == np.float32
    assert contact.segment.dtype == contact.vertex.dtype == np.int32
    expected = oracle_contact_3d(x.astype(np.float32), nodes.astype(np.float32), triangles, 0.6)
    clear = np.abs(expected.distance - 0.6) > FLOAT32_RADIUS_EDGE
    np.testing.assert_array_equal(contact.found[clear], expected.found[clear])
    both = contact.found & expected.found
    atol = helpers.local_atol(np.float32, 16.0)
    np.testing.assert_allclose(contact.gap[both], expected.gap[both], rtol=0, atol=atol)


# -- transformations and gradients ------------------------------------------------


def test_jit_and_vmap_give_the_plain_answer():
    scenes = [star_mesh(seed) for seed in (11, 12)]
    xs, surfaces, masks = zip(
        *(padded(random_slaves(s), *scene) for s, scene in zip((11, 12), scenes, strict=True)),
        strict=True,
    )
    plain = [
        jaxcontact.all_to_all(x, s, radius=0.6, mask=m)
        for x, s, m in zip(xs, surfaces, masks, strict=True)
    ]
    jitted = jax.jit(lambda x, s, m: jaxcontact.all_to_all(x, s, radius=0.6, mask=m))
    batched = jax.vmap(jitted)(
        jnp.stack(xs), jax.tree.map(lambda *a: jnp.stack(a), *surfaces), jnp.stack(masks)
    )
    atol = helpers.local_atol(np.float64, 16.0)
    for b, one in enumerate(plain):
        alone = jitted(xs[b], surfaces[b], masks[b])
        for result in (
            alone,
            jax.tree.map(lambda field, b=b: field[b] if field.ndim else field, batched),
        ):
            np.testing.assert_array_equal(result.segment, one.segment)
            np.testing.assert_array_equal(result.vertex, one.vertex)
            np.testing.assert_allclose(result.gap, one.gap, rtol=0, atol=atol)


def _gap_sum(x, nodes, triangles):
    surface = Surface(nodes, triangles)
    contact = jaxcontact.all_to_all(x, surface, radius=5.0)
    return jnp.sum(contact.gap * jnp.arange(1, x.shape[0] + 1))


def test_gradients_of_the_gap_against_central_differences():
    # Slaves in each kind of region, away from the regions' borders: a
    # face from outside and inside, an edge, a vertex.
    x = jnp.asarray(
        [[0.3, 0.2, -0.4], [0.2, 0.3, 0.1], [0.5, -0.7, -0.6], [-0.6, -0.5, -0.7], [0.6, 0.6, 0.6]]
    )
    nodes = jnp.asarray(TETRA_NODES) * jnp.asarray([[1.0, 1.1, 0.9]])
    triangles = jnp.asarray(TETRA_FACES, jnp.int32)
    check_grads(
        lambda x, nodes: _gap_sum(x, nodes, triangles),
        (x, nodes),
        order=1,
        modes=["rev"],
        eps=FD_STEP,
        atol=FD_ATOL,
        rtol=FD_RTOL,
    )
    # d gap / d x is the unit normal of the feature.
    gradient = jax.grad(_gap_sum)(x, nodes, triangles) / jnp.arange(1, 6)[:, None]
    np.testing.assert_allclose(jnp.linalg.norm(gradient, axis=1), 1.0, rtol=0, atol=FD_ATOL)


def test_gradients_are_finite_on_degenerate_inputs():
    # Slaves on a vertex, on an edge, on a face; a zero-area triangle, a
    # masked one with NaN nodes, NaN padding slaves.
    nodes = jnp.asarray(TETRA_NODES + [[0.5, 0.5, 0.5], [np.nan, 0.0, 0.0]])
    triangles = jnp.asarray(TETRA_FACES + [[4, 4, 1], [5, 0, 1]], jnp.int32)
    face_mask = jnp.asarray([True] * 5 + [False])
    x = jnp.asarray([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.25, 0.25, 0.0], [np.nan] * 3])
    mask = jnp.asarray([True, True, True, False])

    def total(x, nodes):
        surface = Surface(nodes, triangles, face_mask)
        contact = jaxcontact.all_to_all(x, surface, radius=1.0, mask=mask)
        return jnp.sum(contact.gap + contact.point.sum(axis=1) + contact.xi.sum(axis=1))

    grads = jax.jit(jax.grad(total, argnums=(0, 1)))(x, nodes)
    for gradient in grads:
        assert np.isfinite(np.asarray(gradient)).all()


# -- what refuses 3D input -------------------------------------------------------


def test_the_forms_without_3d_refuse_it_by_name():
    xs, surface, mask = padded(random_slaves(0), *star_mesh(0))
    message = "3D input is supported by all_to_all in this release"
    with pytest.raises(
        ValueError, match=r"^x must have shape \(N, 2\) in bucket_sort; got shape \(48, 3\)"
    ):
        jaxcontact.bucket_sort(xs, surface, radius=0.5, mask=mask)
    with pytest.raises(ValueError, match="^x_prev must have shape .* in swept; .*" + message):
        jaxcontact.swept(xs, xs, surface, mask=mask)
    with pytest.raises(ValueError, match="^x_prev .* in bucket_swept; .*" + message):
        jaxcontact.bucket_swept(xs, xs, surface, mask=mask)
    with pytest.raises(ValueError, match="^x must have shape .*" + message):
        Search(radius=0.5).allocate(xs, surface, mask=mask)
    flat = jnp.zeros((4, 2))
    flat_surface = Surface(flat, jnp.asarray([[0, 1]]))
    state = Search(radius=0.5).allocate(flat, flat_surface)
    with pytest.raises(
        ValueError, match=r"^x must have shape \(N, 2\); got shape \(48, 3\).*" + message
    ):
        Search(radius=0.5).closest(state, xs, surface, mask=mask)
    with pytest.raises(ValueError, match="^pairs must be None.*slave_body.*" + message):
        jaxcontact.all_to_all(xs, surface, radius=0.5, mask=mask, pairs=Pairs(slave_body=mask * 1))
    with pytest.raises(ValueError, match="^normals must be None.*" + message):
        jaxcontact.all_to_all(xs, surface, radius=0.5, mask=mask, normals=Smooth())
    # A 3D result is refused by the forces and the slip history, which spread onto two
    # nodes and slip along a line (a silent wrong answer otherwise).
    contact = jaxcontact.all_to_all(xs, surface, radius=0.5, mask=mask)
    with pytest.raises(ValueError, match=r"^contact is a 3D result .*" + message):
        jaxcontact.forces.penalty(contact, surface, 1.0)
    with pytest.raises(ValueError, match=r"^contact is a 3D result .*" + message):
        jaxcontact.forces.coulomb(
            contact,
            jaxcontact.Slip(jnp.zeros(48), jnp.zeros(48, bool), jnp.zeros((48, 2))),
            jaxcontact.forces.Friction.zeros(48),
            surface,
            stiffness=1.0,
            tangent_stiffness=1.0,
            mu=0.3,
        )
    with pytest.raises(ValueError, match=r"^contact is a 3D result .*" + message):
        jaxcontact.track(contact, contact, surface)


def test_mismatched_dimensions_name_the_argument():
    x = jnp.zeros((3, 3))
    with pytest.raises(
        ValueError, match=r"^x has 3 .* surface.nodes must have shape \(P, 3\).*\(4, 2\)"
    ):
        jaxcontact.all_to_all(x, Surface(jnp.zeros((4, 2)), jnp.asarray([[0, 1]])), radius=1.0)
    with pytest.raises(ValueError, match=r"surface.segments must have shape \(M, 3\).*\(1, 2\)"):
        jaxcontact.all_to_all(x, Surface(jnp.zeros((4, 3)), jnp.asarray([[0, 1]])), radius=1.0)
    with pytest.raises(ValueError, match=r"x must have shape \(N, 2\) or \(N, 3\).*\(3, 4\)"):
        jaxcontact.all_to_all(
            jnp.zeros((3, 4)), Surface(jnp.zeros((4, 3)), jnp.zeros((1, 3), int)), radius=1.0
        )


def test_an_empty_surface_and_no_slaves():
    xs, surface, mask = padded(random_slaves(0), *star_mesh(0))
    empty = Surface(surface.nodes, jnp.zeros((0, 3), jnp.int32))
    contact = jaxcontact.all_to_all(xs, empty, radius=0.5)
    assert contact.xi.shape == (48, 2) and contact.vertex.shape == (48, 2)
    assert not contact.found.any()
    none = jaxcontact.all_to_all(jnp.zeros((0, 3)), surface, radius=0.5)
    assert none.point.shape == (0, 3)


# -- the quad helper -------------------------------------------------------------


def test_split_quads_keeps_the_orientation_and_the_box_is_closed():
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    np.testing.assert_array_equal(split_quads(quads), [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    for subdivisions in (1, 2):
        box = box_surface((0.0, 0.0, 0.0), (1.0, 2.0, 3.0), subdivisions, dtype=np.float64)
        nodes, triangles = np.asarray(box.nodes), np.asarray(box.segments)
        assert triangles.shape == (12 * subdivisions**2, 3)
        a, b, c = (nodes[triangles[:, i]] for i in range(3))
        # Closed and outward: the signed volume is the box's, and every edge
        # is met once in each direction.
        volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
        np.testing.assert_allclose(volume, 6.0, rtol=0, atol=FLOAT64_ATOL)
        edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
        assert {tuple(e) for e in edges} == {tuple(e) for e in edges[:, ::-1]}
        assert len({tuple(e) for e in edges}) == len(edges)
    with pytest.raises(ValueError, match=r"quads must have shape \(Q, 4\)"):
        split_quads(np.zeros((2, 3), int))
