"""Gradients through the slip history over many steps.

A slave dragged along a master under a sticking Coulomb contact: the stick
spring's force after ``k`` steps is ``-k_t`` times the whole distance slid, so
the friction force depends on every past step's closest point. ``jax.grad``
of the force through a ``lax.scan`` must equal finite differences: the
history's projection coordinate carries its gradient to the next step (a
history held as a constant counts each step's slip from a point that does
not move with the parameters, and the sum of the increments no longer
telescopes).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact.forces import Friction, coulomb
from tests.support.tolerances import CLOSED_FORM_RTOL, FD_HISTORY_RTOL

pytestmark = pytest.mark.x64

# A floor from x = 4 to x = -4 (right to left: its normal points up, +y).
FLOOR = jaxcontact.Surface(jnp.array([[4.0, 0.0], [-4.0, 0.0]]), jnp.array([[0, 1]]))
SEARCH = jaxcontact.Search(radius=0.5, method="exhaustive", track=True)
STEPS = 12


def dragged(speed, mu):
    """The friction force on a slave pressed 0.01 into the floor and moved
    ``speed`` per step along it, summed over the steps."""
    start = jnp.array([[-1.0, -0.01]])
    state = SEARCH.init(start, FLOOR, sizes=None)

    def step(carry, k):
        state, friction = carry
        x = start + jnp.stack([speed * k, 0.0 * k])[None, :]
        contact, state = SEARCH.closest(state, x, FLOOR)
        forces, friction = coulomb(
            contact, state.slip, friction, FLOOR, stiffness=100.0, tangent_stiffness=50.0, mu=mu
        )
        return (state, friction), forces.on_slaves[0, 0]

    _, tangential = jax.lax.scan(
        step, (state, Friction.zeros(1, jnp.float64)), jnp.arange(STEPS, dtype=jnp.float64)
    )
    return tangential.sum()


@pytest.mark.parametrize("mu", [50.0, 0.3])  # sticking all along; sliding after a few steps
def test_the_friction_force_differentiates_through_the_history(mu):
    value_and_grad = jax.jit(jax.value_and_grad(dragged))
    speed = jnp.float64(0.01)
    value, gradient = value_and_grad(speed, mu)
    step = 1e-6
    difference = (value_and_grad(speed + step, mu)[0] - value_and_grad(speed - step, mu)[0]) / (
        2 * step
    )
    np.testing.assert_allclose(float(gradient), float(difference), rtol=FD_HISTORY_RTOL)
    if mu == 50.0:
        # Sticking: the spring holds -k_t times the distance, summed over the steps.
        expected = -50.0 * sum(range(STEPS))
        np.testing.assert_allclose(float(gradient), expected, rtol=CLOSED_FORM_RTOL)
