"""How to check a gradient through penalty contact (the contract's differentiability section).

A penalty force switches on where a node's gap crosses 0, so a run's objective has a kink at
every contact onset. A central difference whose step carries a node across its onset measures
neither side's slope and disagrees with ``jax.grad``; one whose step stays inside one contact
pattern agrees. Here three nodes fall onto a flat floor in a short ``lax.scan``: gaps are the
nodes' heights and forces linear in them, so between onsets the final heights are affine in
the drop height, and a central difference there is exact but for rounding at any step.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import Surface, all_to_all
from jaxcontact.forces import penalty
from tests.support.tolerances import FD_ATOL, FD_RTOL

# A floor along y = 0 listed right to left, so its normal points up (+y).
FLOOR_NODES = [[2.0, 0.0], [-2.0, 0.0]]
# Three nodes at these heights above the drop height, falling at 1 per unit time.
SPREAD = [[-1.0, 0.0], [0.0, 0.013], [1.0, 0.027]]
STIFFNESS, MASS, DT, STEPS = 1.0e3, 1.0, 0.01, 8
# At this drop height the first node is 3e-4 above the floor at step 3 (it falls 0.03 by
# then): a step of 1e-3 carries it across its onset, one of 1e-6 does not.
NEAR_ONSET = 0.0303
# Here every node stays at least 1.5e-3 (in drop height) from each onset.
AWAY = 0.0345
LARGE_STEP, SMALL_STEP = 1e-3, 1e-6


def run(height):
    """The nodes' final heights summed, and which were active at each step (float64)."""
    floor = Surface(jnp.array(FLOOR_NODES, jnp.float64), jnp.array([[0, 1]]))

    def step(carry, _):
        x, v = carry
        contact = all_to_all(x, floor, radius=0.1)
        force = penalty(contact, floor, STIFFNESS).on_slaves
        v = v + DT * force / MASS
        return (x + DT * v, v), contact.active

    x0 = jnp.array(SPREAD, jnp.float64).at[:, 1].add(height)
    v0 = jnp.zeros_like(x0).at[:, 1].set(-1.0)
    (x, _), active = jax.lax.scan(step, (x0, v0), None, length=STEPS)
    return x[:, 1].sum(), active


objective = jax.jit(lambda height: run(height)[0])
pattern = jax.jit(lambda height: run(height)[1])
gradient = jax.jit(jax.grad(objective))


def central(height, step):
    return (objective(height + step) - objective(height - step)) / (2 * step)


def crosses_an_onset(height, step):
    """Whether some node's contact switches between ``height - step`` and ``height + step``."""
    return not bool((pattern(height - step) == pattern(height + step)).all())


@pytest.mark.x64
def test_a_step_across_a_contact_onset_misses_the_gradient_and_a_smaller_one_agrees():
    height = jnp.float64(NEAR_ONSET)
    exact = float(gradient(height))
    assert bool(pattern(height).any())  # contact happens during the run
    # A step of 1e-3 carries the first node across its onset: the central difference
    # averages the slopes on both sides of the kink.
    assert crosses_an_onset(height, LARGE_STEP)
    assert not np.isclose(float(central(height, LARGE_STEP)), exact, rtol=FD_RTOL, atol=FD_ATOL)
    # A step of 1e-6 is smaller than every node's distance from its onset: it agrees.
    assert not crosses_an_onset(height, SMALL_STEP)
    np.testing.assert_allclose(
        float(central(height, SMALL_STEP)), exact, rtol=FD_RTOL, atol=FD_ATOL
    )


@pytest.mark.x64
def test_away_from_every_onset_even_a_large_step_agrees():
    height = jnp.float64(AWAY)
    assert bool(pattern(height).any())
    assert not crosses_an_onset(height, LARGE_STEP)
    np.testing.assert_allclose(
        float(central(height, LARGE_STEP)), float(gradient(height)), rtol=FD_RTOL, atol=FD_ATOL
    )
