"""The Q4 element (``elements.q4``): updated-Lagrangian, B-bar, plane strain.

Checked against what the formulation must reproduce exactly: a uniform
strain (the patch test), a rigid rotation taken in steps (objectivity), the
nodal forces of a uniform stress, and a bending mode whose pointwise volume
change averages out (no volumetric locking: no pressure).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact.sim import materials
from jaxcontact.sim.elements import q4
from tests.support.tolerances import FLOAT64_EXACT_ATOL, FLOAT64_RTOL, FORCE_ATOL

pytestmark = pytest.mark.x64

STEEL = materials.AISI_1045


def distorted_mesh():
    """3 x 2 elements over 3 x 2 mm, the two interior nodes moved off the grid."""
    mesh = q4.grid_mesh(3.0, 2.0, 3, 2, STEEL.density, jnp.float64)
    nodes = mesh.nodes.at[5].add(jnp.array([0.17, -0.11])).at[6].add(jnp.array([-0.09, 0.21]))
    return mesh._replace(nodes=nodes)


def test_a_uniform_strain_is_reproduced_exactly_and_interior_nodes_balance():
    mesh = distorted_mesh()
    gradient = jnp.array([[1e-4, 3e-4], [-1e-4, -2e-4]])  # du_i / dX_j, elastic
    moved = mesh.nodes + mesh.nodes @ gradient.T
    strain, spin = q4.strain_and_spin(mesh, mesh.nodes, moved)
    # The midpoint gradient of a uniform H: H (I + H/2)^-1, the same at every point.
    midpoint = np.asarray(gradient) @ np.linalg.inv(np.eye(2) + 0.5 * np.asarray(gradient))
    expected = [midpoint[0, 0], midpoint[1, 1], 0.0, midpoint[0, 1] + midpoint[1, 0]]
    got = np.asarray(strain).reshape(-1, 4)
    np.testing.assert_allclose(got, np.tile(expected, (24, 1)), atol=FLOAT64_EXACT_ATOL)
    np.testing.assert_allclose(
        np.asarray(spin), 0.5 * (midpoint[0, 1] - midpoint[1, 0]), atol=FLOAT64_EXACT_ATOL
    )
    state = materials.PointState.at_rest((6, 4), STEEL, jnp.float64)
    state, delta = q4.step_material(STEEL, mesh, state, mesh.nodes, moved, 1e-6)
    assert float(jnp.abs(delta).max()) == 0.0
    forces = q4.internal_forces(mesh, moved, state.stress)
    np.testing.assert_allclose(np.asarray(forces[np.array([5, 6])]), 0, atol=FORCE_ATOL)
    np.testing.assert_allclose(np.asarray(forces.sum(0)), 0, atol=FORCE_ATOL)
    assert float(jnp.abs(forces).max()) > 1.0  # the boundary nodes do carry the stress


def test_a_uniform_stress_pulls_the_nodes_by_half_an_edge_each():
    mesh = q4.grid_mesh(2.0, 1.0, 1, 1, STEEL.density, jnp.float64)
    stress = jnp.tile(jnp.array([100.0, 0.0, 30.0, 0.0]), (1, 4, 1))  # sigma_xx = 100 MPa
    forces = np.asarray(q4.internal_forces(mesh, mesh.nodes, stress))
    # Nodes 0 and 2 on the left edge, 1 and 3 on the right: sigma h / 2 = 50 N/mm inwards.
    np.testing.assert_allclose(forces[:, 0], [50.0, -50.0, 50.0, -50.0], atol=FORCE_ATOL)
    np.testing.assert_allclose(forces[:, 1], 0, atol=FORCE_ATOL)
    np.testing.assert_allclose(float(mesh.mass.sum()), STEEL.density * 2.0, rtol=FLOAT64_RTOL)


def test_a_rigid_rotation_in_steps_turns_the_stress_and_strains_nothing():
    mesh = distorted_mesh()
    prestress = jnp.array([100.0, -40.0, 18.0, 25.0])
    state = materials.PointState.at_rest((6, 4), STEEL, jnp.float64)
    state = state._replace(stress=jnp.tile(prestress, (6, 4, 1)))
    angles = jnp.radians(jnp.arange(91.0))  # to 90 degrees, one at a time

    def place(angle):
        c, s = jnp.cos(angle), jnp.sin(angle)
        shift = jnp.array([1.0, -2.0]) * angle
        return mesh.nodes @ jnp.array([[c, -s], [s, c]]).T + shift[None, :]

    def step(state, pair):
        state, delta = q4.step_material(STEEL, mesh, state, place(pair[0]), place(pair[1]), 1e-6)
        return state, jnp.abs(delta).max()

    state, plastic = jax.lax.scan(step, state, jnp.stack([angles[:-1], angles[1:]], -1))
    assert float(plastic.max()) == 0.0
    # Turned by 90 degrees counter-clockwise: xx and yy swap, xy changes sign, zz stays.
    turned = np.array([-40.0, 100.0, 18.0, -25.0])
    got = np.asarray(state.stress).reshape(-1, 4)
    np.testing.assert_allclose(got, np.tile(turned, (24, 1)), atol=FORCE_ATOL)


def test_a_bending_mode_changes_no_element_volume_and_makes_no_pressure():
    mesh = q4.grid_mesh(1.0, 1.0, 1, 1, STEEL.density, jnp.float64)
    # u_x = a (x - 1/2)(y - 1/2): the volume changes by a (y - 1/2) at the Gauss
    # points, by nothing on average over the element.
    x, y = mesh.nodes[:, 0], mesh.nodes[:, 1]
    moved = mesh.nodes.at[:, 0].add(4e-4 * (x - 0.5) * (y - 0.5))
    strain, _ = q4.strain_and_spin(mesh, mesh.nodes, moved)
    np.testing.assert_allclose(np.asarray(strain[..., :3].sum(-1)), 0, atol=FLOAT64_EXACT_ATOL)
    state = materials.PointState.at_rest((1, 4), STEEL, jnp.float64)
    state, _ = q4.step_material(STEEL, mesh, state, mesh.nodes, moved, 1e-6)
    np.testing.assert_allclose(np.asarray(state.stress[..., :3].mean(-1)), 0, atol=FORCE_ATOL)
    assert float(jnp.abs(state.stress[..., 0]).max()) > 1.0  # yet it is stressed (deviatoric)
