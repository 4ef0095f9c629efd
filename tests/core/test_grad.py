"""Gradients: right on smooth inputs, finite (and zero for padding) everywhere else."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

import jaxcontact
from jaxcontact import Surface
from tests.support.oracle import oracle_contact, oracle_crossing
from tests.support.tolerances import FLOAT64_EXACT_ATOL

MODES = pytest.mark.parametrize("mode", ["fwd", "rev"])

# A concave corner: the master fills {y < 0} u {x < 0}, outline (2, 0) -> (0, 0) -> (0, 2).
L_NODES = np.array([[2.0, 0.0], [0.0, 0.0], [0.0, 2.0]])
L_SEGMENTS = np.array([[0, 1], [1, 2]], np.int32)
# Each slave projects strictly inside one face, well away from the other face,
# from the radius (0.5) and from the corner, so a small step changes no choice.
SMOOTH_SLAVES = np.array([[1.3, 0.2], [0.7, -0.15], [0.25, 1.1], [-0.3, 1.6]])
RADIUS = 0.5


def contact_fields(x, nodes, segments=L_SEGMENTS, seg_mask=None, mask=None, radius=RADIUS):
    surface = Surface(nodes, jnp.asarray(segments), seg_mask)
    contact = jaxcontact.all_to_all(x, surface, radius=radius, mask=mask)
    return contact.gap, contact.point


def test_smooth_scene_is_really_smooth():
    # Guards the premise of the gradient checks below (on the oracle: the
    # premise is about the geometry, and it costs no compilation).
    expected = oracle_contact(SMOOTH_SLAVES, L_NODES, L_SEGMENTS, radius=RADIUS)
    assert expected.found.all()
    np.testing.assert_array_equal(expected.segment, [0, 0, 1, 1])
    assert np.all((expected.xi > 0.1) & (expected.xi < 0.9))
    assert np.all(np.abs(expected.gap) < RADIUS - 0.1)
    # Each slave is at least 0.3 farther from the other face than from its own.
    for i, own in enumerate(expected.segment):
        other = L_SEGMENTS[1 - own : 2 - own]
        distance = abs(oracle_contact(SMOOTH_SLAVES[i], L_NODES, other, radius=10.0).gap[0])
        assert distance > abs(expected.gap[i]) + 0.3


@MODES
def test_gap_and_point_gradients_match_finite_differences(mode):
    # Jointly in x and surface.nodes (check_grads perturbs both along random
    # directions): one compilation per mode rather than one per argument.
    fields = jax.jit(contact_fields)
    check_grads(fields, (jnp.asarray(SMOOTH_SLAVES), jnp.asarray(L_NODES)), order=1, modes=[mode])


def test_crossing_gradients_match_finite_differences():
    # Transversal crossings through the interior of one face each, far from
    # its ends. Reverse mode only, as gradients of a loss are taken; forward
    # mode goes through the same kernels and is checked for the contact above.
    x_prev = np.array([[1.2, 0.5], [0.6, 1.3]])
    x = np.array([[1.4, -0.5], [-0.4, 1.1]])
    expected = oracle_crossing(x_prev, x, L_NODES, L_SEGMENTS)
    np.testing.assert_array_equal(expected.segment, [0, 1])
    assert np.all((expected.t > 0.1) & (expected.t < 0.9))
    segments = jnp.asarray(L_SEGMENTS)

    @jax.jit
    def fields(x_prev, x, nodes):
        crossing = jaxcontact.swept(x_prev, x, Surface(nodes, segments))
        return crossing.t, crossing.point

    check_grads(fields, (jnp.asarray(x_prev), jnp.asarray(x), jnp.asarray(L_NODES)), 1, ["rev"])


@jax.jit
def contact_gradients(x, nodes, segments, seg_mask, mask):
    """``[(d gap.sum() / dx, d gap.sum() / dnodes), (the same for point.sum())]``."""

    def total(x, nodes, index):
        return contact_fields(x, nodes, segments, seg_mask, mask, radius=1.0)[index].sum()

    return [jax.grad(total, argnums=(0, 1))(x, nodes, index) for index in (0, 1)]


# Every case has 4 slaves, 5 nodes and 4 segments (and both masks), so that one
# compilation of contact_gradients serves them all: the L's two faces, and two
# more segments between nodes 3 and 4 that vary by case.
ALL = np.ones(4, bool)
FAR_NODES = np.concatenate([L_NODES, [[5.0, 5.0], [6.0, 5.0]]])
FAR_SEGMENTS = np.array([[0, 1], [1, 2], [3, 4], [4, 3]], np.int32)
DEGENERATE = {  # x, nodes, segments, seg_mask, mask
    # The L's three vertices (the middle one shared) and a vertex shared by two
    # coincident segments of opposite direction.
    "slaves_on_vertices": (
        [[2.0, 0.0], [0.0, 0.0], [0.0, 2.0], [5.0, 5.0]],
        FAR_NODES,
        FAR_SEGMENTS,
        ALL,
        ALL,
    ),
    "slaves_on_segments": (
        [[1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [5.5, 5.0]],
        FAR_NODES,
        FAR_SEGMENTS,
        ALL,
        ALL,
    ),
    # Nodes 3 and 4 coincide (zero-length segment 2); segment 3 uses node 1 twice.
    "slaves_on_zero_length_segments": (
        [[1.0, 1.0], [0.0, 0.0], [1.0, 1.0 + 2.0**-20], [0.5, 0.5]],
        np.concatenate([L_NODES, [[1.0, 1.0], [1.0, 1.0]]]),
        np.array([[0, 1], [1, 2], [3, 4], [1, 1]], np.int32),
        ALL,
        ALL,
    ),
    # NaN and inf in masked slaves, and in nodes that only masked segments use.
    "nan_and_inf_padding": (
        [[np.nan, np.nan], [1.0, 0.25], [np.inf, 0.0], [0.0, 0.0]],
        np.concatenate([L_NODES, [[np.nan, np.nan], [np.inf, -np.inf]]]),
        np.array([[0, 1], [3, 4], [1, 2], [0, 3]], np.int32),
        np.array([True, False, True, False]),
        np.array([False, True, False, True]),
    ),
}


@pytest.mark.parametrize("case", list(DEGENERATE))
def test_gap_and_point_gradients_are_finite_on_degenerate_inputs(case):
    x, nodes, segments, seg_mask, mask = (jnp.asarray(value) for value in DEGENERATE[case])
    gradients = contact_gradients(x, nodes, segments, seg_mask, mask)
    for field, (grad_x, grad_nodes) in zip(["gap", "point"], gradients, strict=True):
        assert jnp.isfinite(grad_x).all(), (field, grad_x)
        assert jnp.isfinite(grad_nodes).all(), (field, grad_nodes)
        # Padding changes no result, so no result depends on it.
        np.testing.assert_array_equal(grad_x[~mask], 0)
        np.testing.assert_array_equal(grad_nodes[~jnp.isfinite(nodes)], 0)


def test_gap_gradient_on_a_face_is_its_normal():
    # gap = (x - p) . n is smooth across the interior of a face: a slave on the
    # face has the gradient of its neighbours, the outward normal. (The fourth
    # slave lies on segment 2, (5, 5) -> (6, 5), whose normal points down.)
    x, nodes, segments, seg_mask, mask = (
        jnp.asarray(value) for value in DEGENERATE["slaves_on_segments"]
    )
    (grad_x, _), _ = contact_gradients(x, nodes, segments, seg_mask, mask)
    np.testing.assert_allclose(
        grad_x, [[0.0, 1.0], [1.0, 0.0], [0.0, 1.0], [0.0, -1.0]], rtol=0, atol=FLOAT64_EXACT_ATOL
    )


def test_crossing_gradients_are_finite_on_degenerate_inputs():
    # Grazing an end point, collinear, zero motion on the segment and on an end
    # point, arriving exactly at t = 1, a NaN padding slave (masked), and a NaN
    # node that only a masked segment uses.
    x_prev = jnp.array(
        [[0.0, 2.0], [1.0, -1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 1.0], [np.nan, np.nan]]
    )
    x = jnp.array([[2.0, 2.0], [1.0, 3.0], [1.0, 1.0], [1.0, 2.0], [1.0, 1.0], [np.nan, 0.0]])
    nodes = jnp.array([[1.0, 0.0], [1.0, 2.0], [np.nan, np.inf]])
    surface = Surface(nodes, jnp.array([[0, 1], [1, 2]], jnp.int32), jnp.array([True, False]))
    mask = jnp.array([True] * 5 + [False])

    def total(x_prev, x, nodes):
        crossing = jaxcontact.swept(x_prev, x, surface._replace(nodes=nodes), mask=mask)
        return crossing.t.sum() + crossing.point.sum(), crossing.crossed

    gradient = jax.jit(jax.grad(total, argnums=(0, 1, 2), has_aux=True))
    (grad_prev, grad_x, grad_nodes), crossed = gradient(x_prev, x, nodes)
    np.testing.assert_array_equal(crossed, [True] * 5 + [False])
    for grad in (grad_prev, grad_x, grad_nodes):
        assert jnp.isfinite(grad).all(), grad
    np.testing.assert_array_equal(grad_prev[5], 0)
    np.testing.assert_array_equal(grad_x[5], 0)
    np.testing.assert_array_equal(grad_nodes[2], 0)
