"""Simulations: orthogonal cutting against Merchant and Kienzle, the ploughing simulation's speed,
a cylinder pressed into an elastic block against Hertz.

Three parts, the first two float32, each run as ``jaxcontact demo`` runs it:

1. **Orthogonal cutting** (``jaxcontact.problems.cutting``: AISI 1045, 100 m/min, h = 0.10 mm,
   rake 0°, mu = 0.3 up to Zorev's limit of half the shear flow stress, 4 elements through h,
   0.8 mm of travel, mass scaled 400x), then the same cut at half the mass scaling (200x: the
   stable step shorter by sqrt 2, the steps more by as much) and at half the element size
   (the mesh refined: 8 elements through h, about 8x the work). Then **other conditions**,
   one run each, the default mesh: 200 m/min, h = 0.05 and 0.15 mm, rake +10° and -10°, and
   Zorev's limit raised to the shear flow stress A / sqrt 3 (a shear factor of 1).
   Reported: the steady cutting and thrust forces (means over the last
   40 % of the steps, N per mm of width), the chip's thickness ratio and shear angle (from
   the chip's geometry), the friction angle (from the forces), beside

   * **Merchant** (``cutting.machining``): the shear angle 45 + gamma/2 - beta/2 and the forces
     of the force circle for the friction angle the run gives, with the shear stress
     tau_s = sigma_JC / sqrt 3 at the steady chip's plastic strain and temperature and the
     primary shear zone's strain rate;
   * **Kienzle** for Ck45: k_c1.1 = 2220 N/mm², m_c = 0.14 (König and Klocke), and the band
     down to k_c1.1 = 1500 N/mm² that handbooks span;
   * **mass scaling**: the forces of both runs and their difference;

   and the share of a step spent in contact detection (``detection_share``, here: the
   step's two searches alone, 400 steps, over whole steps; the median of 3).
2. **The ploughing simulation** (``jaxcontact.problems.ploughing.demo.run_demo``; a tool
   ploughing elastic steel, 3 m/s, 0.5 mm of travel) at 10^4 and 63,001 nodes, the slaves
   the workpiece's free outline (the default) and every node: the set-up and the search's sizes
   on the host, one run to compile (allocating larger sizes if they overflowed), then the whole
   ``lax.scan`` timed ``--repeats`` times beside the same scan with detection replaced by a
   fixed contact result (``scan(..., detect=False)``: the same elastic update and force
   assembly, no ``Search.closest``), the two in alternation. The detection share is the
   median over those pairs of ``1 - without / with``.
3. **Hertz indentation** (``jaxcontact.problems.hertz``, float64): a rigid cylinder (R = 10 mm)
   pressed with P = 1,000 N/mm into an elastic steel block (E = 210 GPa, nu = 0.3), plane
   strain, frictionless, solved to equilibrium by Newton-CG at 12, 24 and 48 elements across
   Hertz's contact width 2a (``--quick``: 12 and 24), against Hertz's line contact (Johnson,
   Contact Mechanics, 1985, eq. 4.43-4.45: a = sqrt(4PR / pi E*), p0 = 2P / pi a, E* = E /
   (1 - nu^2)). Reported per mesh: the FE a (the least-squares fit of p^2 = p0^2 (1 - x^2/a^2)
   over the pressed nodes) and p0 (the node at x = 0) against Hertz's, the relative L2 error
   of the nodal pressures, the deepest penetration, and ``jax.grad`` of the FE p0 with
   respect to R and E (the implicit-function theorem) against Hertz's dp0/dR = -p0/2R,
   dp0/dE = p0/2E and against a central difference of the FE value (step 1e-5 of the
   parameter). Timed: the solve with its compilation, then again compiled; the gradient
   likewise.

A published orthogonal-cutting experiment on AISI 1045 is not in this comparison: the data
sets found (Klippel et al. 2024, Int. J. Adv. Manuf. Technol. 135, 2871-2908, Ck45 with open
data; the CIRP benchmark of Ivester et al. 2000) could not be read from this machine, and no
number is quoted from memory.

The figure: the cutting and thrust forces against the tool's travel with Merchant's and
Kienzle's predictions, detection's share of a step in every run; the FE contact pressure of
each mesh over Hertz's, and the errors against the element size.

    python benchmarks/simulations.py                  # about 20 min on 2 cores
    python benchmarks/simulations.py --quick          # a coarse cut, no others, 2,000 nodes
                                                      # ploughing, Hertz at 12 and 24 elements
    python benchmarks/simulations.py --ale            # about 8 min: the ALE chip root and the
                                                      # chip's own friction limit against
                                                      # Extended Oxley, a table on stdout
    python benchmarks/simulations.py --diagnostics    # about 7 min: the rake face term by
                                                      # term at D, C and A (--diagnostics D:
                                                      # one condition), a table on stdout

``--ale`` runs only ``ALE_RUNS`` (issue 51's checks, not yet part of the stored record): each
an orthogonal cut on the default mesh, 0.8 mm of travel, mu = 0.3, the Lagrangian default
first, then the chip root rezoned and remapped every 20 steps (``sim.ale``) at the default
cap, at A / sqrt 3, and at the chip's own shear flow stress (``friction_limit="flow"``,
m = 1) at 100 m/min h 0.10 mm rake 0°, h 0.15 mm, rake -10°, 200 m/min h 0.15 mm rake -7°
and 300 m/min h 0.15 mm rake +5°; beside each, ``cutting.machining.oxley`` (Lalwani et al.
2009) at the same speed, thickness and rake.

``--diagnostics`` measures the rake face of issue 60's conditions D (100 m/min, h 0.10 mm,
rake 0°), C (300 m/min, h 0.15 mm, +5°) and A (200 m/min, h 0.15 mm, -7°), each cut
Lagrangian and with the ALE chip root (every 20 steps), at the default friction, 0.8 mm of
travel, over the last 40 % of the steps: what each step saw at the tool comes from the model
(``cutting.observe`` with the probe ``rake_face``), binned in 5 µm along the rake face from
the parting line at the edge. Reported: F_c and F_t; F_t split into the rake face's friction
and its pressure (each node's force along its contact's tangent and normal), the edge's arc,
the flank and the rest; the contact length (the rake face's normal force, 99 % of it within
it), the mean normal and shear stress over it, the share of the pressed rake-face node-steps
whose friction is at Zorev's cap, the rezones that moved no node, and each eroded element
(its step, travel, plastic strain and temperature before the step, where it was, and the
distortion that took it out); beside them Oxley's h', sigma_N and tau_int.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import _run, report, style
from jaxcontact.problems import cutting, hertz
from jaxcontact.problems.cutting import machining
from jaxcontact.problems.ploughing.demo import run_demo
from jaxcontact.sim import ale

TITLE = "Simulations: orthogonal cutting, ploughing, a cylinder against Hertz"
POINTS = 300  # a force trace's points in the record: means over as many equal runs of steps
COARSE = {"element": 0.05, "uncut": 0.10, "depth": 0.1, "travel": 0.25}  # --quick's cut
PLOUGHING = {"full": ((10_000, 63_001), 0.5), "quick": ((2_000,), 0.1)}  # (nodes, travel mm)
HERTZ = {"full": hertz.MESHES, "quick": hertz.MESHES[:2]}  # elements across 2a
HERTZ_STEP = 1e-5  # the central difference's step, relative to the parameter
# The other conditions: (label, what differs from the default cut, the rake angle in degrees).
CONDITIONS = (
    ("200 m/min", {"speed": 200.0}, 0.0),
    ("h = 0.05 mm", {"uncut": 0.05}, 0.0),
    ("h = 0.15 mm", {"uncut": 0.15}, 0.0),
    ("rake +10°", {}, 10.0),
    ("rake -10°", {}, -10.0),
    # Zorev's limit at the shear flow stress A / sqrt 3 (twice the default's): the sticking
    # friction Oxley-type analyses assume, which the Lagrangian chip root must carry.
    ("sticking limit A/√3", {"shear_factor": 1.0}, 0.0),
)
# The quantities of the cutting table: (row, summary key, decimals; None: as it is).
QUANTITIES = (
    ("cutting force F_c (N/mm)", "cutting_force_N_per_mm", 1),
    ("thrust force F_t (N/mm)", "thrust_force_N_per_mm", 1),
    ("forces steady over the averaging window", "forces_steady", None),
    ("averaging window from (mm of travel)", "window_from_mm", 3),
    ("F_c's drift over the window (%)", "cutting_force_drift_percent", 1),
    ("F_t's drift over the window (%)", "thrust_force_drift_percent", 1),
    ("chip thickness ratio h_c / h", "chip_thickness_ratio", 2),
    ("shear angle from the chip (°)", "shear_angle_deg", 1),
    ("friction angle from the forces (°)", "friction_angle_deg", 1),
    ("chip plastic strain (median)", "chip_plastic_strain", 2),
    ("chip temperature (°C, median)", "chip_temperature_C", 0),
    ("shear zone strain rate (1/s)", "shear_zone_strain_rate_per_s", -2),
    ("Merchant: tau_s (MPa)", "merchant_shear_stress_MPa", 0),
    ("Merchant: shear angle (°)", "merchant_shear_angle_deg", 1),
    ("Merchant: F_c (N/mm)", "merchant_cutting_force_N_per_mm", 1),
    ("Merchant: F_t (N/mm)", "merchant_thrust_force_N_per_mm", 1),
    ("Kienzle (Ck45): F_c (N/mm)", "kienzle_cutting_force_N_per_mm", 1),
    ("deepest penetration / element", "max_penetration_over_element", 3),
    ("eroded elements", "eroded_elements", None),
    ("own contacts left out (deeper than 0.25 element)", "dropped_own_contacts", None),
    ("a search overflowed", "overflow", None),
    ("nodes", "nodes", None),
    ("steps", "steps", None),
    ("steps per second (the first compile included)", "steps_per_second", 0),
    ("contact detection's share of a step (%)", "detection_percent", 1),
    ("wall time, detection share included (s)", "wall_s", 0),
)


# -- orthogonal cutting --------------------------------------------------------------


def cuts(quick: bool):
    """``(Cutting, label, series)`` of each run: the default cut (``--quick``: a coarse one),
    the same at half the mass scaling, and (not ``quick``) at half the element size."""
    base = cutting.Cutting(**COARSE) if quick else cutting.Cutting()
    kind = "coarse" if quick else "default"
    mass = base.mass_scaling
    plan = [
        (base, f"{kind} ({mass:.0f}x mass)", f"simulation, {mass:.0f}x mass"),
        (
            dataclasses.replace(base, mass_scaling=mass / 2),
            f"half the scaling ({mass / 2:.0f}x)",
            f"simulation, {mass / 2:.0f}x mass",
        ),
    ]
    if not quick:
        half = dataclasses.replace(base, element=base.element / 2)
        plan.append((half, "half the element", "simulation, half the element"))
    return plan


def trace(travel, force, points: int = POINTS) -> dict:
    """The force on the tool against its travel, in ``points`` means over equal runs of
    steps (a run has one per step: too many for the record, and noisy step to step)."""
    travel, force = np.asarray(travel, np.float64), np.asarray(force, np.float64)
    edges = np.linspace(0, len(travel), min(points, len(travel)) + 1).round().astype(int)
    parts = list(zip(edges[:-1], edges[1:], strict=True))
    return {
        "travel_mm": [round(float(travel[a:b].mean()), 5) for a, b in parts],
        "cutting_N_per_mm": [round(float(force[a:b, 0].mean()), 3) for a, b in parts],
        "thrust_N_per_mm": [round(float(force[a:b, 1].mean()), 3) for a, b in parts],
    }


def summarise(
    model, state, record, frames, seconds, label: str, series: str, rake: float = 0.0
) -> dict:
    """A cutting run's summary (``cutting.summary``) with what the record adds: its label
    and series, the element, the own contacts left out, the force trace and where the
    forces' averaging window begins (``cutting.steady_window``: the steady state where the
    run reaches one, else the last 40 % of the steps)."""
    summary = cutting.summary(model, state, record, frames, seconds, rake, cutting.MU)
    steps = len(record.force)
    at = np.arange(1, steps + 1)
    travel = cutting.tool_travel(model.cut, at)
    summary.update(
        label=label,
        series=series,
        element_mm=model.cut.element,
        dropped_own_contacts=int(np.sum(record.dropped)),
        window_from_mm=float(summary["force_window_mm"][0]),
        trace=trace(travel, record.force),
    )
    return summary


def _detect(model, state, rake, steps: int):
    """The cut's step's two searches alone (``cutting.contacts``), ``steps`` times on
    ``state``'s configuration nudged each time (so that no search is hoisted out of the loop)."""
    x0 = state.body.x
    kept = cutting.held(model.mesh, state.alive)
    lowest_x = cutting.tool_position(model.cut, model.start_x, state.step)

    def body(carry, k):
        x = x0 + (k * 1e-9).astype(x0.dtype)
        _, on_tool, tool_state, _, _, on_own, own_state = cutting.contacts(
            model, *carry, x, lowest_x, rake, state.released, state.alive, kept
        )
        return (tool_state, own_state), on_tool.gap.sum() + on_own.gap.sum()

    ks = jnp.arange(steps, dtype=x0.dtype)
    return jax.lax.scan(body, (state.tool, state.own), ks)


