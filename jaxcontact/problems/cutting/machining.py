"""The analyses a cutting simulation is set against: Merchant's, Oxley's and Kienzle's.

Orthogonal cutting, angles in degrees, lengths in mm, forces in N, stresses in
MPa (N/mm²); ``h`` the uncut chip thickness, ``w`` the width of cut,
``gamma`` the rake angle, ``beta`` the friction angle (``tan beta = mu`` on the
rake face), ``phi`` the shear angle.

* **Merchant** (M. E. Merchant, "Mechanics of the metal cutting process",
  J. Appl. Phys. 16, 267-275 and 318-324, 1945): a thin shear plane at
  ``phi`` whose shear stress is the material's ``tau_s``; minimum energy gives
  ``phi = 45 + gamma / 2 - beta / 2``, and the force circle gives
  ``F_c = tau_s h w cos(beta - gamma) / (sin(phi) cos(phi + beta - gamma))``
  and ``F_t = F_c tan(beta - gamma)``. It is known to overestimate the shear
  angle of steels (hence underestimate the forces); it is a reference, not
  an answer.
* **Shear angle from the chip** (geometry, continuity of volume):
  ``tan(phi) = r cos(gamma) / (1 - r sin(gamma))`` with the chip ratio
  ``r = h / h_chip``.
* **Friction angle from the forces**: ``beta = gamma + atan(F_t / F_c)``.
* **Oxley** (P. L. B. Oxley, *The Mechanics of Machining*, Ellis Horwood,
  1989), extended to the Johnson-Cook flow stress by Lalwani, Mehta and Jain
  (J. Mater. Process. Technol. 209, 5305-5312, 2009): a predictive theory,
  from the work material's flow stress and thermal properties to the shear
  angle, the forces, the chip and the temperatures; :func:`oxley`.
* **Kienzle** (O. Kienzle, "Die Bestimmung von Kräften und Leistungen an
  spanenden Werkzeugen und Werkzeugmaschinen", VDI-Z 94, 299-305, 1952):
  ``F_c = k_c1.1 w h^(1 - m_c)``, an empirical fit. For Ck45 (AISI 1045),
  ``k_c1.1 = 2220 N/mm²`` and ``m_c = 0.14`` as tabulated by König and
  Klocke (*Fertigungsverfahren 1*, Springer); handbooks give other pairs for
  the same steel (k_c1.1 from about 1,500 to 2,220 N/mm²), the spread of
  tool geometry and test conditions behind them, so Kienzle is a sanity
  band, not a measurement.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from jaxcontact.sim.materials import AISI_1045, JohnsonCook

__all__ = [
    "AISI_1045_THERMAL",
    "DELTA_RANGE",
    "KIENZLE_CK45",
    "Oxley",
    "SHEAR_ANGLE_RANGE",
    "STRAIN_RATE_CONSTANT_RANGE",
    "Thermal",
    "friction_angle_from_forces",
    "kienzle_force",
    "merchant_forces",
    "merchant_shear_angle",
    "oxley",
    "shear_angle_from_chip",
]

KIENZLE_CK45 = (2220.0, 0.14)  # (k_c1.1 in N/mm², m_c), König and Klocke


def merchant_shear_angle(rake: float, friction_angle: float) -> float:
    """phi = 45 + gamma / 2 - beta / 2 (degrees)."""
    return 45.0 + rake / 2 - friction_angle / 2


def merchant_forces(
    shear_stress: float, h: float, w: float, rake: float, friction_angle: float
) -> tuple[float, float]:
    """``(F_c, F_t)`` in N: the cutting and thrust forces of Merchant's model."""
    phi = math.radians(merchant_shear_angle(rake, friction_angle))
    gamma, beta = math.radians(rake), math.radians(friction_angle)
    cutting = (
        shear_stress
        * h
        * w
        * math.cos(beta - gamma)
        / (math.sin(phi) * math.cos(phi + beta - gamma))
    )
    return cutting, cutting * math.tan(beta - gamma)


