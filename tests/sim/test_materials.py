"""The materials (``sim.materials``): J2 plasticity, Johnson–Cook AISI 1045, adiabatic heating.

Checked against the formulas themselves (written out here in NumPy) along
monotonic plane-strain paths: consistency (the stress stays on the yield
surface of the current plastic strain, rate and temperature), plastic
incompressibility (the pressure stays elastic), the temperature rise from
the plastic work, and gradients through a run against finite differences.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from jaxcontact.sim.materials import AISI_1045, PointState, von_mises
from tests.support.tolerances import (
    FD_MATERIAL_STEP,
    FD_RTOL,
    FLOAT64_RTOL,
    FLOAT64_STEPS_RTOL,
    FORCE_ATOL,
    RATE_HARDENING_RTOL,
)

pytestmark = pytest.mark.x64

STEEL = AISI_1045
DT = 1e-6  # s


def flow_stress(material, plastic_strain, rate, temperature):
    return material.flow_stress(plastic_strain, rate, temperature)


def update(material, state, strain_increment, dt):
    return material.update(state, strain_increment, dt)


def johnson_cook(eps, rate, temperature, m=STEEL):
    """The flow stress of Jaspers and Dautzenberg (2002), in NumPy."""
    homologous = np.clip((temperature - m.room) / (m.melting - m.room), 0, 1)
    rate_term = 1 + m.C * np.log(np.maximum(rate / m.reference_rate, 1))
    return (m.A + m.B * np.maximum(eps, 0) ** m.n) * rate_term * (1 - homologous**m.m)


def run(material, increments, dt=DT):
    """States after each of ``increments`` (f[T, 3]) at one point, in one scan."""
    start = PointState.at_rest((), material, jnp.float64)

    def step(state, increment):
        state, delta = update(material, state, increment, dt)
        return state, (state, delta)

    return jax.lax.scan(step, start, increments)[1]


def test_flow_stress_is_the_johnson_cook_law():
    eps = np.array([0.0, 0.05, 0.5, 2.0, 0.5, 0.5])
    rate = np.array([0.5, 1.0, 1e3, 1e5, 1e3, 1e3])
    temperature = STEEL.room + np.array([0.0, 0.0, 200.0, 575.0, 1500.0, -50.0])
    got = flow_stress(STEEL, jnp.asarray(eps), jnp.asarray(rate), jnp.asarray(temperature))
    np.testing.assert_allclose(
        np.asarray(got), johnson_cook(eps, rate, temperature), rtol=FLOAT64_RTOL
    )
    assert float(got[0]) == pytest.approx(
        553.1, rel=FLOAT64_RTOL
    )  # A, at room temperature and the reference rate
    assert float(got[4]) == 0.0  # past melting
    grad = jax.grad(lambda e: flow_stress(STEEL, e, 1.0, STEEL.room))(0.0)
    assert np.isfinite(float(grad))  # eps^n's slope is infinite at 0: no NaN


def test_pure_shear_stays_on_the_yield_surface_and_heats_by_the_plastic_work():
    increments = jnp.tile(jnp.array([[0.0, 0.0, 2e-3]]), (400, 1))  # shear rate 2000/s
    states, delta = run(STEEL, increments)
    q = np.asarray(von_mises(states.stress))
    eps = np.asarray(states.plastic_strain)
    temperature = np.asarray(states.temperature)
    d = np.asarray(delta)
    plastic = d > 0
    assert 0 < plastic.argmax() < 5 and plastic[plastic.argmax() :].all()
    # Consistency: q = sigma_y(eps_p, d eps_p / dt, T at the step's start).
    start_temperature = np.concatenate([[STEEL.room], temperature[:-1]])
    expected = johnson_cook(eps, d / DT, start_temperature)
    np.testing.assert_allclose(q[plastic], expected[plastic], rtol=FLOAT64_STEPS_RTOL)
    # Incompressible plastic flow: pure shear keeps the pressure and the normal stresses at 0.
    np.testing.assert_allclose(np.asarray(states.stress[:, :3]), 0, atol=FORCE_ATOL)
    # eps_p = (gamma - tau / G) / sqrt(3) in pure shear.
    gamma = 2e-3 * np.arange(1, 401)
    tau = np.asarray(states.stress[:, 3])
    np.testing.assert_allclose(
        eps, (gamma - tau / STEEL.shear_modulus) / np.sqrt(3), rtol=FLOAT64_STEPS_RTOL
    )
    # The temperature rises by beta * plastic work / (rho c).
    work = np.cumsum(q * d)
    rise = STEEL.taylor_quinney * work / (STEEL.density * STEEL.specific_heat)
    np.testing.assert_allclose(
        temperature - STEEL.room, rise, rtol=FLOAT64_STEPS_RTOL, atol=FORCE_ATOL
    )
    assert 100 < rise[-1] < 200  # kelvin, at eps_p about 0.46
    # The heat softens (against the same run held at room temperature), and the
    # rate hardens (against that run a million times slower: below rate_0).
    isothermal = STEEL._replace(taylor_quinney=0.0)
    cold = float(von_mises(run(isothermal, increments)[0].stress)[-1])
    slow = float(von_mises(run(isothermal, increments, dt=1.0)[0].stress)[-1])
    assert slow < cold and q[-1] < cold
    np.testing.assert_allclose(
        cold / slow, 1 + STEEL.C * np.log(d[-1] / DT), rtol=RATE_HARDENING_RTOL
    )


def test_plane_strain_compression_keeps_an_elastic_pressure():
    increments = jnp.tile(jnp.array([[-1e-3, 0.0, 0.0]]), (300, 1))
    states, delta = run(STEEL, increments)
    stress = np.asarray(states.stress)
    volume = -1e-3 * np.arange(1, 301)
    np.testing.assert_allclose(
        stress[:, :3].mean(-1), STEEL.bulk_modulus * volume, rtol=FLOAT64_STEPS_RTOL
    )
    assert float(delta[-1]) > 0
    # Below yield, one small increment is Hooke's law exactly, with no plastic strain.
    state, d = update(
        STEEL, PointState.at_rest((), STEEL, jnp.float64), jnp.array([1e-4, 0, 0]), DT
    )
    lam = STEEL.bulk_modulus - 2 * STEEL.shear_modulus / 3
    hooke = np.array([(lam + 2 * STEEL.shear_modulus) * 1e-4, lam * 1e-4, lam * 1e-4, 0])
    np.testing.assert_allclose(np.asarray(state.stress), hooke, rtol=FLOAT64_RTOL)
    assert float(d) == 0.0


def test_gradients_through_a_run_match_finite_differences():
    def final_stress(shear, A, B):
        material = STEEL._replace(A=A, B=B)
        increments = jnp.stack(
            [0.2 * shear * jnp.ones(60), -0.1 * shear * jnp.ones(60), shear * jnp.ones(60)], -1
        )
        states, _ = run(material, increments)
        return von_mises(states.stress)[-1] + states.temperature[-1]

    args = (jnp.float64(2e-3), jnp.float64(553.1), jnp.float64(600.8))
    grads = jax.grad(final_stress, argnums=(0, 1, 2))(*args)
    assert all(np.isfinite(float(g)) and float(g) != 0 for g in grads)
    check_grads(final_stress, args, order=1, modes=["rev"], eps=FD_MATERIAL_STEP, rtol=FD_RTOL)
