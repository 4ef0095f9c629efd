"""benchmarks/simulations.py: its record and figure from hand-built runs, and the cutting
summary it records from the coarse cut tests/problems/test_cutting.py runs.

Nothing is timed and no full simulation is run: the suite's measurements are
``cutting.run``, ``cutting.summary``, ``simulations.detection_share``, ``demo.run_demo`` and
``hertz.run``, which tests/problems tests; here are tested what the suite adds (the force
trace, the tables, the notes, the figure).
"""

import json

import numpy as np
import pytest

from benchmarks import simulations
from benchmarks.harness import report, style
from jaxcontact._timing import Timing
from jaxcontact.problems import cutting
from jaxcontact.problems.ploughing.demo import Summary
from tests.problems.test_cutting import COARSE
from tests.support.tolerances import (
    FLOAT32_SUM_ATOL,
    FLOAT32_SUM_RTOL,
    TRACE_END_RTOL,
    TRACE_MEAN_RTOL,
)


def test_the_trace_is_means_over_equal_runs_of_steps():
    travel = np.linspace(0.0, 1.0, 1000)
    force = np.stack([np.arange(1000.0), -np.arange(1000.0)], axis=1)
    found = simulations.trace(travel, force, points=10)
    assert len(found["travel_mm"]) == len(found["cutting_N_per_mm"]) == 10
    assert found["cutting_N_per_mm"][0] == pytest.approx(49.5)
    assert found["thrust_N_per_mm"][-1] == pytest.approx(-949.5)
    assert np.all(np.diff(found["travel_mm"]) > 0)
    short = simulations.trace(travel[:4], force[:4], points=10)  # fewer steps than points
    assert short["cutting_N_per_mm"] == [0.0, 1.0, 2.0, 3.0]


def _run(label, series, cutting_force, mass_scaling):
    """A cutting run as ``measure_cut`` records it: every key the table and figure read."""
    found = {key: 1.0 for _, key, _ in simulations.QUANTITIES}
    found.update(
        label=label,
        series=series,
        cutting_speed_m_per_min=100.0,
        uncut_chip_thickness_mm=0.1,
        rake_deg=0.0,
        friction=0.3,
        friction_shear_factor=0.5,
        element_mm=0.025,
        mass_scaling=mass_scaling,
        cutting_force_N_per_mm=cutting_force,
        thrust_force_N_per_mm=60.0,
        chip_thickness_ratio=1.8,
        merchant_cutting_force_N_per_mm=160.0,
        merchant_thrust_force_N_per_mm=50.0,
        kienzle_cutting_force_N_per_mm=306.4,
        kienzle_band_N_per_mm=[207.1, 306.4],
        eroded_elements=0,
        dropped_own_contacts=12,
        overflow=False,
        detection_share=0.18,
        detection_percent=18.0,
        window_from_mm=0.36,
        trace=simulations.trace(np.linspace(0, 0.6, 50), np.full((50, 2), [cutting_force, 60.0])),
    )
    return found


def _ploughing(nodes, slaves, share):
    summary = Summary(nodes, 717, 1575.0, share, 19, 12, 0.01, (1.0, 2.0), 3.1)
    timed, untimed = Timing(3.1, 0.455, 0.446, 0.468, 5), Timing(0.4, 0.388, 0.38, 0.39, 5)
    return simulations.ploughing_row(summary, 296, timed, untimed, slaves)