def shear_angle_from_chip(chip_ratio: float, rake: float) -> float:
    """phi (degrees) from ``r = h / h_chip``: tan phi = r cos gamma / (1 - r sin gamma)."""
    gamma = math.radians(rake)
    return math.degrees(math.atan2(chip_ratio * math.cos(gamma), 1 - chip_ratio * math.sin(gamma)))


def friction_angle_from_forces(cutting: float, thrust: float, rake: float) -> float:
    """beta = gamma + atan(F_t / F_c), degrees."""
    return rake + math.degrees(math.atan2(thrust, cutting))


def kienzle_force(h: float, w: float = 1.0, constants=KIENZLE_CK45) -> float:
    """F_c = k_c1.1 w h^(1 - m_c), N (``h`` and ``w`` in mm)."""
    k_c11, m_c = constants
    return k_c11 * w * h ** (1 - m_c)


# --- Oxley's predictive theory, extended to Johnson-Cook (Lalwani et al., 2009) ---

_SQRT3 = math.sqrt(3.0)
_ZERO_CELSIUS = 273.15  # K
# The searches' ranges: Lalwani et al.'s (and OxleyPython's) for C and delta;
# the shear angle's wide enough for any rake from -15 to +15 degrees.
STRAIN_RATE_CONSTANT_RANGE = (2.0, 10.0)
DELTA_RANGE = (0.005, 0.2)
SHEAR_ANGLE_RANGE = (3.0, 50.0)  # degrees
# Grid points over each range before the bracketed refinement.
_PHI_POINTS, _C_POINTS, _DELTA_POINTS = 48, 17, 14
# Points inside the bracket of delta's least F_c at each round of refinement.
_DELTA_REFINE = 31
# The shear plane's temperature, found in [T_w, T_melt] to this (°C; its
# residual, T_w + eta dT_SZ - T_AB, is in °C too).
_TEMPERATURE_TOL = 1e-10
# The roots' steps, in their units (radians, C; past this the residuals are
# at their rounding noise, ~1e-11 MPa), and the bracket of delta's least F_c.
_PHI_XTOL = 1e-12
_C_XTOL = 1e-10
# ... or their residuals (MPa) below this.
_STRESS_FTOL = 1e-9
_DELTA_XTOL = 2e-4


class Thermal(NamedTuple):
    """The work material's thermal properties, SI units, temperatures in °C.

    ``S = a + b T`` and ``K = a + b T`` are linear in the temperature in °C,
    as Oxley (1989) and Lalwani et al. (2009) write them.
    """

    density: float  # kg/m³
    specific_heat: tuple[float, float]  # (a J/(kg K), b J/(kg K °C)): S = a + b T
    conductivity: tuple[float, float]  # (a W/(m K), b W/(m K °C)): K = a + b T

    def heat_capacity(self, celsius):
        """S (J/(kg K)) at ``celsius``."""
        a, b = self.specific_heat
        return a + b * celsius

    def heat_conductivity(self, celsius):
        """K (W/(m K)) at ``celsius``."""
        a, b = self.conductivity
        return a + b * celsius


AISI_1045_THERMAL = Thermal(
    density=7850.0, specific_heat=(420.0, 0.504), conductivity=(52.61, -0.0281)
)
"""AISI 1045: S = 420 + 0.504 T J/(kg K), K = 52.61 - 0.0281 T W/(m K) (T in °C),
the laws Lalwani et al. (2009) use, as coded in OxleyPython (Pantalé, Dawoua
Kaoutoing and Houé Ngouna, "A new algorithm to solve the Extended-Oxley
analytical model of orthogonal metal cutting in Python", Appl. Mech. 3,
889-904, 2022; github.com/pantale/OxleyPython); rho = 7850 kg/m³ (ASM
Handbook vol. 1, as ``materials.AISI_1045``; OxleyPython takes 8000)."""


