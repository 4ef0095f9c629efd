"""The cut's ALE chip root and the chip's own friction limit (``jaxcontact.problems.cutting``
with ``Cutting(ale=...)`` and ``friction_limit="flow"``), on the coarse mesh of
tests/problems/test_cutting.py: the settings are checked, the limit is the chip's shear flow
stress, an ALE cut forms a chip and conserves the elements' mass, and ``jax.grad`` through
an ALE cut matches central differences. Its own file, so that CI's two workers run it beside
the Lagrangian cut's.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact.problems import cutting
from jaxcontact.sim import ale
from tests.support.tolerances import (
    FD_RUN_RTOL,
    FLOAT32_RTOL,
    FLOAT32_SUM_ATOL,
    FLOAT32_SUM_RTOL,
)

COARSE = dict(element=0.05, uncut=0.1, depth=0.1)  # as tests/problems/test_cutting.py's


def test_cut_settings_are_checked():
    with pytest.raises(ValueError, match="friction_limit must be 'flow'"):
        cutting.Cutting(friction_limit="constant")
    with pytest.raises(ValueError, match="Cutting.ale must be a sim.ale.Settings or None"):
        cutting.Cutting(ale=20)


def test_sticking_limit_is_the_chips_own_shear_flow_stress():
    cut = cutting.Cutting(travel=0.05, friction_limit="flow", shear_factor=0.9, **COARSE)
    model, state = cutting.setup(cut)
    elements = state.alive.shape[0]
    points = state.body.points._replace(
        plastic_strain=jnp.full((elements, 4), 1.5, jnp.float32),
        temperature=jnp.full((elements, 4), 900.0, jnp.float32),
    )
    state = state._replace(
        body=state.body._replace(points=points), rate=jnp.full(elements, 2e4, jnp.float32)
    )
    limit = cutting.sticking_limit(model, state)
    flow = float(cut.work_material.flow_stress(1.5, 2e4, 900.0))
    np.testing.assert_allclose(limit, 0.9 * flow / math.sqrt(3), rtol=FLOAT32_RTOL)
    # An eroded element does not count: a node of it alone has no limit.
    alive = state.alive.at[0].set(False)
    limit = cutting.sticking_limit(model, state._replace(alive=alive))
    corner = int(model.mesh.quads.quads[0, 0])  # the base's corner: of element 0 only
    assert float(limit[corner]) == 0.0
    law = cutting.tool_friction(model, state, 0.3)
    assert law.limit.shape == (model.mesh.quads.nodes.shape[0],)


def test_the_cap_is_carried_over_each_nodes_tributary_length():
    cut = cutting.Cutting(travel=0.05, **COARSE)
    model, state = cutting.setup(cut)
    # The uncut layer squeezed to half its length: its top nodes half as far apart.
    x = state.body.x.at[:, 0].multiply(0.5)
    share = np.asarray(cutting.contact_share(model, x, state.alive))
    top = np.asarray(model.mesh.top)
    np.testing.assert_allclose(share[top[1:-1]], 0.5 * cut.element, rtol=FLOAT32_RTOL)
    inside = np.setdiff1d(np.arange(x.shape[0]), np.asarray(model.mesh.slaves))
    assert (share[inside] == 0).all()
    law = cutting.tool_friction(model, state._replace(body=state.body._replace(x=x)), 0.3)
    np.testing.assert_array_equal(np.asarray(law.share), share)
    np.testing.assert_allclose(law.limit, 0.5 * cut.work_material.shear_yield, rtol=FLOAT32_RTOL)
    # The old call, one element for every node, still works and says what it does.
    with pytest.warns(DeprecationWarning, match="share="):
        old = cutting.friction_law(cut, 0.3)
    assert old.share == cut.element


def test_an_ale_cut_rezones_the_chip_root_and_conserves_mass():
    cut = cutting.Cutting(travel=0.15, ale=ale.Settings(every=20), **COARSE)
    model, state, record, _, _ = cutting.run(cut, 0.0, cutting.MU, chunks=3)
    assert np.isfinite(record.force).all() and not record.overflow.any()
    assert int(record.eroded[-1]) == 0
    # The rezone moved the mesh off the material: the ALE run differs from the Lagrangian.
    lagrangian = cutting.run(dataclasses.replace(cut, ale=None), 0.0, cutting.MU, chunks=3)[1]
    assert float(jnp.abs(state.body.x - lagrangian.body.x).max()) > 0.1 * cut.element
    # The remap conserves the elements' mass (the Lagrangian steps keep it).
    np.testing.assert_allclose(
        float(state.mass.sum()), float(cutting.setup(cut)[1].mass.sum()), rtol=FLOAT32_SUM_RTOL
    )
    # Chunks are whole ALE cycles.
    assert cutting.chunk_steps(cut, 41) == 60
    with pytest.raises(ValueError, match="whole ALE cycles of 20 steps"):
        cutting.advance(model, state, 0.0, cutting.MU, 30)


@pytest.mark.x64
def test_the_gradient_of_the_cutting_force_with_ale_matches_finite_differences():
    """As above, with the chip root rezoned and remapped every 10 steps and the friction
    limited by the chip's own flow stress."""
    cut = cutting.Cutting(
        travel=0.05,
        dtype="float64",
        ale=ale.Settings(every=10),
        friction_limit="flow",
        shear_factor=1.0,
        window=6.0,
        **COARSE,
    )
    model, state = cutting.setup(cut)

    def cutting_force(rake):
        return cutting.mean_forces(model, state, rake, 0.3)[0]

    force = jax.jit(jax.value_and_grad(cutting_force))
    rake = jnp.float64(math.radians(5.0))
    value, by_rake = force(rake)
    assert 20 < float(value) < 1000
    step = 1e-5
    central = (float(force(rake + step)[0]) - float(force(rake - step)[0])) / (2 * step)
    np.testing.assert_allclose(float(by_rake), central, rtol=FD_RUN_RTOL)


def test_observe_sees_each_step_of_the_run_advance_makes():
    cut = cutting.Cutting(travel=0.1, ale=ale.Settings(every=20), **COARSE)
    model, state = cutting.setup(cut)

    def probe(model, before, after, seen):
        return {"force": -seen.force.sum(0), "moved": seen.rezoned, "step": before.step}

    steps = 200
    observed, record, probed = cutting.observe(model, state, 0.0, cutting.MU, steps, probe)
    advanced, plain = cutting.advance(model, state, 0.0, cutting.MU, steps)
    np.testing.assert_array_equal(np.asarray(record.force), np.asarray(plain.force))
    np.testing.assert_array_equal(np.asarray(observed.body.x), np.asarray(advanced.body.x))
    # The tool's force is the sum of what each node feels from it.
    np.testing.assert_allclose(
        np.asarray(probed["force"]),
        np.asarray(record.force),
        rtol=FLOAT32_SUM_RTOL,
        atol=FLOAT32_SUM_ATOL,
    )
    np.testing.assert_array_equal(np.asarray(probed["step"]), np.arange(steps))
    # A rezone's move reaches the step after it, and no other.
    moved = np.asarray(probed["moved"])
    after_rezone = np.arange(steps) % cut.ale.every == 0
    assert np.isnan(moved[~after_rezone]).all() and np.isnan(moved[0])
    assert np.isfinite(moved[after_rezone][1:]).all()
    with pytest.raises(ValueError, match="probe must be a function"):
        cutting.observe(model, state, 0.0, cutting.MU, steps, None)
