"""Merchant's and Kienzle's analyses, checked against the force circle they come from."""

from __future__ import annotations

import math

import pytest

from jaxcontact.problems.cutting import machining
from tests.support.tolerances import FLOAT64_RTOL, HAND_FIGURE_RTOL


@pytest.mark.parametrize("rake, beta", [(0.0, 30.0), (-7.0, 25.0), (5.0, 40.0)])
def test_merchant_forces_close_the_force_circle(rake, beta):
    tau, h, w = 500.0, 0.1, 2.0
    cutting, thrust = machining.merchant_forces(tau, h, w, rake, beta)
    phi = machining.merchant_shear_angle(rake, beta)
    assert phi == pytest.approx(45 + rake / 2 - beta / 2, rel=FLOAT64_RTOL)
    # The resultant's component along the shear plane is tau times its area h w / sin(phi).
    p = math.radians(phi)
    assert cutting * math.cos(p) - thrust * math.sin(p) == pytest.approx(
        tau * h * w / math.sin(p), rel=FLOAT64_RTOL
    )
    # ... and it makes the angle beta - gamma with the cutting direction.
    assert machining.friction_angle_from_forces(cutting, thrust, rake) == pytest.approx(
        beta, rel=FLOAT64_RTOL
    )


@pytest.mark.parametrize("rake", [-7.0, 0.0, 10.0])
def test_shear_angle_from_the_chip_ratio(rake):
    phi = 28.0
    gamma = math.radians(rake)
    # Volume continuity: h / sin(phi) = h_chip / cos(phi - gamma).
    ratio = math.sin(math.radians(phi)) / math.cos(math.radians(phi) - gamma)
    assert machining.shear_angle_from_chip(ratio, rake) == pytest.approx(phi, rel=FLOAT64_RTOL)


# The band handbooks span for Ck45 (m_c = 0.14; k_c1.1 from 1,500 to König and
# Klocke's 2,220 N/mm²) at h = 0.1 mm, worked by hand: 0.1^0.86 = 0.13804, so
# 207.06 and 306.45 N/mm. tests/problems/test_cutting_demo.py checks that a run's
# summary reports this band.
KIENZLE_BAND_AT_0_1_MM = (207.06, 306.45)


def test_kienzle_band_for_ck45():
    low, high = KIENZLE_BAND_AT_0_1_MM
    assert machining.kienzle_force(0.1) == pytest.approx(high, rel=HAND_FIGURE_RTOL)
    assert machining.kienzle_force(0.1, constants=(1500.0, 0.14)) == pytest.approx(
        low, rel=HAND_FIGURE_RTOL
    )
    assert machining.kienzle_force(1.0) == pytest.approx(
        2220.0, rel=FLOAT64_RTOL
    )  # k_c1.1 at h = 1 mm
    # The exponent: twice the thickness, 2^0.86 = 1.8150 times the force.
    ratio = machining.kienzle_force(0.2) / machining.kienzle_force(0.1)
    assert ratio == pytest.approx(1.8150, rel=HAND_FIGURE_RTOL)
    assert machining.kienzle_force(0.1, w=3.0) == pytest.approx(3 * high, rel=HAND_FIGURE_RTOL)