class Oxley(NamedTuple):
    """The solution of :func:`oxley`: forces for the whole width ``w``."""

    cutting_force: float  # F_c, N (N/mm of width times w)
    thrust_force: float  # F_t, N
    shear_angle: float  # phi, degrees
    chip_thickness_ratio: float  # t2 / t1 = h_c / h
    friction_angle: float  # lambda, degrees (tan lambda = F / N on the rake face)
    strain_rate_constant: float  # C (Oxley's: shear-zone length over thickness)
    delta: float  # secondary zone's thickness over the chip thickness
    shear_plane_temperature: float  # T_AB, °C
    interface_temperature: float  # T_int, °C
    shear_plane_strain: float  # eps_AB (equivalent)
    interface_strain: float  # eps_int (equivalent)
    shear_plane_strain_rate: float  # eps'_AB (equivalent), 1/s
    interface_strain_rate: float  # eps'_int (equivalent), 1/s
    shear_plane_flow_stress: float  # k_AB, MPa
    chip_flow_stress: float  # k_chip, MPa
    interface_shear_stress: float  # tau_int = F / (h' w), MPa
    interface_normal_stress: float  # sigma_N = N / (h' w), MPa
    normal_stress_at_b: float  # sigma'_N, MPa
    shear_force: float  # F_s = k_AB t1 w / sin(phi), N
    contact_length: float  # h', mm
    chip_thickness: float  # t2, mm
    strain_hardening: float  # n_eq


class _Problem(NamedTuple):
    material: object
    thermal: Thermal
    speed: float  # m/s
    uncut: float  # mm
    width: float  # mm
    rake: float  # radians
    work: float  # °C
    eta: float
    psi: float


def _flow_stress(material, strain, rate, celsius):
    """Johnson-Cook's sigma_y (MPa) in NumPy, as ``JohnsonCook.flow_stress``."""
    ratio = np.maximum(rate / material.reference_rate, 1.0)
    kelvin = celsius + _ZERO_CELSIUS
    homologous = np.clip((kelvin - material.room) / (material.melting - material.room), 0.0, 1.0)
    hardening = material.A + material.B * np.maximum(strain, 0.0) ** material.n
    return hardening * (1 + material.C * np.log(ratio)) * (1 - homologous**material.m)