_detect_jit = jax.jit(_detect, static_argnums=3)


def detection_share(model, state, rake_deg: float, mu: float, steps: int = 400, repeats: int = 3):
    """The share of a cut's step spent in contact detection: the time of the two
    searches alone over the time of whole steps (``cutting.advance``), each ``steps``
    long from ``state`` (compiled first, then the median of ``repeats`` alternated runs)."""
    dtype = jnp.dtype(model.cut.dtype)
    rake = jnp.asarray(math.radians(rake_deg), dtype)
    mu = jnp.asarray(mu, dtype)
    jax.block_until_ready(cutting.advance(model, state, rake, mu, steps))
    jax.block_until_ready(_detect_jit(model, state, rake, steps))
    ratios = []
    for _ in range(repeats):
        started = time.perf_counter()
        jax.block_until_ready(cutting.advance(model, state, rake, mu, steps))
        whole = time.perf_counter() - started
        started = time.perf_counter()
        jax.block_until_ready(_detect_jit(model, state, rake, steps))
        ratios.append((time.perf_counter() - started) / whole)
    return float(np.median(ratios))


def measure_cut(cut, label: str, series: str, rake: float = 0.0, share: bool = True) -> dict:
    """One cut at ``rake`` (degrees) summarised, with detection's share of a step (``share``)."""
    started = time.perf_counter()
    model, state, record, frames, seconds = cutting.run(cut, rake, cutting.MU)
    summary = summarise(model, state, record, frames, seconds, label, series, rake)
    if share:
        summary["detection_share"] = detection_share(model, state, rake, cutting.MU)
        summary["detection_percent"] = 100 * summary["detection_share"]
    summary["wall_s"] = time.perf_counter() - started
    print(
        f"{label}: F_c {summary['cutting_force_N_per_mm']:.1f} N/mm, "
        f"F_t {summary['thrust_force_N_per_mm']:.1f} N/mm, "
        f"chip ratio {summary['chip_thickness_ratio']:.2f}, "
        f"{summary['steps']} steps in {summary['wall_s']:.0f} s",
        file=sys.stderr,
        flush=True,
    )
    return summary


