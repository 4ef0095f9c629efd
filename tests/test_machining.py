"""Merchant's and Kienzle's analyses, checked against the force circle they come from."""

from __future__ import annotations

import math

import pytest

from jaxcontact.sim import machining


@pytest.mark.parametrize("rake, beta", [(0.0, 30.0), (-7.0, 25.0), (5.0, 40.0)])
def test_merchant_forces_close_the_force_circle(rake, beta):
    tau, h, w = 500.0, 0.1, 2.0
    cutting, thrust = machining.merchant_forces(tau, h, w, rake, beta)
    phi = machining.merchant_shear_angle(rake, beta)
    assert phi == pytest.approx(45 + rake / 2 - beta / 2)
    # The resultant's component along the shear plane is tau times its area h w / sin(phi).
    p = math.radians(phi)
    assert cutting * math.cos(p) - thrust * math.sin(p) == pytest.approx(tau * h * w / math.sin(p))
    # ... and it makes the angle beta - gamma with the cutting direction.
    assert machining.friction_angle_from_forces(cutting, thrust, rake) == pytest.approx(beta)


@pytest.mark.parametrize("rake", [-7.0, 0.0, 10.0])
def test_shear_angle_from_the_chip_ratio(rake):
    phi = 28.0
    gamma = math.radians(rake)
    # Volume continuity: h / sin(phi) = h_chip / cos(phi - gamma).
    ratio = math.sin(math.radians(phi)) / math.cos(math.radians(phi) - gamma)
    assert machining.shear_angle_from_chip(ratio, rake) == pytest.approx(phi)


def test_kienzle_band_for_ck45():
    assert machining.kienzle_force(1.0) == pytest.approx(2220.0)  # k_c1.1 at h = 1 mm
    assert machining.kienzle_force(0.1) == pytest.approx(2220.0 * 0.1**0.86)  # about 306 N/mm
    assert machining.kienzle_force(0.1, w=3.0) == pytest.approx(3 * machining.kienzle_force(0.1))