def _hertz(across, error):
    """One mesh of the Hertz part as ``measure_hertz`` records it: errors ``error`` % (a, p0),
    four times that (L2), ten times (the gradient); a profile of Hertz's shape."""
    x = np.linspace(-1.5, 1.5, 2 * across + 1)
    return {
        "across": across,
        "h_over_a": 2 / across,
        "nodes": 40 * across,
        "pressed": across + 1,
        "a_mm": 0.236,
        "p0_MPa": 2730.0,
        "a_error_percent": error,
        "p0_error_percent": -error,
        "l2_error_percent": 4 * error,
        "penetration_over_a": 2e-5,
        "force_N_per_mm": 1000.0,
        "newton_steps": 3,
        "residual_N_per_mm": 1e-9,
        "first_s": 12.0,
        "solve_s": 0.1,
        "gradient_first_s": 20.0,
        "gradient_s": 0.15,
        "hertz_a_mm": 0.2349,
        "hertz_p0_MPa": 2710.3,
        "dp0_dR": -140.0,
        "dp0_dR_hertz": -135.5,
        "dp0_dR_error_percent": 10 * error,
        "dp0_dR_against_fd": 4e-7,
        "dp0_dE": 0.0069,
        "dp0_dE_hertz": 0.00645,
        "dp0_dE_error_percent": -10 * error,
        "dp0_dE_against_fd": -1.5e-6,
        "profile": {
            "x_over_a": x.tolist(),
            "p_over_p0": np.sqrt(np.clip(1 - x**2, 0, None)).tolist(),
        },
    }


def _record(hertz=True):
    runs = [
        _run("default (400x mass)", "simulation, 400x mass", 209.3, 400.0),
        _run("half the scaling (200x)", "simulation, 200x mass", 209.5, 200.0),
    ]
    ploughing = [_ploughing(10_000, "surface", 0.138), _ploughing(10_000, "all", -0.02)]
    tables = [
        simulations.cutting_table(runs),
        simulations.ploughing_table(ploughing, 0.5, 5),
    ]
    data = {"cutting": runs, "ploughing": ploughing}
    notes = simulations.cutting_notes(runs)
    if hertz:
        meshes = [_hertz(12, 0.8), _hertz(24, 0.3), _hertz(48, 0.2)]
        tables.append(simulations.hertz_table(meshes))
        data["hertz"] = meshes
        notes += simulations.hertz_notes(meshes)
    rec = report.record("simulations", simulations.TITLE, tables, data=data, notes=notes)
    return json.loads(json.dumps(rec, allow_nan=False))  # as read back from the file


@pytest.fixture
def record():
    return _record()


def test_the_tables_and_notes(record):
    cut, plough, indentation = record["tables"]
    assert cut["columns"] == ["quantity", "default (400x mass)", "half the scaling (200x)"]
    assert len(cut["rows"]) == len(simulations.QUANTITIES)
    rows = {row[0]: row[1:] for row in cut["rows"]}
    assert rows["cutting force F_c (N/mm)"] == [209.3, 209.5]
    assert rows["a search overflowed"] == [False, False]
    assert rows["contact detection's share of a step (%)"] == [18.0, 18.0]
    assert plough["rows"][0][:2] == [10_000, "surface (296)"]
    assert plough["rows"][1][plough["columns"].index("detection %")] == -2.0
    kienzle, mass, hertz = record["notes"]
    assert "207 to 306 N/mm" in kienzle and "0.68 of Kienzle's" in kienzle
    assert "halving it changed F_c by +0.1 %" in mass
    rows = [dict(zip(indentation["columns"], row, strict=True)) for row in indentation["rows"]]
    assert [row["elements across 2a"] for row in rows] == [12, 24, 48]
    assert rows[0]["h / a"] == 0.1667 and rows[0]["p0 error %"] == -0.8
    assert rows[1]["L2 error %"] == 1.2 and rows[2]["dp0/dE vs Hertz %"] == -2.0
    assert rows[0]["jax.grad vs central difference"] == 1.5e-6
    assert "Hertz's a = 0.2349 mm, p0 = 2710 MPa" in indentation["note"]
    assert "from 12 to 48 elements across 2a" in hertz and "L2 3.20 to 0.80 %" in hertz