def rounded(value, decimals):
    """A table cell: ``value`` to ``decimals`` places (negative: significant figures)."""
    if value is None or decimals is None:
        return value
    if decimals < 0:
        return float(f"{value:.{-decimals}g}")
    return round(float(value), decimals) if decimals else round(float(value))


def cutting_table(runs) -> dict:
    """A row per quantity, a column per run."""
    columns = ["quantity", *(run["label"] for run in runs)]
    cells = [
        [name, *(rounded(run[key], decimals) for run in runs)] for name, key, decimals in QUANTITIES
    ]
    base = runs[0]
    note = (
        f"Cut: {base['cutting_speed_m_per_min']:g} m/min, h = {base['uncut_chip_thickness_mm']:g}"
        f" mm, rake {base['rake_deg']:g}°, clearance 7°, edge radius 2 µm, mu = "
        f"{base['friction']:g} capped at {base['friction_shear_factor']:g} of A/sqrt 3 "
        f"(Zorev's sticking zone), plane strain, {base['element_mm'] * 1000:g} µm elements. "
        "Forces per mm of width, means over the steady state where the run reaches one "
        "(`cutting.steady_window`: a window to the run's end whose least-squares line drifts "
        "by at most 5 %), else over the last 40 % of the steps, with the drift; one run of each. "
        "A published experiment is not compared here (the module's docstring says why)."
    )
    return report.table(columns, cells, title="Orthogonal cutting, AISI 1045", note=note)


# The conditions table: (column, summary key, decimals).
CONDITION_COLUMNS = (
    ("F_c (N/mm)", "cutting_force_N_per_mm", 1),
    ("F_t (N/mm)", "thrust_force_N_per_mm", 1),
    ("chip ratio", "chip_thickness_ratio", 2),
    ("shear angle (°)", "shear_angle_deg", 1),
    ("steady", "forces_steady", None),
    ("F_c drift (%)", "cutting_force_drift_percent", 1),
    ("F_t drift (%)", "thrust_force_drift_percent", 1),
    ("eroded elements", "eroded_elements", None),
    ("Merchant F_c (N/mm)", "merchant_cutting_force_N_per_mm", 1),
    ("Merchant F_t (N/mm)", "merchant_thrust_force_N_per_mm", 1),
    ("Kienzle F_c (N/mm)", "kienzle_cutting_force_N_per_mm", 1),
)


def conditions_table(runs) -> dict:
    """A row per cutting condition: the default cut, then each of ``CONDITIONS``."""
    labels = ["default: 100 m/min, h = 0.10 mm, rake 0°", *(label for label, _, _ in CONDITIONS)]
    cells = [
        [label, *(rounded(run[key], decimals) for _, key, decimals in CONDITION_COLUMNS)]
        for label, run in zip(labels, runs, strict=False)
    ]
    note = (
        "One run each on the default mesh (25 µm elements), 0.8 mm of travel, mu = 0.3 up to "
        "Zorev's limit of half of A/sqrt 3. Means as in the table above. Merchant's forces "
        "are for each run's own friction angle and shear flow stress; Kienzle's for Ck45 with "
        "k_c1.1 = 2220 N/mm², m_c = 0.14, whatever the speed and rake (its fit has neither). "
        "An eroded element is one the run took out as folded (`Cutting.erode`): a run with "
        "eroded elements tore its mesh, and its forces are not the cut's."
    )
    return report.table(
        ["condition", *(name for name, _, _ in CONDITION_COLUMNS)],
        cells,
        title="Orthogonal cutting at other conditions",
        note=note,
    )


