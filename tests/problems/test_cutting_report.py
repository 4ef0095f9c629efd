"""What the cutting demo reports about a run's forces, on synthetic histories.

``cutting.steady_window`` (the steady-state criterion: a window to the run's
end whose fitted line changes by at most 5 % of the mean) and
``cutting.release_dips`` (F_c's dips against the pair releases), and the
demo's sentences about them. Plain NumPy: no run, no compile.
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from jaxcontact.problems import cutting
from jaxcontact.problems.cutting import demo as cutting_demo
from tests.support.tolerances import STEADY_FIT_RTOL, STEADY_MEAN_RTOL

ROWS = 6000  # rows of a synthetic history: 0.6 mm of travel
SPACING = 0.01  # mm: one "element" of travel, 100 rows


def _travel() -> np.ndarray:
    return np.linspace(1e-4, 0.6, ROWS)


def _dipped(level: float) -> np.ndarray:
    """f[ROWS]: ``level`` with a 50 N/mm dip 10 rows long once per SPACING (a release's)."""
    force = np.full(ROWS, level)
    for start in range(5, ROWS, 100):
        force[start : start + 10] -= 50.0
    return force


def test_a_flat_history_is_steady_from_its_start():
    travel = _travel()
    noise = np.random.default_rng(0).normal(0.0, 2.0, (ROWS, 2))
    force = np.stack([_dipped(200.0), np.full(ROWS, 60.0)], -1) + noise
    window = cutting.steady_window(travel, force, SPACING)
    assert window.steady
    # The longest window the grid reaches: less than a spacing from the first row.
    assert travel[window.start] < travel[0] + SPACING
    np.testing.assert_allclose(window.mean, force[window.start :].mean(0), rtol=STEADY_FIT_RTOL)
    assert np.all(np.abs(window.drift) < 1.0)  # %


def test_a_ramp_is_not_steady_and_its_drift_is_its_rise():
    travel = _travel()
    force = np.stack([150.0 + 100.0 * travel, 30.0 + 50.0 * travel], -1)
    window = cutting.steady_window(travel, force, SPACING)
    assert not window.steady
    # The fallback: the last 40 % of the rows, the summary's window before the criterion.
    assert window.start == ROWS - round(cutting.LAST * ROWS)
    part = travel[window.start :]
    mean = force[window.start :].mean(0)
    rise = np.array([100.0, 50.0]) * (part[-1] - part[0])
    np.testing.assert_allclose(window.mean, mean, rtol=STEADY_FIT_RTOL)
    np.testing.assert_allclose(window.drift, 100 * rise / mean, rtol=STEADY_FIT_RTOL)
    assert window.drift[0] > 100 * cutting.STEADY_DRIFT


def test_a_ramp_then_a_plateau_is_steady_from_near_the_plateau():
    travel = _travel()
    # F_c doubles over 0.2 mm, then holds at 200 N/mm.
    force = np.stack([100.0 + 500.0 * np.minimum(travel, 0.2), np.full(ROWS, 40.0)], -1)
    window = cutting.steady_window(travel, force, SPACING)
    assert window.steady
    start = travel[window.start]
    # A window may take in the ramp's last stretch while its line stays within
    # 5 %: the start is where the drift allows, the mean within 1 % of the plateau.
    assert 0.14 < start <= 0.2 + SPACING
    assert window.mean[0] == pytest.approx(200.0, rel=STEADY_MEAN_RTOL)
    # A tighter tolerance starts it later, nearer the plateau.
    tighter = cutting.steady_window(travel, force, SPACING, tolerance=0.005)
    assert tighter.steady and start < travel[tighter.start] <= 0.2 + SPACING


def test_a_thrust_near_zero_is_judged_against_the_resultant():
    travel = _travel()
    wobble = 0.5 * np.sin(travel / SPACING * 2 * np.pi)  # N/mm, whole cycles
    force = np.stack([np.full(ROWS, 200.0), 0.05 + 2.0 * travel + wobble], -1)
    window = cutting.steady_window(travel, force, SPACING)
    # F_t's rise is ~100 % of its own tiny mean, but 0.5 % of a tenth of the resultant.
    assert window.steady
    assert abs(window.drift[1]) < 100 * cutting.STEADY_DRIFT


def test_one_row_is_no_steady_state_and_bad_input_is_refused():
    window = cutting.steady_window([0.1], [[200.0, 50.0]], SPACING)
    assert not window.steady and window.start == 0
    with pytest.raises(ValueError, match=r"force f\[T, 2\] with T >= 1; got \(2,\) and \(2,\)"):
        cutting.steady_window([0.1, 0.2], [1.0, 2.0], SPACING)
    with pytest.raises(ValueError, match="spacing must be > 0 mm; got 0"):
        cutting.steady_window([0.1], [[1.0, 2.0]], 0)
    with pytest.raises(ValueError, match="0 < last <= 1; got 0.05 and 1.5"):
        cutting.steady_window([0.1], [[1.0, 2.0]], SPACING, last=1.5)


def test_the_dips_follow_the_releases():
    rows, cycle = 1930, 100
    released = 2 + np.arange(rows) // cycle  # a pair released every 100 rows, from row 100
    force = np.full((rows, 2), 200.0)
    for row in range(cycle, rows, cycle):
        force[row + 7, 0] -= 40.0  # 7 rows after each release
    dips = cutting.release_dips(types.SimpleNamespace(released=released, force=force), cycle)
    np.testing.assert_array_equal(dips.releases, np.arange(cycle, rows, cycle))
    # The last release has no whole cycle after it: left out.
    assert len(dips.lag) == len(dips.releases) - 1
    np.testing.assert_array_equal(dips.lag, 7)
    np.testing.assert_allclose(dips.depth, 40.0 * (1 - 1 / cycle), rtol=STEADY_FIT_RTOL)


def _reported(steady: bool) -> dict:
    return {
        "forces_steady": steady,
        "force_window_mm": [0.354, 0.6],
        "cutting_force_drift_percent": 5.4,
        "thrust_force_drift_percent": 17.8,
        "release_dip_cycles": 22,
        "release_dips_after_release": 22,
        "release_dip_lag_steps": 9.0,
        "release_dip_N_per_mm": 52.0,
    }


def test_the_demo_says_whether_the_means_are_steady():
    assert cutting_demo.window_note(_reported(True)).startswith(
        "steady from 0.354 mm of travel (to 0.600 mm; F_c drifts +5.4 %, F_t +17.8 %"
    )
    note = cutting_demo.window_note(_reported(False))
    assert note.startswith("no steady state in the run")
    assert "last 40 % of the steps, 0.354 to 0.600 mm; F_c drifts +5.4 %, F_t +17.8 %" in note
    dips = cutting_demo.dips_note(_reported(True), 0.025, 600)
    assert "in 22 of 22 element cycles" in dips and "within 60 steps after it" in dips
    assert "a median 9 steps after, 52 N/mm below" in dips
    too_few = dict(_reported(True), release_dip_N_per_mm=float("nan"))
    assert cutting_demo.dips_note(too_few, 0.025, 600).startswith("(too few pair releases")
