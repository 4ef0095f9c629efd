"""The pieces of the cutting simulation together: an explicit plane-strain
compression of an AISI 1045 block by a rigid platen, through jaxcontact.

A 1 x 1 mm block of 4 x 4 elements (``elements.q4``), Johnson–Cook with
adiabatic heating (``materials.AISI_1045``), central differences
(``sim.explicit``), pressed by a rigid platen moving down at 1 m/s; the
contact is a ``jaxcontact.Search`` with the normal penalty of
``jaxcontact.forces``. Frictionless, the block deforms homogeneously, and
the platen's force per mm of width is plane-strain compression's
``(2 / sqrt(3)) sigma_y(eps_p, rate, T) w``, with ``eps_p = (2 / sqrt(3))
ln(h0 / h)`` and the width ``w = w0 h0 / h`` (plastic incompressibility).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact.forces import penalty
from jaxcontact.sim import explicit, materials
from jaxcontact.sim.elements import q4
from tests.support.tolerances import EXPLICIT_AREA_RTOL, EXPLICIT_FORCE_RTOL, EXPLICIT_HEAT_ATOL

pytestmark = pytest.mark.x64

STEEL = materials.AISI_1045
SPEED = 1000.0  # mm/s
TRAVEL = 0.12  # mm


def compress(stiffness=5.0e4):
    quads = q4.grid_mesh(1.0, 1.0, 4, 4, STEEL.density, jnp.float64)
    dt = explicit.stable_dt(quads, STEEL)
    steps = int(TRAVEL / SPEED / dt)
    bottom = np.asarray(quads.nodes[:, 1]) == 0
    fixed = np.zeros((25, 2), bool)
    fixed[bottom, 1] = True  # a frictionless floor (symmetry)
    fixed[0, 0] = True  # no rigid sliding
    search = jaxcontact.Search(radius=0.05, method="exhaustive")

    def platen(height):
        nodes = (
            jnp.stack([jnp.array([-1.0, 0.0]), jnp.array([2.0, 0.0])])
            + jnp.array([[0.0, 1.0]]) * height
        )
        return jaxcontact.Surface(nodes, jnp.array([[0, 1]]))  # left to right: normal down

    def step(carry, k):
        body, height = carry
        # The platen's speed ramps up over the first fifth of the run.
        height = height - dt * SPEED * jnp.minimum(1.0, 5.0 * k / steps)
        surface = platen(height)
        contact, _ = search.closest(search.init(body.x, surface, sizes=None), body.x, surface)
        on_slaves = penalty(contact, surface, stiffness).on_slaves
        body, _ = explicit.step(
            STEEL, quads, body, on_slaves, dt, explicit.Boundary(fixed=jnp.asarray(fixed))
        )
        top = jnp.mean(jnp.where(jnp.asarray(bottom)[:, None], 0.0, body.x)[20:, 1])
        return (body, height), (-on_slaves[:, 1].sum(), top, body.points.temperature.mean())

    start = (explicit.at_rest(quads, STEEL), jnp.float64(1.0))
    (body, _), (force, top, temperature) = jax.lax.scan(
        jax.jit(step), start, jnp.arange(steps, dtype=jnp.float64)
    )
    return body, np.asarray(force), np.asarray(top), np.asarray(temperature), steps


def plane_strain_force(height, heights_path):
    """(2/sqrt 3) sigma_y w at ``height``, heating integrated along the path, in NumPy."""
    m = STEEL
    factor = 2 / np.sqrt(3)
    eps = factor * np.log(1 / heights_path)
    rate = factor * SPEED / heights_path
    temperature = m.room
    for k in range(1, len(eps)):
        homologous = (temperature - m.room) / (m.melting - m.room)
        flow = (
            (m.A + m.B * max(eps[k], 0) ** m.n)
            * (1 + m.C * np.log(max(rate[k], 1)))
            * (1 - homologous)
        )
        temperature += (
            m.taylor_quinney * flow * (eps[k] - eps[k - 1]) / (m.density * m.specific_heat)
        )
    return factor * flow / height, temperature


def test_a_block_pressed_by_a_rigid_platen_takes_the_plane_strain_flow_stress():
    body, force, top, temperature, steps = compress()
    assert steps > 1000
    assert np.isfinite(force).all()
    # The last tenth of the run: the force rings about its quasi-static value.
    late = slice(int(0.9 * steps), None)
    height = float(top[late].mean())
    assert 0.88 < height < 0.93  # compressed by about 10 %
    expected, heated = plane_strain_force(height, np.linspace(1.0, height, 400))
    np.testing.assert_allclose(force[late].mean(), expected, rtol=EXPLICIT_FORCE_RTOL)
    np.testing.assert_allclose(temperature[late].mean(), heated, atol=EXPLICIT_HEAT_ATOL)
    # Homogeneous: every point has nearly the same plastic strain, and the block kept its area.
    eps = np.asarray(body.points.plastic_strain)
    assert eps.min() > 0.9 * eps.mean()
    corners = np.asarray(body.x)
    width = corners[4, 0] - corners[0, 0]
    np.testing.assert_allclose(width * height, 1.0, rtol=EXPLICIT_AREA_RTOL)
