"""AISI 1045 for the cutting simulation: J2 plasticity with Johnson–Cook flow stress.

The constitutive update an explicit plane-strain code calls once per
integration point and step: given the stress at the start of the step, a
strain increment (in the frame the element formulation rotates the stress
into: this module is rate-form and frame-free, objectivity is the
element's job), the equivalent plastic strain and the temperature, it
returns the stress, plastic strain and temperature at the end of the step.

Model (all in mm, N, tonne, s, K: stresses in MPa, energies in mJ):

* Isotropic linear elasticity (Hooke), plane strain: ``eps_zz = 0`` and
  ``sigma_zz`` carried as a state.
* J2 (von Mises) yield ``q = sqrt(3/2 s:s) <= sigma_y``, associated flow,
  isotropic hardening, by the radial return mapping (Simo and Hughes,
  *Computational Inelasticity*, 1998, section 3.3): the trial deviatoric
  stress is scaled back to the yield surface along itself, so the plastic
  strain is deviatoric (no plastic volume change) and the pressure stays
  elastic.
* Johnson–Cook flow stress (Johnson and Cook, 1983)::

    sigma_y = (A + B eps_p^n) (1 + C ln(max(rate / rate_0, 1))) (1 - T*^m),
    T* = (T - T_room) / (T_melt - T_room), clipped to [0, 1],

  with the AISI 1045 parameters of Jaspers and Dautzenberg (2002),
  "Material behaviour in conditions similar to metal cutting: flow stress
  in the primary shear zone", J. Mater. Process. Technol. 122, 322-330:
  A = 553.1 MPa, B = 600.8 MPa, n = 0.234, C = 0.0134, m = 1.0,
  rate_0 = 1/s, T_melt = 1460 °C, T_room = 25 °C. The plastic strain rate is
  the step's ``d eps_p / dt``, so the rate term is part of the return
  mapping's equation, solved implicitly.
* Adiabatic heating: a share ``taylor_quinney = 0.9`` (Taylor and Quinney,
  1934) of the plastic work heats the point, ``dT = beta sigma_y d eps_p /
  (rho c)``, with ``rho = 7850 kg/m³`` and ``c = 486 J/(kg K)`` (handbook
  values for 1045 near room temperature; ASM Handbook vol. 1). The
  temperature of the step's start softens the step (explicit in T; the step
  is small). No conduction: at 100 m/min the primary shear zone deforms in
  microseconds, far faster than heat diffuses across it.

What it leaves out: kinematic hardening, damage, the temperature
dependence of the elastic constants and of ``c``, strain-rate effects below
``rate_0`` (the JC rate term is cut off at 1, as usual), and the JC fit's
validity range (Jaspers and Dautzenberg fitted strain rates up to about
1e4/s and temperatures up to about 600 °C; cutting reaches more).

Differentiable: the plastic multiplier is found by bisection (robust for
``n < 1``, whose hardening slope is infinite at ``eps_p = 0``) without
gradient, then given the exact implicit-function gradient of the
consistency condition, so ``jax.grad`` through a run differentiates the
converged update, not the iterations.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import Array

BISECTIONS = (
    60  # halvings of the bracket [0, q_trial / 3G]: past float64 resolution (half in float32)
)


class JohnsonCook(NamedTuple):
    """AISI 1045 by default. Units: MPa, t/mm³, mJ/(t K), K (°C + 273.15), 1/s."""

    young: float = 210_000.0  # MPa
    poisson: float = 0.3
    density: float = 7.85e-9  # t/mm³ (7850 kg/m³)
    specific_heat: float = 4.86e8  # mJ/(t K) (486 J/(kg K))
    A: float = 553.1  # MPa, Jaspers and Dautzenberg (2002)
    B: float = 600.8  # MPa
    n: float = 0.234
    C: float = 0.0134
    m: float = 1.0
    reference_rate: float = 1.0  # 1/s
    melting: float = 1460.0 + 273.15  # K
    room: float = 25.0 + 273.15  # K
    taylor_quinney: float = 0.9

    @property
    def shear_modulus(self) -> float:
        return self.young / (2 * (1 + self.poisson))

    @property
    def bulk_modulus(self) -> float:
        return self.young / (3 * (1 - 2 * self.poisson))


class PointState(NamedTuple):
    """What an integration point carries: arrays of any common batch shape ``S``."""

    stress: Array  # f[S, 4]  sigma_xx, sigma_yy, sigma_zz, sigma_xy (MPa)
    plastic_strain: Array  # f[S]  equivalent plastic strain eps_p
    temperature: Array  # f[S]  K

    @staticmethod
    def at_rest(shape, material: JohnsonCook | None = None, dtype=jnp.float32) -> PointState:
        """Unstressed, no plastic strain, at room temperature."""
        material = JohnsonCook() if material is None else material
        shape = tuple(shape) if not isinstance(shape, int) else (shape,)
        return PointState(
            jnp.zeros(shape + (4,), dtype),
            jnp.zeros(shape, dtype),
            jnp.full(shape, material.room, dtype),
        )


def flow_stress(material: JohnsonCook, plastic_strain, rate, temperature) -> Array:
    """The Johnson–Cook flow stress (MPa) at ``plastic_strain``, ``rate`` (1/s) and
    ``temperature`` (K)."""
    eps = jnp.maximum(plastic_strain, 0)
    # eps^n with a gradient that stays finite at eps = 0 (where the slope of
    # eps^n, n < 1, is infinite): 0 there.
    positive = eps > 0
    power = jnp.where(positive, jnp.where(positive, eps, 1) ** material.n, 0)
    ratio = jnp.maximum(rate / material.reference_rate, 1)
    homologous = jnp.clip((temperature - material.room) / (material.melting - material.room), 0, 1)
    softening = 1 - homologous**material.m
    return (material.A + material.B * power) * (1 + material.C * jnp.log(ratio)) * softening


def _deviator(stress: Array) -> tuple[Array, Array]:
    """(deviatoric stress f[..., 4], pressure f[...]) of (xx, yy, zz, xy)."""
    pressure = jnp.mean(stress[..., :3], axis=-1)
    return stress - jnp.stack([pressure, pressure, pressure, 0 * pressure], -1), pressure


def von_mises(stress: Array) -> Array:
    """q = sqrt(3/2 s:s) of (xx, yy, zz, xy) stresses (MPa)."""
    s, _ = _deviator(stress)
    contracted = 1.5 * (jnp.sum(s[..., :3] ** 2, axis=-1) + 2 * s[..., 3] ** 2)
    # 0 with a zero gradient at zero stress (sqrt's slope is infinite there).
    positive = contracted > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, contracted, 1)), 0)


def update(
    material: JohnsonCook, state: PointState, strain_increment: Array, dt
) -> tuple[PointState, Array]:
    """One step of the constitutive update: the point's state after ``strain_increment``.

    Args:
      material: the ``JohnsonCook`` parameters.
      state: the ``PointState`` at the start of the step.
      strain_increment: f[S, 3], ``(d eps_xx, d eps_yy, d gamma_xy)`` in
        plane strain (``gamma_xy = 2 eps_xy``; ``d eps_zz = 0``), or f[S, 4],
        ``(d eps_xx, d eps_yy, d eps_zz, d gamma_xy)`` (a B-bar element's
        strain has a ``zz`` part), in the frame of ``state.stress``.
      dt: the step's duration (s), for the plastic strain rate.

    Returns:
      ``(state, plastic_increment)``: the new ``PointState`` and the step's
      ``d eps_p`` (f[S]), whose ``sigma_y d eps_p`` is the plastic work.
    """
    g, k = material.shear_modulus, material.bulk_modulus
    dxx, dyy, dgamma = strain_increment[..., 0], strain_increment[..., 1], strain_increment[..., -1]
    dzz = strain_increment[..., 2] if strain_increment.shape[-1] == 4 else jnp.zeros_like(dxx)
    volume = dxx + dyy + dzz
    mean = volume / 3
    # Hooke in rates: d sigma = 2 G de + K d(tr eps) I, de the deviatoric increment.
    increment = jnp.stack(
        [
            2 * g * (dxx - mean) + k * volume,
            2 * g * (dyy - mean) + k * volume,
            2 * g * (dzz - mean) + k * volume,
            g * dgamma,
        ],
        axis=-1,
    )
    trial = state.stress + increment
    deviator, pressure = _deviator(trial)
    q_trial = von_mises(trial)
    temperature = state.temperature

    def residual(delta):
        rate = delta / dt
        return (
            q_trial
            - 3 * g * delta
            - flow_stress(material, state.plastic_strain + delta, rate, temperature)
        )

    yielding = residual(jnp.zeros_like(q_trial)) > 0
    # Bisection on [0, q_trial / 3G] (the residual falls monotonically with
    # delta and is <= 0 at the upper end), without gradient.
    high = jax.lax.stop_gradient(jnp.where(yielding, q_trial / (3 * g), 0))
    low = jnp.zeros_like(high)

    def halve(_, bracket):
        low, high = bracket
        middle = 0.5 * (low + high)
        above = jax.lax.stop_gradient(residual(middle)) > 0
        return jnp.where(above, middle, low), jnp.where(above, high, middle)

    # float32 resolves the bracket in about 26 halvings; float64 in about 55.
    halvings = BISECTIONS if q_trial.dtype == jnp.float64 else BISECTIONS // 2
    low, high = jax.lax.fori_loop(0, halvings, halve, (low, high))
    root = jax.lax.stop_gradient(0.5 * (low + high))
    # The implicit-function gradient: d delta = -(d residual) / (d residual / d delta).
    slope = jax.lax.stop_gradient(jax.grad(lambda d: jnp.sum(residual(d)))(root))
    safe_slope = jnp.where(slope < 0, slope, -3 * g)
    value = residual(root)
    delta = root - (value - jax.lax.stop_gradient(value)) / safe_slope
    delta = jnp.where(yielding, delta, 0)
    # Radial return: the deviator scaled back along itself to q = sigma_y.
    safe_q = jnp.where(yielding, q_trial, 1)
    scale = jnp.where(yielding, 1 - 3 * g * delta / safe_q, 1)
    stress = deviator * scale[..., None] + jnp.stack(
        [pressure, pressure, pressure, 0 * pressure], -1
    )
    plastic_strain = state.plastic_strain + delta
    heat = material.taylor_quinney * von_mises(stress) * delta
    temperature = temperature + heat / (material.density * material.specific_heat)
    return PointState(stress, plastic_strain, temperature), delta