def cutting_notes(runs) -> list[str]:
    """What the cutting runs say beside the table: Kienzle's band, Merchant's and Kienzle's
    forces over the simulated, what halving the mass scaling changed."""
    base = runs[0]
    low, high = base["kienzle_band_N_per_mm"]
    notes = [
        f"Kienzle's band for Ck45 at h = {base['uncut_chip_thickness_mm']:g} mm: {low:.0f} to "
        f"{high:.0f} N/mm (k_c1.1 from 1500 to 2220 N/mm², m_c = 0.14). In the "
        f"{base['label']} run the simulated F_c is {base['cutting_force_N_per_mm'] / high:.2f} "
        f"of Kienzle's tabulated value; Merchant's F_c for the run's own friction angle is "
        f"{base['merchant_cutting_force_N_per_mm'] / base['cutting_force_N_per_mm']:.2f} of "
        "the simulated."
    ]
    if len(runs) > 1:
        half = runs[1]
        change = {
            key: 100 * (half[key] / base[key] - 1)
            for key in ("cutting_force_N_per_mm", "thrust_force_N_per_mm", "chip_thickness_ratio")
        }
        notes.append(
            f"Mass scaling: halving it changed F_c by {change['cutting_force_N_per_mm']:+.1f} %, "
            f"F_t by {change['thrust_force_N_per_mm']:+.1f} % and the chip ratio by "
            f"{change['chip_thickness_ratio']:+.1f} %."
        )
    return notes


# -- the ploughing simulation ----------------------------------------------------------


def measure_ploughing(nodes: int, travel: float, repeats: int, slaves: str) -> dict:
    summary, drawn = run_demo(nodes, travel, repeats, np.float32, slaves)
    config, timed, untimed = drawn[2], drawn[5], drawn[6]
    return ploughing_row(summary, config.sizes["closest"].num_slaves, timed, untimed, slaves)


def ploughing_row(summary, num_slaves: int, timed, untimed, slaves: str) -> dict:
    """One ploughing run as plain numbers: ``summary`` a ``demo.Summary``, ``timed`` and
    ``untimed`` the ``Timing`` of the scan with and without detection."""
    return {
        "nodes": summary.nodes,
        "slaves": slaves,
        "slave nodes": num_slaves,
        "steps": summary.steps,
        "steps/s": round(summary.steps_per_s),
        "scan s": round(timed.median_s, 4),
        "scan p10 s": round(timed.p10_s, 4),
        "scan p90 s": round(timed.p90_s, 4),
        "without detection s": round(untimed.median_s, 4),
        "detection share": round(summary.detection_share, 4),
        "detection %": round(100 * summary.detection_share, 1),
        "list rebuilds": summary.rebuilds,
        "compile + first run s": round(summary.first_s, 2),
    }


def ploughing_table(rows, travel: float, repeats: int) -> dict:
    columns = (
        "nodes",
        "slaves",
        "steps",
        "steps/s",
        "scan s",
        "without detection s",
        "detection %",
        "list rebuilds",
        "compile + first run s",
    )
    cells = [{**entry, "slaves": f"{entry['slaves']} ({entry['slave nodes']:,})"} for entry in rows]
    note = (
        f"Tool travel {travel:g} mm at 3 m/s, steel with mass scaling 1e4. `scan s`: the "
        f"whole `lax.scan`, median of {repeats} runs (the record's data keeps the 10th and "
        "90th percentiles); `detection %`: the median over pairs of runs of "
        "1 - without / with; a scan of milliseconds on a loaded machine can make it negative."
    )
    return report.table(columns, cells, title="The ploughing simulation", note=note)


# -- a cylinder against Hertz ---------------------------------------------------------

HERTZ_GUIDE = "Hertz (Johnson 1985)"
# (series, the row's key of the error in %)
HERTZ_ERRORS = (
    ("FE a against Hertz's", "a_error_percent"),
    ("FE p0 against Hertz's", "p0_error_percent"),
    ("FE p(x), relative L2", "l2_error_percent"),
    ("jax.grad dp0/dR against Hertz's", "dp0_dR_error_percent"),
    ("jax.grad dp0/dE against Hertz's", "dp0_dE_error_percent"),
)
PROFILE_SPAN = 1.5  # the recorded profile: top nodes with |x| <= 1.5 a


def _timed(call):
    started = time.perf_counter()
    found = jax.block_until_ready(call())
    return found, time.perf_counter() - started


def measure_hertz(across: int, problem: hertz.Indentation = hertz.NOMINAL) -> dict:
    """One mesh: the solve against Hertz, ``jax.grad`` of the FE p0 against Hertz's
    derivatives and a central difference, each timed with its compilation and again."""
    result, first_s = _timed(lambda: hertz.run(problem, across))
    _, solve_s = _timed(lambda: hertz.run(problem, across))
    block = hertz.setup(problem, across)
    gradient = jax.jit(jax.value_and_grad(hertz.peak_pressure, argnums=1))
    (_, grads), gradient_first_s = _timed(lambda: gradient(block, problem))
    _, gradient_s = _timed(lambda: gradient(block, problem))
    exact = result.exact
    analytic = {"R": -exact.peak / (2 * problem.radius), "E": exact.peak / (2 * problem.young)}
    row = {}
    for key, name in (("R", "radius"), ("E", "young")):
        nominal, found = getattr(problem, name), float(getattr(grads, name))
        step = HERTZ_STEP * nominal
        up, down = (
            float(hertz.peak_pressure(block, problem._replace(**{name: nominal + change})))
            for change in (step, -step)
        )
        row[f"dp0_d{key}"] = found
        row[f"dp0_d{key}_hertz"] = analytic[key]
        row[f"dp0_d{key}_error_percent"] = 100 * (found / analytic[key] - 1)
        row[f"dp0_d{key}_against_fd"] = found / ((up - down) / (2 * step)) - 1
    a, p0 = exact.half_width, exact.peak
    shown = np.abs(result.x) <= PROFILE_SPAN * a
    row.update(
        across=result.across,
        h_over_a=result.element / a,
        nodes=result.nodes,
        pressed=result.active,
        a_mm=result.half_width,
        p0_MPa=result.peak,
        a_error_percent=100 * result.half_width_error,
        p0_error_percent=100 * result.peak_error,
        l2_error_percent=100 * result.l2_error,
        penetration_over_a=result.penetration / a,
        force_N_per_mm=result.force,
        newton_steps=result.newton_steps,
        residual_N_per_mm=result.residual,
        first_s=first_s,
        solve_s=solve_s,
        gradient_first_s=gradient_first_s,
        gradient_s=gradient_s,
        hertz_a_mm=a,
        hertz_p0_MPa=p0,
        profile={
            "x_over_a": [round(float(x), 6) for x in result.x[shown] / a],
            "p_over_p0": [round(float(p), 6) for p in result.pressure[shown] / p0],
        },
    )
    print(
        f"hertz, {across} across: a {row['a_error_percent']:+.2f} %, p0 "
        f"{row['p0_error_percent']:+.2f} %, L2 {row['l2_error_percent']:.2f} %, "
        f"solve {solve_s:.2f} s",
        file=sys.stderr,
        flush=True,
    )
    return row


