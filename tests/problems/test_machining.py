"""Merchant's and Kienzle's analyses, checked against the force circle they come from."""

from __future__ import annotations

import functools
import math

import pytest

from jaxcontact.problems.cutting import machining
from tests.support.tolerances import FLOAT64_RTOL, HAND_FIGURE_RTOL, OXLEY_RESIDUAL_ATOL


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


# Oxley's theory extended to Johnson-Cook (Lalwani et al., 2009) for AISI 1045:
# three conditions about the CIRP benchmark's (200 m/min, 0.15 mm, -7 degrees).
OXLEY_CONDITIONS = [(100.0, 0.10, 0.0), (200.0, 0.15, -7.0), (300.0, 0.15, 5.0)]


@functools.cache
def _oxley(speed, uncut, rake, delta=None):
    return machining.oxley(speed=speed, uncut=uncut, rake=rake, delta=delta)


@pytest.mark.parametrize("speed, uncut, rake", OXLEY_CONDITIONS)
def test_oxley_solves_its_equilibria(speed, uncut, rake):
    r = _oxley(speed, uncut, rake)
    # phi: the interface's shear stress is the chip's flow stress there.
    assert r.interface_shear_stress == pytest.approx(r.chip_flow_stress, abs=OXLEY_RESIDUAL_ATOL)
    # C: the normal stress at the tool tip B balances the rake face's mean.
    assert r.normal_stress_at_b == pytest.approx(r.interface_normal_stress, abs=OXLEY_RESIDUAL_ATOL)
    low, high = machining.STRAIN_RATE_CONSTANT_RANGE
    assert low < r.strain_rate_constant < high
    # delta: an interior minimum of the cutting force.
    low, high = machining.DELTA_RANGE
    assert low < r.delta < high
    step = r.delta / 20
    for delta in (r.delta - step, r.delta + step):
        assert _oxley(speed, uncut, rake, delta).cutting_force >= r.cutting_force


@pytest.mark.parametrize("speed, uncut, rake", OXLEY_CONDITIONS)
def test_oxley_geometry_and_force_circle(speed, uncut, rake):
    r = _oxley(speed, uncut, rake)
    # The chip ratio (h_c / h) and the shear angle: volume continuity.
    phi = machining.shear_angle_from_chip(1 / r.chip_thickness_ratio, rake)
    assert phi == pytest.approx(r.shear_angle, rel=FLOAT64_RTOL)
    assert r.chip_thickness == pytest.approx(r.chip_thickness_ratio * uncut, rel=FLOAT64_RTOL)
    # The friction angle on the rake face and the forces.
    beta = machining.friction_angle_from_forces(r.cutting_force, r.thrust_force, rake)
    assert beta == pytest.approx(r.friction_angle, rel=FLOAT64_RTOL)
    # The force circle: the resultant's component along AB is k_AB t1 w / sin(phi).
    p = math.radians(r.shear_angle)
    along = r.cutting_force * math.cos(p) - r.thrust_force * math.sin(p)
    assert along == pytest.approx(r.shear_plane_flow_stress * uncut / math.sin(p), rel=FLOAT64_RTOL)
    assert along == pytest.approx(r.shear_force, rel=FLOAT64_RTOL)
    # The interface is hotter than the shear plane, the shear plane than the work.
    assert 25.0 < r.shear_plane_temperature < r.interface_temperature


def test_oxley_trends():
    speed = 200.0
    thin, base, thick = (_oxley(speed, h, -7.0).cutting_force for h in (0.10, 0.15, 0.20))
    # The force rises with the uncut thickness, less than in proportion (size effect).
    assert thin < base < thick
    assert thick / thin < 2.0
    # ... and falls as the rake angle rises.
    negative, zero, positive = (_oxley(speed, 0.15, a).cutting_force for a in (-7.0, 0.0, 5.0))
    assert negative > zero > positive


def test_oxley_says_which_equilibrium_fails():
    # At 5 m/min the normal stresses at B and on the rake face do not meet for C in 2-10.
    with pytest.raises(ValueError, match="sigma'_N = sigma_N"):
        machining.oxley(speed=5.0, uncut=0.15, rake=0.0)
    # At +30 degrees rake the cutting force falls all the way to delta's end.
    with pytest.raises(ValueError, match="F_c has no minimum"):
        machining.oxley(speed=200.0, uncut=0.15, rake=30.0)