def _state(phi, c, delta, p: _Problem) -> dict:
    """Every quantity of the model at ``(phi [rad], C, delta)``, broadcast arrays.

    Invalid states (no equilibrium: tan theta <= 0, lambda out of (0, 90°),
    a temperature past melting, a fixed point that does not converge) are NaN.
    """
    mat, th = p.material, p.thermal
    alpha, t1, w, v = p.rake, p.uncut, p.width, p.speed
    sin_phi, cos_pa = np.sin(phi), np.cos(phi - alpha)
    melting = mat.melting - _ZERO_CELSIUS
    # Shear plane AB: length, velocity of shear, strain and strain rate (Oxley 1989).
    l_ab = t1 / sin_phi  # mm
    v_s = v * math.cos(alpha) / cos_pa  # m/s
    v_c = v * sin_phi / cos_pa  # m/s, the chip's
    t2 = t1 * cos_pa / sin_phi  # mm
    gamma_ab = 0.5 * math.cos(alpha) / (sin_phi * cos_pa)
    eps_ab = gamma_ab / _SQRT3
    rate_ab = c * (v_s * 1e3) / l_ab / _SQRT3  # 1/s (v_s in mm/s)
    # The chip's heat capacity flow rho S V t1 w in W/K per unit S: SI, t1 w in m².
    flow = th.density * v * (t1 * 1e-3) * (w * 1e-3)  # kg/s

    def shear_zone(t_ab):
        s, k = th.heat_capacity(t_ab), th.heat_conductivity(t_ab)
        rt_tan = th.density * s * v * (t1 * 1e-3) / k * np.tan(phi)
        log_rt = np.log10(rt_tan)
        beta = np.clip(np.where(rt_tan > 10, 0.3 - 0.15 * log_rt, 0.5 - 0.35 * log_rt), 0, 1)
        k_ab = _flow_stress(mat, eps_ab, rate_ab, t_ab) / _SQRT3
        f_s = k_ab * l_ab * w  # N
        rise = (1 - beta) * f_s * v_s / (flow * s)  # K
        return rise, k_ab, f_s, beta

    def t_ab_residual(t_ab):
        return p.work + p.eta * shear_zone(t_ab)[0] - t_ab

    # T_AB = T_w + eta dT_SZ(T_AB): positive at T_w, T_w - T_melt < 0 at melting
    # (k_AB = 0 there), so a root lies between; found by regula falsi.
    shape = np.broadcast(phi, c, delta).shape
    low, high = np.full(shape, float(p.work)), np.full(shape, float(melting))
    t_ab = _root(
        t_ab_residual,
        low,
        high,
        t_ab_residual(low),
        t_ab_residual(high),
        _TEMPERATURE_TOL,
        _TEMPERATURE_TOL,
    )
    rise_sz, k_ab, f_s, beta = shear_zone(t_ab)
    # Lalwani et al.'s n_eq for Johnson-Cook: d ln(A + B eps^n) / d ln eps at eps_AB.
    hard = mat.B * eps_ab**mat.n
    n_eq = mat.n * hard / (mat.A + hard)
    tan_theta = 1 + 2 * (math.pi / 4 - phi) - c * n_eq
    theta = np.arctan(tan_theta)
    resultant = f_s / np.cos(theta)
    lam = theta + alpha - phi
    friction, normal = resultant * np.sin(lam), resultant * np.cos(lam)
    cutting, thrust = resultant * np.cos(theta - phi), resultant * np.sin(theta - phi)
    sigma_b = k_ab * (1 + math.pi / 2 - 2 * alpha - 2 * c * n_eq)
    contact = t1 * np.sin(theta) / (np.cos(lam) * sin_phi) * (1 + c * n_eq / (3 * tan_theta))
    tau_int = friction / (contact * w)
    sigma_n = normal / (contact * w)
    gamma_int = 2 * gamma_ab + 0.5 * contact / (delta * t2)
    eps_int = gamma_int / _SQRT3
    rate_int = (v_c * 1e3) / (delta * t2) / _SQRT3
    # The chip's mean temperature T_c = T_w + dT_SZ + dT_C, dT_C = F V_c / (rho S(T_c) V t1 w):
    # with S = a + b T linear, b dT_C^2 + S(T_w + dT_SZ) dT_C - q = 0, q = F V_c / (rho V t1 w),
    # solved in its cancellation-free form.
    q = friction * v_c / flow  # J/kg
    s_0 = th.heat_capacity(p.work + rise_sz)
    rise_c = 2 * q / (s_0 + np.sqrt(s_0**2 + 4 * th.specific_heat[1] * q))
    t_c = p.work + rise_sz + rise_c
    r_t = th.density * th.heat_capacity(t_c) * v * (t1 * 1e-3) / th.heat_conductivity(t_c)
    x = r_t * t2 / contact
    rise_m = rise_c * 10 ** (0.06 - 0.195 * delta * np.sqrt(x) + 0.5 * np.log10(x))
    t_int = p.work + rise_sz + p.psi * rise_m
    k_chip = _flow_stress(mat, eps_int, rate_int, t_int) / _SQRT3
    valid = (tan_theta > 0) & (lam > 0) & (lam < math.pi / 2) & (t_int < melting)
    nan = np.float64(np.nan)
    out = dict(
        cutting_force=cutting,
        thrust_force=thrust,
        shear_angle=phi,
        chip_thickness=t2,
        friction_angle=lam,
        theta=theta,
        strain_rate_constant=c,
        delta=delta,
        shear_plane_temperature=t_ab,
        interface_temperature=t_int,
        shear_plane_strain=eps_ab,
        interface_strain=eps_int,
        shear_plane_strain_rate=rate_ab,
        interface_strain_rate=rate_int,
        shear_plane_flow_stress=k_ab,
        chip_flow_stress=k_chip,
        interface_shear_stress=tau_int,
        interface_normal_stress=sigma_n,
        normal_stress_at_b=sigma_b,
        shear_force=f_s,
        contact_length=contact,
        strain_hardening=n_eq,
        beta=beta,
    )
    return {
        key: np.where(valid, np.broadcast_to(value, valid.shape), nan) for key, value in out.items()
    }


