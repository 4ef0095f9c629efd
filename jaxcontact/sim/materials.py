"""Materials behind one protocol: what an integration point carries and how it updates.

An element hands a material the strain increment of a step at each
integration point (in the frame the element rotated the stress into: the
update is rate-form and frame-free, objectivity is the element's job); the
material returns the point's new state and the step's plastic strain
increment. Two materials follow the protocol:

* ``Elastic``: isotropic linear elasticity (Hooke), rate form.
* ``JohnsonCook``: J2 (von Mises) plasticity with the Johnson–Cook flow
  stress and adiabatic heating.

Presets, each with its source: ``AISI_1045`` (Jaspers and Dautzenberg,
2002), ``AISI_4340`` and ``OFHC_COPPER`` (Johnson and Cook, 1983), and the
elastic ``STEEL``.

Units throughout: mm, N, tonne, s, K: stresses in MPa, densities in t/mm³,
specific heats in mJ/(t K) (1 J/(kg K) = 1e6 mJ/(t K)).

**Mass scaling** is a material's field, ``mass_scale``: explicit codes
multiply the density by it to lengthen the stable step (by its square
root). It scales inertia only: ``inertial_density`` is what masses, wave
speeds and bulk viscosity read, while heating reads the true ``density``,
so ``rho c`` and the adiabatic temperature rise stay the material's.

Plane strain: stresses are ``(sigma_xx, sigma_yy, sigma_zz, sigma_xy)``,
strain increments ``(d eps_xx, d eps_yy, d gamma_xy)`` or, from a B-bar
element, ``(d eps_xx, d eps_yy, d eps_zz, d gamma_xy)``.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

import jax
import jax.numpy as jnp
from jax import Array

__all__ = [
    "AISI_1045",
    "AISI_4340",
    "BISECTIONS",
    "Elastic",
    "JohnsonCook",
    "Material",
    "OFHC_COPPER",
    "PointState",
    "ROOM",
    "STEEL",
    "deviator",
    "hooke",
    "inertial_density",
    "von_mises",
    "wave_speed",
]

ROOM = 25.0 + 273.15  # K
# Halvings of the return mapping's bracket [0, q_trial / 3G]: past float64's
# resolution (half of them in float32).
BISECTIONS = 60


class PointState(NamedTuple):
    """What an integration point carries: arrays of any common batch shape ``S``."""

    stress: Array  # f[S, 4]  sigma_xx, sigma_yy, sigma_zz, sigma_xy (MPa)
    plastic_strain: Array  # f[S]  equivalent plastic strain eps_p
    temperature: Array  # f[S]  K

    @staticmethod
    def at_rest(shape, material: Material | None = None, dtype=jnp.float32) -> PointState:
        """Unstressed, no plastic strain, at the material's room temperature
        (``ROOM`` without one)."""
        shape = (shape,) if isinstance(shape, int) else tuple(shape)
        return PointState(
            jnp.zeros(shape + (4,), dtype),
            jnp.zeros(shape, dtype),
            jnp.full(shape, ROOM if material is None else material.room, dtype),
        )


class Material(Protocol):
    """The contract an element relies on (``elements.q4``, ``explicit``).

    Attributes:
      density: the true density (t/mm³).
      mass_scale: the density's factor for inertia (1: none).
      room: the temperature a point starts at (K).
      shear_modulus, bulk_modulus: elastic moduli (MPa), for wave speeds.
    """

    density: float
    mass_scale: float
    room: float

    @property
    def shear_modulus(self) -> float: ...

    @property
    def bulk_modulus(self) -> float: ...

    def update(self, state: PointState, strain_increment: Array, dt) -> tuple[PointState, Array]:
        """``(state, plastic_increment f[S])`` after ``strain_increment`` over ``dt`` (s)."""
        ...


def inertial_density(material: Material) -> float:
    """The density inertia sees (t/mm³): the true one times ``mass_scale``."""
    return material.density * material.mass_scale


def wave_speed(material: Material) -> float:
    """The dilatational wave speed ``sqrt((K + 4G/3) / rho)`` (mm/s), mass scaling included."""
    modulus = material.bulk_modulus + 4 * material.shear_modulus / 3
    return math.sqrt(modulus / inertial_density(material))


def hooke(shear_modulus, bulk_modulus, strain_increment: Array) -> Array:
    """f[S, 4]: the stress increment ``2 G de + K d(tr eps) I`` of a strain increment.

    ``strain_increment`` is f[S, 3] (plane strain, ``d eps_zz = 0``) or f[S, 4].
    """
    dxx, dyy, dgamma = strain_increment[..., 0], strain_increment[..., 1], strain_increment[..., -1]
    dzz = strain_increment[..., 2] if strain_increment.shape[-1] == 4 else jnp.zeros_like(dxx)
    volume = dxx + dyy + dzz
    mean = volume / 3
    g, k = shear_modulus, bulk_modulus
    return jnp.stack(
        [
            2 * g * (dxx - mean) + k * volume,
            2 * g * (dyy - mean) + k * volume,
            2 * g * (dzz - mean) + k * volume,
            g * dgamma,
        ],
        axis=-1,
    )


def deviator(stress: Array) -> tuple[Array, Array]:
    """(deviatoric stress f[..., 4], pressure-like mean stress f[...]) of (xx, yy, zz, xy)."""
    mean = jnp.mean(stress[..., :3], axis=-1)
    return stress - jnp.stack([mean, mean, mean, 0 * mean], -1), mean


def von_mises(stress: Array) -> Array:
    """q = sqrt(3/2 s:s) of (xx, yy, zz, xy) stresses (MPa)."""
    s, _ = deviator(stress)
    contracted = 1.5 * (jnp.sum(s[..., :3] ** 2, axis=-1) + 2 * s[..., 3] ** 2)
    # 0 with a zero gradient at zero stress (sqrt's slope is infinite there).
    positive = contracted > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, contracted, 1)), 0)


class Elastic(NamedTuple):
    """Isotropic linear elasticity. Steel's constants by default."""

    young: float = 210_000.0  # MPa
    poisson: float = 0.3
    density: float = 7.85e-9  # t/mm³
    mass_scale: float = 1.0
    room: float = ROOM  # K

    @property
    def shear_modulus(self) -> float:
        return self.young / (2 * (1 + self.poisson))

    @property
    def bulk_modulus(self) -> float:
        return self.young / (3 * (1 - 2 * self.poisson))

    @property
    def lame(self) -> tuple[float, float]:
        """(λ, μ) in MPa."""
        nu = self.poisson
        return self.young * nu / ((1 + nu) * (1 - 2 * nu)), self.shear_modulus

    @property
    def wave_speed(self) -> float:
        """The dilatational wave speed sqrt((λ + 2μ) / ρ) in mm/s, with mass scaling."""
        return wave_speed(self)

    def update(self, state: PointState, strain_increment: Array, dt):
        """Hooke's law in rates: no plastic strain, no heating."""
        del dt
        stress = state.stress + hooke(self.shear_modulus, self.bulk_modulus, strain_increment)
        return state._replace(stress=stress), jnp.zeros_like(state.plastic_strain)