def hertz_table(rows) -> dict:
    columns = (
        "elements across 2a",
        "h / a",
        "nodes",
        "pressed nodes",
        "a error %",
        "p0 error %",
        "L2 error %",
        "penetration / a",
        "dp0/dR vs Hertz %",
        "dp0/dE vs Hertz %",
        "jax.grad vs central difference",
        "Newton steps",
        "solve s",
        "compile + first solve s",
        "gradient s",
    )
    cells = [
        [
            row["across"],
            round(row["h_over_a"], 4),
            row["nodes"],
            row["pressed"],
            round(row["a_error_percent"], 2),
            round(row["p0_error_percent"], 2),
            round(row["l2_error_percent"], 2),
            float(f"{row['penetration_over_a']:.2g}"),
            round(row["dp0_dR_error_percent"], 2),
            round(row["dp0_dE_error_percent"], 2),
            float(f"{max(abs(row['dp0_dR_against_fd']), abs(row['dp0_dE_against_fd'])):.2g}"),
            row["newton_steps"],
            round(row["solve_s"], 3),
            round(row["first_s"], 1),
            round(row["gradient_s"], 3),
        ]
        for row in rows
    ]
    first = rows[0]
    note = (
        f"A rigid cylinder, R = {hertz.NOMINAL.radius:g} mm, pressed with P = "
        f"{hertz.NOMINAL.force:g} N/mm into steel (E = {hertz.NOMINAL.young:g} MPa, nu = "
        f"{hertz.NOMINAL.poisson:g}), plane strain, frictionless, float64: Hertz's a = "
        f"{first['hertz_a_mm']:.4g} mm, p0 = {first['hertz_p0_MPa']:.4g} MPa (Johnson 1985, "
        "eq. 4.43-4.45). Block 20a x 10a, bottom fixed, sides free; penalty 100 E*/h. "
        "Errors: FE / Hertz - 1; a from the least-squares fit of p^2 over the pressed "
        "nodes, p0 the node at x = 0; L2 over the contact, weighted by tributary length. "
        "dp0/dR, dp0/dE: jax.grad of the FE p0 (implicit-function theorem) against Hertz's "
        "-p0/2R and p0/2E; against a central difference of the FE value (step 1e-5), the "
        "larger relative difference of the two. Times: one run each."
    )
    return report.table(
        columns, cells, title="A cylinder pressed into a block, against Hertz", note=note
    )


def hertz_notes(rows) -> list[str]:
    """How the errors fall from the coarsest mesh to the finest."""
    first, last = rows[0], rows[-1]
    falls = ", ".join(
        f"{name} {abs(first[key]):.2f} to {abs(last[key]):.2f} %"
        for name, key in (
            ("a", "a_error_percent"),
            ("p0", "p0_error_percent"),
            ("L2", "l2_error_percent"),
            ("dp0/dR", "dp0_dR_error_percent"),
            ("dp0/dE", "dp0_dE_error_percent"),
        )
    )
    return [
        f"Hertz: from {first['across']} to {last['across']} elements across 2a the errors "
        f"(absolute) go {falls}."
    ]


def draw_hertz(rows, profile, errors, used) -> None:
    """The FE pressures of each mesh over Hertz's p(x) (x >= 0: the problem is symmetric),
    and each error against the element size (log-log, a slope-1 guide)."""
    curve = np.linspace(0, PROFILE_SPAN, 301)
    guide = style.style(HERTZ_GUIDE, used, kind="guide")
    profile.plot(curve, np.sqrt(np.clip(1 - curve**2, 0, None)), label=HERTZ_GUIDE, **guide)
    for row in rows:
        name = f"FE, {row['across']} elements across 2a"
        looks = style.style(name, used, kind="jaxcontact")
        x, p = np.array(row["profile"]["x_over_a"]), np.array(row["profile"]["p_over_p0"])
        right = x >= 0
        profile.plot(x[right], p[right], label=name, **{**looks, "linewidth": 0.8})
    profile.set(xlim=(0, PROFILE_SPAN), ylim=(0, 1.12), xlabel="x / a (Hertz's a)")
    profile.set_ylabel("contact pressure p / p0 (Hertz's p0)")
    profile.set_title("Contact pressure against Hertz's p(x)", fontsize=9.5)

    sizes = np.array([row["h_over_a"] for row in rows])
    for name, key in HERTZ_ERRORS:
        looks = style.style(name, used, kind="jaxcontact")
        values = np.array([abs(row[key]) for row in rows])
        errors.plot(sizes, np.maximum(values, 1e-3), label=name, **looks)
    anchor = max(abs(rows[0]["l2_error_percent"]), 1e-3)
    errors.plot(
        [sizes.min(), sizes.max()],
        [anchor * sizes.min() / sizes.max(), anchor],
        label="slope 1",
        **style.style("slope 1", used),
    )
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

    errors.set(xscale="log", yscale="log", xlabel="element size at the contact h / a")
    # Ticks at the meshes' sizes and at 1-2-5 per cent, written out (no powers of ten).
    errors.xaxis.set_major_locator(FixedLocator(sorted(sizes)))
    errors.yaxis.set_major_locator(
        FixedLocator([m * 10.0**k for k in range(-3, 3) for m in (1, 2, 5)])
    )
    for axis in (errors.xaxis, errors.yaxis):
        axis.set_minor_locator(NullLocator())
        axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:.3g}"))
    errors.set_ylabel("|FE / Hertz - 1| (%)")
    errors.set_title("Errors against the element size", fontsize=9.5)