def _root(fun, lo, hi, f_lo, f_hi, xtol, ftol):
    """Roots of ``fun`` in the brackets ``[lo, hi]`` (arrays; ``f_lo``, ``f_hi`` of opposite signs).

    The Illinois variant of regula falsi (Dowell and Jarratt, BIT 11, 168-174,
    1971), elementwise: the bracket always holds the root, and an end kept
    twice in a row has its value halved, until the bracket or the step is
    below ``xtol`` or the value below ``ftol`` (Illinois creeps by halvings
    when an iterate lands on the root). A NaN bracket stays NaN; a NaN value inside a bracket (an
    invalid state) is taken as the low end's sign.
    """
    lo, hi, f_lo, f_hi = np.broadcast_arrays(lo, hi, f_lo, f_hi)
    kept = np.zeros(lo.shape, dtype=np.int8)  # +1: lo kept last step, -1: hi kept
    x = np.full(lo.shape, np.inf)
    for _ in range(200):
        secant = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        previous, x = x, np.where((secant > lo) & (secant < hi), secant, 0.5 * (lo + hi))
        f_x = fun(x)
        f_x = np.where(np.isnan(f_x) & ~np.isnan(lo), f_lo, f_x)  # invalid: keep hi
        left = np.sign(f_x) == np.sign(f_lo)  # the root lies in [x, hi]: hi is kept
        f_hi = np.where(left & (kept == -1), 0.5 * f_hi, f_hi)
        f_lo = np.where(~left & (kept == 1), 0.5 * f_lo, f_lo)
        kept = np.where(left, -1, 1).astype(np.int8)
        lo, f_lo = np.where(left, x, lo), np.where(left, f_x, f_lo)
        hi, f_hi = np.where(left, hi, x), np.where(left, f_hi, f_x)
        # Converged: the bracket or the step below xtol, or the value below ftol.
        if np.all(~(hi - lo > xtol) | ~(np.abs(x - previous) > xtol) | ~(np.abs(f_x) > ftol)):
            break
    return x


def _first_crossing(grid, values):
    """Per row, the first grid interval where ``values`` change sign: ``(lo, hi, f_lo, f_hi)``.

    NaN where there is none (NaN values never bracket).
    """
    cross = ((values[..., :-1] > 0) & (values[..., 1:] <= 0)) | (
        (values[..., :-1] < 0) & (values[..., 1:] >= 0)
    )
    found = cross.any(axis=-1)
    k = np.argmax(cross, axis=-1)[..., None]
    grid = np.broadcast_to(grid, values.shape)

    def take(a, shift):
        return np.where(found, np.take_along_axis(a, k + shift, axis=-1)[..., 0], np.nan)

    return take(grid, 0), take(grid, 1), take(values, 0), take(values, 1)


def _phi_residual(phi, c, delta, p):
    s = _state(phi, c, delta, p)
    return s["interface_shear_stress"] - s["chip_flow_stress"]


def _solve_phi(c, delta, p):
    """phi (radians) with tau_int = k_chip, for arrays ``c`` and ``delta``; NaN where none."""
    c, delta = np.broadcast_arrays(np.asarray(c, float), np.asarray(delta, float))
    grid = np.radians(np.linspace(*SHEAR_ANGLE_RANGE, _PHI_POINTS))
    values = _phi_residual(grid, c[..., None], delta[..., None], p)
    lo, hi, f_lo, f_hi = _first_crossing(grid, values)
    return _root(
        lambda x: _phi_residual(x, c, delta, p), lo, hi, f_lo, f_hi, _PHI_XTOL, _STRESS_FTOL
    )