class JohnsonCook(NamedTuple):
    """J2 plasticity with the Johnson–Cook flow stress (Johnson and Cook, 1983)::

        sigma_y = (A + B eps_p^n) (1 + C ln(max(rate / rate_0, 1))) (1 - T*^m),
        T* = (T - T_room) / (T_melt - T_room), clipped to [0, 1].

    The update is the radial return mapping (Simo and Hughes, *Computational
    Inelasticity*, 1998, section 3.3): the trial deviator is scaled back to
    the yield surface along itself, so the plastic flow is isochoric and the
    pressure elastic. The plastic strain rate is the step's ``d eps_p / dt``,
    so the rate term is part of the equation the return solves. A share
    ``taylor_quinney`` of the plastic work heats the point (Taylor and
    Quinney, 1934): ``dT = beta sigma_y d eps_p / (rho c)``, the temperature
    of the step's start softening the step (explicit in T: the step is short).

    Leaves out: kinematic hardening, damage, heat conduction, the temperature
    dependence of the elastic constants and of ``c``, and rates below
    ``rate_0`` (the rate term is cut off at 1, as usual).

    Differentiable: the plastic multiplier is found by bisection (robust for
    ``n < 1``, whose hardening slope is infinite at ``eps_p = 0``) without
    gradient, then given the implicit-function gradient of the consistency
    condition, so ``jax.grad`` differentiates the converged update, not the
    iterations.
    """

    A: float  # MPa
    B: float  # MPa
    n: float
    C: float
    m: float
    melting: float  # K
    young: float  # MPa
    poisson: float
    density: float  # t/mm³
    specific_heat: float  # mJ/(t K)
    reference_rate: float = 1.0  # 1/s
    room: float = ROOM  # K
    taylor_quinney: float = 0.9
    mass_scale: float = 1.0

    @property
    def shear_modulus(self) -> float:
        return self.young / (2 * (1 + self.poisson))

    @property
    def bulk_modulus(self) -> float:
        return self.young / (3 * (1 - 2 * self.poisson))

    @property
    def shear_yield(self) -> float:
        """The initial shear flow stress ``A / sqrt 3`` (MPa), von Mises."""
        return self.A / math.sqrt(3)

    def flow_stress(self, plastic_strain, rate, temperature) -> Array:
        """sigma_y (MPa) at ``plastic_strain``, ``rate`` (1/s) and ``temperature`` (K)."""
        eps = jnp.maximum(plastic_strain, 0)
        # eps^n with a gradient that stays finite at eps = 0 (where the slope
        # of eps^n, n < 1, is infinite): 0 there.
        positive = eps > 0
        power = jnp.where(positive, jnp.where(positive, eps, 1) ** self.n, 0)
        ratio = jnp.maximum(rate / self.reference_rate, 1)
        homologous = jnp.clip((temperature - self.room) / (self.melting - self.room), 0, 1)
        softening = 1 - homologous**self.m
        return (self.A + self.B * power) * (1 + self.C * jnp.log(ratio)) * softening

    def update(self, state: PointState, strain_increment: Array, dt):
        """One step: ``(state, d eps_p f[S])``; ``sigma_y d eps_p`` is the plastic work."""
        g = self.shear_modulus
        trial = state.stress + hooke(g, self.bulk_modulus, strain_increment)
        s, mean = deviator(trial)
        q_trial = von_mises(trial)
        temperature = state.temperature

        def residual(delta):
            rate = delta / dt
            return (
                q_trial
                - 3 * g * delta
                - self.flow_stress(state.plastic_strain + delta, rate, temperature)
            )

        yielding = residual(jnp.zeros_like(q_trial)) > 0
        # Bisection on [0, q_trial / 3G]: the residual falls with delta and is
        # <= 0 at the upper end.
        high = jax.lax.stop_gradient(jnp.where(yielding, q_trial / (3 * g), 0))
        low = jnp.zeros_like(high)

        def halve(_, bracket):
            low, high = bracket
            middle = 0.5 * (low + high)
            above = jax.lax.stop_gradient(residual(middle)) > 0
            return jnp.where(above, middle, low), jnp.where(above, high, middle)

        halvings = BISECTIONS if q_trial.dtype == jnp.float64 else BISECTIONS // 2
        low, high = jax.lax.fori_loop(0, halvings, halve, (low, high))
        root = jax.lax.stop_gradient(0.5 * (low + high))
        # The implicit-function gradient: d delta = -(d residual) / (d residual / d delta).
        slope = jax.lax.stop_gradient(jax.grad(lambda d: jnp.sum(residual(d)))(root))
        safe_slope = jnp.where(slope < 0, slope, -3 * g)
        value = residual(root)
        delta = root - (value - jax.lax.stop_gradient(value)) / safe_slope
        delta = jnp.where(yielding, delta, 0)
        safe_q = jnp.where(yielding, q_trial, 1)
        scale = jnp.where(yielding, 1 - 3 * g * delta / safe_q, 1)
        stress = s * scale[..., None] + jnp.stack([mean, mean, mean, 0 * mean], -1)
        heat = self.taylor_quinney * von_mises(stress) * delta
        temperature = temperature + heat / (self.density * self.specific_heat)
        return PointState(stress, state.plastic_strain + delta, temperature), delta