# -- the suite ---------------------------------------------------------------------------


def run(args) -> dict:
    started = time.perf_counter()
    runs = [measure_cut(*plan) for plan in cuts(args.quick)]
    others = [
        measure_cut(
            dataclasses.replace(cutting.Cutting(), **change), label, "condition", rake, False
        )
        for label, change, rake in ([] if args.quick else CONDITIONS)
    ]
    sizes, travel = PLOUGHING["quick" if args.quick else "full"]
    repeats = args.repeats or 5
    ploughing = [
        measure_ploughing(nodes, travel, repeats, slaves)
        for nodes in sizes
        for slaves in ("surface", "all")
    ]
    indentation = [measure_hertz(across) for across in HERTZ["quick" if args.quick else "full"]]
    notes = [
        *cutting_notes(runs),
        *hertz_notes(indentation),
        f"Whole run {time.perf_counter() - started:.0f} s.",
    ]
    tables = [
        cutting_table(runs),
        *([conditions_table([runs[0], *others])] if others else []),
        ploughing_table(ploughing, travel, repeats),
        hertz_table(indentation),
    ]
    data = {"cutting": runs, "conditions": others, "ploughing": ploughing, "hertz": indentation}
    return {"title": TITLE, "tables": tables, "data": data, "notes": notes}


MERCHANT, KIENZLE, SEARCH = "Merchant", "Kienzle (Ck45)", "Search.closest (reused state)"


