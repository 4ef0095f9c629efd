"""The analyses a cutting simulation is set against: Merchant's and Kienzle's.

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