# -- presets -----------------------------------------------------------------

STEEL = Elastic()
"""Linear elastic steel: E = 210 GPa, ν = 0.3, ρ = 7850 kg/m³ (handbook values)."""

AISI_1045 = JohnsonCook(
    # Jaspers and Dautzenberg (2002), "Material behaviour in conditions
    # similar to metal cutting: flow stress in the primary shear zone",
    # J. Mater. Process. Technol. 122, 322-330: fitted to split-Hopkinson
    # tests up to about 1e4/s and 600 °C (cutting reaches more).
    A=553.1,
    B=600.8,
    n=0.234,
    C=0.0134,
    m=1.0,
    melting=1460.0 + 273.15,
    # Elastic constants, density and specific heat near room temperature:
    # ASM Handbook vol. 1 (7850 kg/m³, 486 J/(kg K)).
    young=210_000.0,
    poisson=0.3,
    density=7.85e-9,
    specific_heat=4.86e8,
)
"""AISI 1045 (Ck45, C45): Johnson–Cook after Jaspers and Dautzenberg (2002)."""

AISI_4340 = JohnsonCook(
    # Johnson and Cook (1983), "A constitutive model and data for metals
    # subjected to large strains, high strain rates and high temperatures",
    # Proc. 7th Int. Symp. on Ballistics, The Hague, 541-547: their table of
    # constants, with the density, specific heat and melting point they list.
    A=792.0,
    B=510.0,
    n=0.26,
    C=0.014,
    m=1.03,
    melting=1793.0,
    young=200_000.0,  # MPa and ν: handbook values (ASM Handbook vol. 1)
    poisson=0.29,
    density=7.83e-9,
    specific_heat=4.77e8,
)
"""AISI 4340 (Rockwell C30): Johnson and Cook's own constants (1983)."""

OFHC_COPPER = JohnsonCook(
    # Johnson and Cook (1983), as for AISI_4340.
    A=90.0,
    B=292.0,
    n=0.31,
    C=0.025,
    m=1.09,
    melting=1356.0,
    young=124_000.0,  # MPa and ν: handbook values (ASM Handbook vol. 2)
    poisson=0.34,
    density=8.96e-9,
    specific_heat=3.83e8,
)
"""OFHC copper: Johnson and Cook's own constants (1983)."""