def _c_residual(c, delta, p):
    s = _state(_solve_phi(c, delta, p), c, delta, p)
    return s["normal_stress_at_b"] - s["interface_normal_stress"]


def _solve_c(delta, p):
    """C with sigma'_N = sigma_N (and phi with tau_int = k_chip) for an array ``delta``."""
    delta = np.asarray(delta, float)
    grid = np.linspace(*STRAIN_RATE_CONSTANT_RANGE, _C_POINTS)
    values = _c_residual(grid, delta[..., None], p)
    lo, hi, f_lo, f_hi = _first_crossing(grid, values)
    return _root(lambda x: _c_residual(x, delta, p), lo, hi, f_lo, f_hi, _C_XTOL, _STRESS_FTOL)


def _solve_delta(deltas, p):
    """``(F_c, C, phi)`` at each of ``deltas`` (both equilibria solved; NaN where not)."""
    c = _solve_c(deltas, p)
    phi = _solve_phi(c, deltas, p)
    return _state(phi, c, deltas, p)["cutting_force"], c, phi


def _failure(p) -> str:
    """Which equilibrium has no solution over the grids of ``(phi, C, delta)``."""
    deltas = np.linspace(*DELTA_RANGE, _DELTA_POINTS)
    grid = np.linspace(*STRAIN_RATE_CONSTANT_RANGE, _C_POINTS)
    phi = _solve_phi(grid[None, :], deltas[:, None], p)
    if np.all(np.isnan(phi)):
        return (
            f"tau_int = k_chip has no root for phi in {SHEAR_ANGLE_RANGE} degrees at any C in "
            f"{STRAIN_RATE_CONSTANT_RANGE} and delta in {DELTA_RANGE}"
        )
    return (
        f"sigma'_N = sigma_N (the normal stress at B) has no root for C in "
        f"{STRAIN_RATE_CONSTANT_RANGE} at any delta in {DELTA_RANGE}"
    )