def test_the_figure_draws_from_the_record_alone(record):
    plt = report.pyplot()
    figure = simulations.draw(record, plt)
    try:
        figure.canvas.draw()
        labels = set()
        for axes in figure.axes:
            labels |= {line.get_label() for line in axes.lines}
            labels |= {bars.get_label() for bars in axes.containers}
        labels = {label for label in labels if not label.startswith("_")}
        hertz = {f"FE, {n} elements across 2a" for n in (12, 24, 48)}
        hertz |= {name for name, _ in simulations.HERTZ_ERRORS}
        assert labels == {
            "simulation, 400x mass",
            "simulation, 200x mass",
            simulations.MERCHANT,
            simulations.KIENZLE,
            simulations.SEARCH,
            simulations.HERTZ_GUIDE,
            "slope 1",
            *hertz,
        }
        missing = {label for label in labels if style.canonical(label) not in style.STYLES}
        assert not missing, f"not in benchmarks/harness/style.py's STYLES: {missing}"
        legend = figure.axes[1].get_legend()
        for axes in figure.axes:
            assert not legend.get_window_extent().overlaps(axes.bbox)
        shares = figure.axes[2]
        assert [t.get_text() for t in shares.get_yticklabels()][-1] == (
            "ploughing, 10,000 nodes, all slaves"
        )
        # The Hertz panels: each mesh's profile and the errors, drawn in their table looks.
        profile, errors = figure.axes[3:5]
        drawn = {line.get_label(): line for line in profile.lines + errors.lines}
        for name, line in drawn.items():
            if name in style.JAXCONTACT:
                assert (line.get_color(), line.get_marker()) == style.JAXCONTACT[name]
        assert errors.get_xscale() == errors.get_yscale() == "log"
        assert min(errors.get_xlim()) > 0 and profile.get_xlim()[0] == 0
        legends = [axes.get_legend() for axes in figure.axes if axes.get_legend()]
        assert len(legends) == 2
        for legend in legends:
            for axes in figure.axes:
                assert not legend.get_window_extent().overlaps(axes.bbox)
    finally:
        plt.close(figure)


def test_a_record_without_the_hertz_part_draws_as_before():
    plt = report.pyplot()
    figure = simulations.draw(_record(hertz=False), plt)
    try:
        figure.canvas.draw()
        assert len(figure.axes) == 3
        assert figure.get_size_inches()[1] == pytest.approx(6.2 + 0.28 * 4)
    finally:
        plt.close(figure)


@pytest.mark.slow
def test_the_recorded_summary_of_the_coarse_cut():
    # The run tests/problems/test_cutting.py's coarse_run makes (compiled once per process).
    cut = cutting.Cutting(travel=0.25, **COARSE)
    model, state, found, frames, seconds = cutting.run(cut, 0.0, cutting.MU, chunks=5)
    summary = simulations.summarise(model, state, found, frames, seconds, "coarse", "series")
    trace = summary["trace"]
    assert len(trace["travel_mm"]) == simulations.POINTS
    end = trace["travel_mm"][-1]
    assert 0 < trace["travel_mm"][0] < end == pytest.approx(0.25, rel=TRACE_END_RTOL)
    assert 0.5 * 0.25 < summary["window_from_mm"] < 0.25
    steady = np.array(trace["cutting_N_per_mm"])[np.array(trace["travel_mm"]) >= 0.16]
    assert steady.mean() == pytest.approx(summary["cutting_force_N_per_mm"], rel=TRACE_MEAN_RTOL)
    summary.update(detection_share=0.2, detection_percent=20.0, wall_s=1.0)
    table = simulations.cutting_table([summary])
    json.dumps(table, allow_nan=False)
    assert [row[0] for row in table["rows"]] == [name for name, _, _ in simulations.QUANTITIES]


def test_the_rake_face_diagnosis_adds_up():
    # The coarse cut, short: the probe's parts of F_t sum to the record's F_t, over one window.
    found = simulations.diagnose("D", {**COARSE, "travel": 0.15}, 0.0)
    assert found["model"] == "Lagrangian" and found["rezones_idle"] is None
    np.testing.assert_allclose(
        sum(found["thrust_split"]),
        found["thrust_force"],
        rtol=FLOAT32_SUM_RTOL,
        atol=FLOAT32_SUM_ATOL,
    )
    assert found["thrust_force"] > 0
    assert 0 < found["contact_length"] <= simulations.BINS * simulations.BIN
    assert found["normal_stress"] > 0 and found["shear_stress"] > 0
    assert 0 <= found["at_cap"] <= 1
    assert found["oxley"].contact_length > 0