def draw(record, plt):
    """The cutting and thrust forces against travel, Merchant's and Kienzle's forces beside
    them, the averaging window marked (steady or not, with the drift); below, detection's
    share of a step in every run; then (in records that have it) the Hertz part: the pressure
    profiles and the errors."""
    runs, ploughing = record["data"]["cutting"], record["data"]["ploughing"]
    indentation = record["data"].get("hertz")  # records before the Hertz part have none
    labels = [f"cutting, {run['label']}" for run in runs]
    labels += [f"ploughing, {r['nodes']:,} nodes, {r['slaves']} slaves" for r in ploughing]
    heights = [3, 0.8 + 0.3 * len(labels)] + ([3] if indentation else [])
    figure = plt.figure(figsize=(11, 6.2 + 0.28 * len(labels) + 1.3 * sum(heights[2:])), dpi=120)
    grid = figure.add_gridspec(len(heights), 2, height_ratios=heights)
    forces = [figure.add_subplot(grid[0, 0]), figure.add_subplot(grid[0, 1])]
    used = {}
    for axes, key, merchant, name in (
        (forces[0], "cutting_N_per_mm", "merchant_cutting_force_N_per_mm", "cutting force F_c"),
        (forces[1], "thrust_N_per_mm", "merchant_thrust_force_N_per_mm", "thrust force F_t"),
    ):
        for run in runs:
            looks = style.style(run["series"], used, kind="jaxcontact")
            travel = run["trace"]["travel_mm"]
            every = max(1, len(travel) // 12)
            axes.plot(travel, run["trace"][key], label=run["series"], markevery=every, **looks)
        base = runs[0]
        # The averaging window: a rule where it starts (a fill would compete with Kienzle's
        # band), saying whether the forces are steady over it (cutting.steady_window).
        axes.axvline(base["window_from_mm"], color="#999999", linewidth=0.9, linestyle=(0, (4, 3)))
        drift = base.get(
            f"{'cutting' if key == 'cutting_N_per_mm' else 'thrust'}_force_drift_percent"
        )
        steady = base.get("forces_steady", True)
        axes.annotate(
            "mean: steady state →" if steady else f"mean: drifts {drift:+.0f} % →",
            (base["window_from_mm"], 0.0),
            xycoords=("data", "axes fraction"),
            xytext=(3, 4),
            textcoords="offset points",
            fontsize=7,
            color="#666666",
        )
        axes.axhline(base[merchant], label=MERCHANT, **style.style(MERCHANT, used, kind="guide"))
        if key == "cutting_N_per_mm":
            low, high = base["kienzle_band_N_per_mm"]
            kienzle = style.style(KIENZLE, used, kind="guide")
            axes.axhspan(low, high, color=kienzle["color"], alpha=0.12, linewidth=0)
            axes.axhline(base["kienzle_cutting_force_N_per_mm"], label=KIENZLE, **kienzle)
        axes.set_ylim(bottom=0)
        axes.set_xlim(left=0)
        axes.set(xlabel="tool travel (mm)", ylabel=f"{name} (N per mm of width)")
        axes.set_title(f"{name[0].upper()}{name[1:]}", fontsize=9.5)
    style.legend_outside(forces[1], "right")

    axes = figure.add_subplot(grid[1, :])
    shares = [run["detection_share"] for run in runs] + [r["detection share"] for r in ploughing]
    at = np.arange(len(labels))[::-1]
    colour = style.style(SEARCH, used)["color"]
    percent = [100 * share for share in shares]
    axes.barh(at, percent, color=colour, height=0.6, label=SEARCH)
    for y, value in zip(at, percent, strict=True):
        axes.text(max(value, 0) + 0.6, y, f"{value:.0f} %", va="center", fontsize=7.5)
    axes.set_yticks(at, labels, fontsize=7.5)
    axes.set_xlim(min(0.0, 1.15 * min(percent, default=0)), max(10.0, 1.15 * max(percent)))
    axes.axvline(0, color="#555555", linewidth=0.8)
    axes.set_xlabel("share of a step in contact detection, Search.closest (%)")
    axes.set_title("Contact detection's share of a simulation step", fontsize=9.5)
    title = (
        "Orthogonal cutting against Merchant and Kienzle (band: Kienzle's handbook span); "
        "contact detection's share of a step"
    )
    if indentation:
        panels = [figure.add_subplot(grid[2, 0]), figure.add_subplot(grid[2, 1])]
        draw_hertz(indentation, *panels, used)
        style.legend_outside(panels[1], "right", panels=panels)
        title += ";\na rigid cylinder pressed into an elastic block against Hertz"
    figure.suptitle(title, fontsize=10.5)
    return figure


# -- the ALE chip root against Extended Oxley (--ale) -------------------------------------

ALE_EVERY = ale.Settings(every=20)
# Zorev's limit at the chip's own shear flow stress, m = 1 (Oxley's sticking).
ALE_OWN = {"ale": ALE_EVERY, "shear_factor": 1.0, "friction_limit": "flow"}
# fmt: off
ALE_RUNS = (
    ("Lagrangian, cap A/(2√3)", {}, 0.0),
    ("ALE, cap A/(2√3)", {"ale": ALE_EVERY}, 0.0),
    ("ALE, cap A/√3", {"ale": ALE_EVERY, "shear_factor": 1.0}, 0.0),
    ("ALE, chip's own k", ALE_OWN, 0.0),
    ("ALE, chip's own k, h 0.15", {**ALE_OWN, "uncut": 0.15}, 0.0),
    ("ALE, chip's own k, rake -10°", ALE_OWN, -10.0),
    ("ALE, own k, 200 m/min h 0.15 rake -7°", {**ALE_OWN, "speed": 200.0, "uncut": 0.15}, -7.0),
    ("ALE, own k, 300 m/min h 0.15 rake +5°", {**ALE_OWN, "speed": 300.0, "uncut": 0.15}, 5.0),
)
# fmt: on


def ale_table() -> int:
    """``--ale``: each of ``ALE_RUNS`` with Oxley's forces beside it, a Markdown table."""
    print("| run | F_c | F_t | chip ratio | eroded | Oxley F_c | Oxley F_t | Oxley ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for label, changes, rake in ALE_RUNS:
        cut = cutting.Cutting(**changes)
        model, state, record, frames, seconds = cutting.run(cut, rake, cutting.MU)
        run = cutting.summary(model, state, record, frames, seconds, rake, cutting.MU)
        theory = machining.oxley(speed=cut.speed, uncut=cut.uncut, rake=rake)
        print(
            f"| {label} | {run['cutting_force_N_per_mm']:.1f} | {run['thrust_force_N_per_mm']:.1f}"
            f" | {run['chip_thickness_ratio']:.2f} | {run['eroded_elements']} | "
            f"{theory.cutting_force:.1f} | {theory.thrust_force:.1f} | "
            f"{theory.chip_thickness_ratio:.2f} |",
            flush=True,
        )
    return 0


# -- the rake face term by term against Extended Oxley (--diagnostics) ----------------------

# Issue 60's conditions: (name, what differs from the default cut, the rake angle in degrees).
DIAGNOSED = (
    ("D", {}, 0.0),
    ("C", {"speed": 300.0, "uncut": 0.15}, 5.0),
    ("A", {"speed": 200.0, "uncut": 0.15}, -7.0),
)
DIAGNOSED_MODELS = (("Lagrangian", {}), ("ALE", {"ale": ALE_EVERY}))
BIN = 0.005  # mm: the rake-face profile's bins along the face
BINS = 160  # 0.8 mm of rake face
CONTACT_SHARE = 0.99  # the contact length holds this share of the rake face's normal force
LOGGED = 4  # elements an erosion log keeps per step (more going at once are counted)
# The tool's segments by kind (``tools.Tool(split_faces=True)``'s outline, each side's
# ring): the arc's, the flank's two, the back and top, the rake face's two.
ARC = np.arange(cutting.ARC_SEGMENTS)
FLANK_SEGMENTS = cutting.ARC_SEGMENTS + np.arange(2)
RAKE_SEGMENTS = cutting.TOOL_NODES - 2 + np.arange(2)


def rake_face(model, before, after, seen, rake: float):
    """One step's rake-face profile, thrust by part and erosions (``cutting.observe``'s probe,
    ``rake`` in degrees): fixed shapes, so that a run's thousands of steps fit in memory."""
    cut = model.cut
    dtype = seen.x.dtype
    gamma = math.radians(rake)
    up = jnp.asarray([math.sin(gamma), math.cos(gamma)], dtype)
    on_tool = -seen.force  # each node's push on the tool (N/mm)
    normal = seen.contact.normal
    tangent = jnp.stack([-normal[:, 1], normal[:, 0]], -1)
    pressure = -jnp.sum(on_tool * normal, -1)  # along the tool's outward normal, into it
    shear = jnp.abs(jnp.sum(on_tool * tangent, -1))
    segment = jnp.where(seen.contact.active, seen.contact.segment % cutting.TOOL_NODES, -1)
    on_rake = jnp.isin(segment, jnp.asarray(RAKE_SEGMENTS))
    on_arc = jnp.isin(segment, jnp.asarray(ARC))
    on_flank = jnp.isin(segment, jnp.asarray(FLANK_SEGMENTS))
    edge = jnp.stack([seen.lowest_x, jnp.asarray(cut.parting_y, dtype)])
    along = jnp.sum((seen.x - edge[None, :]) * up[None, :], -1)
    where = jnp.clip(jnp.floor(along / BIN).astype(jnp.int32), 0, BINS - 1)

    def binned(values):
        return jnp.zeros(BINS, dtype).at[where].add(jnp.where(on_rake, values, 0))

    def thrust(part, values=on_tool[:, 1]):
        return jnp.sum(jnp.where(part, values, 0))

    # Erosion: the elements this step took out, at their state before it.
    gone = before.alive & ~after.alive
    (which,) = jnp.nonzero(gone, size=LOGGED, fill_value=-1)
    at = jnp.maximum(which, 0)
    points = before.body.points
    centre = before.body.x[model.mesh.quads.quads[at]].mean(1)
    return {
        "step": before.step,
        "normal": binned(pressure),
        "shear": binned(shear),
        "pressed": binned(jnp.ones_like(pressure)),
        "capped": binned(seen.at_cap.astype(dtype)),
        "thrust": jnp.stack(
            [
                thrust(on_rake, jnp.sum(on_tool * tangent, -1) * tangent[:, 1]),
                thrust(on_rake, -pressure * normal[:, 1]),
                thrust(on_arc),
                thrust(on_flank),
                thrust(~(on_rake | on_arc | on_flank)),
            ]
        ),
        "rezoned": seen.rezoned,
        "eroded": gone.sum(),
        "element": which,
        "strain": points.plastic_strain.mean(1)[at],
        "celsius": points.temperature.mean(1)[at] - 273.15,
        "distortion": seen.distortion[at],
        "ahead": seen.lowest_x - centre[:, 0],
        "above": centre[:, 1] - cut.parting_y,
    }


def diagnose(name: str, changes: dict, rake: float, chunks: int = 20) -> dict:
    """One cut observed step by step: the rake-face measures over the last 40 % of its
    steps (``cutting.observe`` with ``rake_face``), the erosion log over the whole run."""
    cut = cutting.Cutting(**changes)
    model, state = cutting.setup(cut)
    total = cut.steps
    window = total - round(cutting.LAST * total)
    per = cutting.chunk_steps(cut, math.ceil(total / chunks))
    dtype = jnp.dtype(cut.dtype)
    probe = functools.partial(rake_face, rake=rake)
    sums, steps, forces, rezones, log = {}, 0, [], [], []
    started = time.perf_counter()
    for _ in range(0, total, per):
        state, record, seen = cutting.observe(
            model, state, jnp.asarray(math.radians(rake), dtype), jnp.asarray(cutting.MU, dtype),
            per, probe, until=total,
        )  # fmt: skip
        seen = jax.device_get(seen)
        at = np.asarray(seen["step"])
        real = at < total
        kept = real & (at >= window)
        forces.append(np.asarray(record.force)[kept])
        for key in ("normal", "shear", "pressed", "capped", "thrust"):
            sums[key] = sums.get(key, 0) + np.asarray(seen[key], np.float64)[kept].sum(0)
        steps += int(kept.sum())
        moved = np.asarray(seen["rezoned"])[kept]
        rezones.extend(moved[np.isfinite(moved)].tolist())
        for row in np.flatnonzero(real & (np.asarray(seen["eroded"]) > 0)):
            for k in range(min(LOGGED, int(seen["eroded"][row]))):
                log.append(
                    {
                        "element": int(seen["element"][row, k]),
                        "step": int(at[row]),
                        "travel_mm": round(float(cutting.tool_travel(cut, at[row])), 3),
                        "plastic_strain": round(float(seen["strain"][row, k]), 2),
                        "temperature_C": round(float(seen["celsius"][row, k])),
                        "ahead_um": round(1000 * float(seen["ahead"][row, k])),
                        "above_um": round(1000 * float(seen["above"][row, k])),
                        "trigger": f"det J ratio {float(seen['distortion'][row, k]):.3g} "
                        f"< {cut.erode}",
                    }
                )
    mean = {key: value / steps for key, value in sums.items()}
    cumulative = np.cumsum(mean["normal"])
    reach = int(np.searchsorted(cumulative, CONTACT_SHARE * cumulative[-1])) + 1
    length = reach * BIN
    theory = machining.oxley(speed=cut.speed, uncut=cut.uncut, rake=rake)
    force = np.concatenate(forces).mean(0)
    split = mean["thrust"]
    return {
        "condition": name,
        "model": "ALE" if cut.ale is not None else "Lagrangian",
        "cutting_force": float(force[0]),
        "thrust_force": float(force[1]),
        "contact_length": length,
        "normal_stress": float(mean["normal"][:reach].sum() / length),
        "shear_stress": float(mean["shear"][:reach].sum() / length),
        "at_cap": float(sums["capped"].sum() / max(sums["pressed"].sum(), 1)),
        "thrust_split": [float(v) for v in split],
        "rezones_idle": (sum(m == 0 for m in rezones), len(rezones)) if cut.ale else None,
        "eroded": log,
        "oxley": theory,
        "seconds": time.perf_counter() - started,
    }


def diagnostics_table(names=None) -> int:
    """``--diagnostics [D C A]``: each condition's Lagrangian and ALE cut against Oxley."""
    rows = []
    print(
        "| condition | model | F_c | F_t | of F_t: rake friction / rake pressure / edge / "
        "flank / other | contact length (mm) | σ̄_N (MPa) | τ̄ (MPa) | node-steps at the cap "
        "| idle rezones | eroded |"
    )
    print("|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|")
    for name, changes, rake in DIAGNOSED:
        if names and name not in names:
            continue
        for label, extra in DIAGNOSED_MODELS:
            row = diagnose(name, {**changes, **extra}, rake)
            rows.append(row)
            split = " / ".join(f"{v:.1f}" for v in row["thrust_split"])
            idle = "–" if row["rezones_idle"] is None else "{}/{}".format(*row["rezones_idle"])
            print(
                f"| {name} | {label} | {row['cutting_force']:.1f} | {row['thrust_force']:.1f} | "
                f"{split} | {row['contact_length']:.3f} | {row['normal_stress']:,.0f} | "
                f"{row['shear_stress']:,.0f} | {row['at_cap']:.2f} | {idle} | "
                f"{len(row['eroded'])} |",
                flush=True,
            )
            print(f"  ({row['seconds']:.0f} s)", file=sys.stderr, flush=True)
        theory = rows[-1]["oxley"]
        print(
            f"| {name} | Oxley | {theory.cutting_force:.1f} | {theory.thrust_force:.1f} | | "
            f"h′ {theory.contact_length:.3f} | {theory.interface_normal_stress:,.0f} | "
            f"{theory.interface_shear_stress:,.0f} | | | |",
            flush=True,
        )
    for row in rows:
        for entry in row["eroded"]:
            print(f"erosion, {row['condition']} {row['model']}: {entry}")
    return 0


if __name__ == "__main__":
    if sys.argv[1:] == ["--ale"]:
        sys.exit(ale_table())
    if sys.argv[1:2] == ["--diagnostics"]:
        sys.exit(diagnostics_table(sys.argv[2:]))
    sys.exit(_run.suite("simulations", run, draw, __doc__.splitlines()[0]))