def oxley(
    material: JohnsonCook = AISI_1045,
    *,
    speed: float,
    uncut: float,
    rake: float,
    width: float = 1.0,
    thermal: Thermal = AISI_1045_THERMAL,
    work_temperature: float | None = None,
    eta: float = 0.9,
    psi: float = 0.9,
    delta: float | None = None,
) -> Oxley:
    """Oxley's predictive machining theory with a Johnson-Cook work material.

    The extended Oxley analysis of orthogonal cutting by Lalwani, Mehta and
    Jain (2009), "Extension of Oxley's predictive machining theory for
    Johnson and Cook flow stress model", J. Mater. Process. Technol. 209,
    5305-5312, on P. L. B. Oxley, *The Mechanics of Machining: An Analytical
    Approach to Assessing Machinability*, Ellis Horwood, 1989 (chapters 6
    and 7). For a shear angle ``phi``, a strain-rate constant ``C`` and a
    secondary-zone thickness ratio ``delta`` (``alpha`` the rake angle,
    ``V`` the cutting speed, ``t1`` the uncut chip thickness, ``w`` the width):

    * shear plane AB: ``l_AB = t1 / sin(phi)``,
      ``V_s = V cos(alpha) / cos(phi - alpha)``,
      ``gamma_AB = cos(alpha) / (2 sin(phi) cos(phi - alpha))``,
      ``gamma'_AB = C V_s / l_AB``; equivalent strain and rate
      ``eps = gamma / sqrt(3)``, ``eps' = gamma' / sqrt(3)``;
    * its temperature ``T_AB = T_w + eta dT_SZ``,
      ``dT_SZ = (1 - beta) F_s V_s / (rho S V t1 w)``, with
      ``F_s = k_AB l_AB w``, ``k_AB = sigma_JC(eps_AB, eps'_AB, T_AB) / sqrt(3)``
      and Boothroyd's partition as Oxley fits it, from
      ``R_T tan(phi)``, ``R_T = rho S V t1 / K``:
      ``beta = 0.5 - 0.35 log10(R_T tan phi)`` up to 10,
      ``beta = 0.3 - 0.15 log10(R_T tan phi)`` above; S and K at ``T_AB``.
      ``T_AB`` is solved for in ``[T_w, T_melt]`` (a root always lies there);
    * Lalwani et al.'s strain-hardening index for Johnson-Cook,
      ``n_eq = n B eps_AB^n / (A + B eps_AB^n)``;
    * the resultant's angle with AB:
      ``tan(theta) = 1 + 2 (pi/4 - phi) - C n_eq``; the friction angle
      ``lambda = theta - phi + alpha``; ``R = F_s / cos(theta)``,
      ``F = R sin(lambda)``, ``N = R cos(lambda)``,
      ``F_c = R cos(theta - phi)``, ``F_t = R sin(theta - phi)``;
    * the normal stress at the tool tip B,
      ``sigma'_N = k_AB (1 + pi/2 - 2 alpha - 2 C n_eq)``;
    * the tool-chip contact length
      ``h' = t1 sin(theta) / (cos(lambda) sin(phi)) (1 + C n_eq / (3 tan(theta)))``;
      on it ``tau_int = F / (h' w)``, ``sigma_N = N / (h' w)``;
    * the chip ``t2 = t1 cos(phi - alpha) / sin(phi)``,
      ``V_c = V sin(phi) / cos(phi - alpha)``; at the interface
      ``gamma_int = 2 gamma_AB + h' / (2 delta t2)``,
      ``gamma'_int = V_c / (delta t2)``;
    * the chip's mean temperature rise ``dT_C = F V_c / (rho S V t1 w)``
      (S at the chip's mean temperature ``T_w + dT_SZ + dT_C``), the
      interface's maximum rise
      ``log10(dT_M / dT_C) = 0.06 - 0.195 delta sqrt(R_T t2 / h') + 0.5 log10(R_T t2 / h')``
      (R_T at that mean temperature) and its temperature
      ``T_int = T_w + dT_SZ + psi dT_M``;
      ``k_chip = sigma_JC(eps_int, eps'_int, T_int) / sqrt(3)``.

    The solution: ``phi`` such that ``tau_int = k_chip``, then ``C`` such
    that ``sigma'_N = sigma_N``, then ``delta`` the one of least ``F_c``
    (Lalwani et al.'s order; Oxley's ranges: C in 2-10, delta in
    0.005-0.2). Each root is bracketed on a grid (the first change of sign)
    and refined by regula falsi (Illinois) to steps of 1e-12 rad and 1e-10 in C;
    delta's least F_c is bracketed on a grid and refined on finer grids
    to a bracket of 2e-4.

    Units: the geometry in mm and the stresses in MPa, as the package;
    the heat balances in SI (the chip's mass flow ``rho V t1 w`` in kg/s,
    S in J/(kg K), K in W/(m K), speeds in m/s, forces in N), as Oxley's.

    Args:
        material: the work's Johnson-Cook law; its ``room`` and ``melting``
            (K) set the homologous temperature, its rate term is cut off
            below ``reference_rate`` as in ``JohnsonCook.flow_stress``.
        speed: the cutting speed V, m/min.
        uncut: the uncut chip thickness t1 (h), mm.
        rake: the rake angle alpha, degrees.
        width: the width of cut w, mm; forces are for the whole width.
        thermal: the work's density, specific heat and conductivity.
        work_temperature: the work's initial temperature T_w, K (default
            ``material.room``).
        eta: the share of the shear zone's temperature rise at AB
            (Oxley's eta; 0.9 as Lalwani et al. take it).
        psi: the ratio of the interface's mean to maximum temperature rise
            (Oxley's psi; 0.9 as Lalwani et al. take it).
        delta: fix delta (no minimisation of F_c): the equilibria solved at it.

    Returns:
        The solution, an :class:`Oxley`.

    Raises:
        ValueError: when ``tau_int = k_chip`` has no root in phi, or
            ``sigma'_N = sigma_N`` none in C, or ``F_c`` has no minimum
            inside the range of delta; the message says which.
    """
    p = _Problem(
        material=material,
        thermal=thermal,
        speed=speed / 60.0,
        uncut=uncut,
        width=width,
        rake=math.radians(rake),
        work=(material.room if work_temperature is None else work_temperature) - _ZERO_CELSIUS,
        eta=eta,
        psi=psi,
    )
    with np.errstate(all="ignore"):  # invalid states are NaN by design
        if delta is not None:
            deltas = np.array([float(delta)])
            forces, cs, phis = _solve_delta(deltas, p)
            if np.isnan(forces[0]):
                raise ValueError(_failure(p) + f" (at delta = {delta})")
            best = 0
        else:
            deltas = np.linspace(*DELTA_RANGE, _DELTA_POINTS)
            forces, cs, phis = _solve_delta(deltas, p)
            if np.all(np.isnan(forces)):
                raise ValueError(_failure(p))
            best = int(np.nanargmin(forces))
            if best in (0, len(deltas) - 1):
                raise ValueError(
                    f"F_c has no minimum inside delta's range {DELTA_RANGE}: it is least at "
                    f"its end, delta = {deltas[best]:.4g}"
                )
            if np.isnan(forces[[best - 1, best + 1]]).any():
                raise ValueError(
                    f"F_c has no minimum where the equilibria hold in delta's range "
                    f"{DELTA_RANGE}: it is least at delta = {deltas[best]:.4g}, next to a delta "
                    f"without a solution"
                )
            # Finer grids about the least: the bracket shrinks by (points + 1) / 2 a round.
            while deltas[best + 1] - deltas[best - 1] > _DELTA_XTOL:
                finer = np.linspace(deltas[best - 1], deltas[best + 1], _DELTA_REFINE + 2)
                f_inner, c_inner, phi_inner = _solve_delta(finer[1:-1], p)
                deltas = finer
                forces = np.concatenate([forces[[best - 1]], f_inner, forces[[best + 1]]])
                cs = np.concatenate([cs[[best - 1]], c_inner, cs[[best + 1]]])
                phis = np.concatenate([phis[[best - 1]], phi_inner, phis[[best + 1]]])
                best = int(np.clip(np.nanargmin(forces), 1, len(deltas) - 2))
        s = _state(phis[best], cs[best], deltas[best], p)
    s = {key: float(value) for key, value in s.items()}
    return Oxley(
        cutting_force=s["cutting_force"],
        thrust_force=s["thrust_force"],
        shear_angle=math.degrees(s["shear_angle"]),
        chip_thickness_ratio=s["chip_thickness"] / uncut,
        friction_angle=math.degrees(s["friction_angle"]),
        strain_rate_constant=s["strain_rate_constant"],
        delta=s["delta"],
        shear_plane_temperature=s["shear_plane_temperature"],
        interface_temperature=s["interface_temperature"],
        shear_plane_strain=s["shear_plane_strain"],
        interface_strain=s["interface_strain"],
        shear_plane_strain_rate=s["shear_plane_strain_rate"],
        interface_strain_rate=s["interface_strain_rate"],
        shear_plane_flow_stress=s["shear_plane_flow_stress"],
        chip_flow_stress=s["chip_flow_stress"],
        interface_shear_stress=s["interface_shear_stress"],
        interface_normal_stress=s["interface_normal_stress"],
        normal_stress_at_b=s["normal_stress_at_b"],
        shear_force=s["shear_force"],
        contact_length=s["contact_length"],
        chip_thickness=s["chip_thickness"],
        strain_hardening=s["strain_hardening"],
    )
