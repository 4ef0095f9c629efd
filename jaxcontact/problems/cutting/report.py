"""What a cut measured: the steady window of its forces, the dips at the pair
releases, the chip's thickness, the deepest node in the tool, and ``summary``,
which sets it all beside Merchant's and Kienzle's analyses (``machining``).

All on the host, in NumPy (float64), from ``model.run``'s results.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from jaxcontact.problems.cutting import machining
from jaxcontact.problems.cutting.config import TOOL_NODES
from jaxcontact.problems.cutting.model import (
    Model,
    Record,
    State,
    held,
    tool_position,
    tool_surface,
    tool_travel,
    travel_at,
)
from jaxcontact.sim import materials

__all__ = [
    "Dips",
    "LAST",
    "SMALL_FLOOR",
    "STEADY_DRIFT",
    "Window",
    "chip_thickness",
    "deepest_in_tool",
    "release_dips",
    "steady_window",
    "summary",
]

# The steady state of the forces: a criterion defined here, not taken from a
# source. A window of the run's last steps is steady when the least-squares
# line through each force component (raw, every step) changes across the
# window by at most STEADY_DRIFT of that component's mean. A component whose
# mean is under SMALL_FLOOR of the mean resultant is judged against that
# floor instead (a thrust near 0 N/mm has no meaningful percentage).
STEADY_DRIFT = 0.05
SMALL_FLOOR = 0.1
# The shortest window, and the one the means fall back on when none is
# steady: the last 40 % of the steps (the convention of the summary's forces
# before the criterion, kept so that their meaning stays where no steady
# state shows).
LAST = 0.4


class Window(NamedTuple):
    """Where a run's forces are averaged, and how far they drift there (plain numbers)."""

    start: int  # the window's first row of the record (it runs to the last)
    steady: bool  # the criterion held from ``start`` on (False: the fallback, the last LAST)
    mean: np.ndarray  # f[2]  the mean force over the window (N/mm): cutting, thrust
    drift: np.ndarray  # f[2]  the line's change across the window, % of the judged mean


def _drift(travel: np.ndarray, force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mean (f[2]) and the least-squares line's change across the window
    in % of the judged mean (f[2]) of ``force`` (f[T, 2]) against ``travel`` (f[T])."""
    mean = force.mean(axis=0)
    s = travel - travel.mean()
    spread = float(np.sum(s * s))
    # No travel across the window (one row): no line, and no steady state.
    slope = (s @ (force - mean)) / spread if spread > 0 else np.full(2, np.nan)
    judged = np.maximum(np.abs(mean), SMALL_FLOOR * np.hypot(*mean))
    with np.errstate(divide="ignore", invalid="ignore"):
        drift = 100 * slope * (travel[-1] - travel[0]) / judged
    return mean, drift


def steady_window(
    travel, force, spacing: float, tolerance: float = STEADY_DRIFT, last: float = LAST
) -> Window:
    """The window the forces are averaged over: from the earliest start, on a
    grid of ``spacing`` mm of travel back from the start of the last ``last``
    of the rows, such that the window from it and every later start on the
    grid drifts by at most ``tolerance`` (``STEADY_DRIFT``); when even the
    last ``last`` drifts more, that window, not steady.

    ``travel`` (f[T], mm, not decreasing) and ``force`` (f[T, 2], N/mm) are
    a run's rows. ``spacing`` is the element's edge in a cut: a window then
    holds whole cycles of the dip each pair release causes (``release_dips``),
    which would otherwise tilt the line. Every window ends at the run's end:
    a steady state lasts once reached."""
    travel = np.asarray(travel, np.float64)
    force = np.asarray(force, np.float64)
    rows = len(force)
    if rows == 0 or force.shape != (rows, 2) or travel.shape != (rows,):
        raise ValueError(
            f"steady_window needs travel f[T] and force f[T, 2] with T >= 1; "
            f"got {travel.shape} and {force.shape}"
        )
    if not spacing > 0:
        raise ValueError(f"steady_window's spacing must be > 0 mm; got {spacing!r}")
    if not (tolerance > 0 and 0 < last <= 1):
        raise ValueError(
            f"steady_window needs tolerance > 0 and 0 < last <= 1; got {tolerance!r} and {last!r}"
        )
    shortest = rows - max(1, round(last * rows))
    starts = [shortest]
    while True:
        row = int(np.searchsorted(travel, travel[starts[-1]] - spacing, side="left"))
        if row >= starts[-1] or travel[starts[-1]] - spacing < travel[0]:
            break
        starts.append(row)
    found = None
    for start in starts:  # the shortest window first, then ever longer
        _, drift = _drift(travel[start:], force[start:])
        if not np.all(np.abs(drift) <= 100 * tolerance):
            break
        found = start
    start = shortest if found is None else found
    mean, drift = _drift(travel[start:], force[start:])
    return Window(start, found is not None, mean, drift)


class Dips(NamedTuple):
    """How the cutting force falls at the release of the parting line's pairs (node
    separation), one entry per release with a whole element's cycle of rows around it."""

    releases: np.ndarray  # i[R]  every row at which a pair (or more) was released
    lag: np.ndarray  # i[C]  rows from a release to F_c's lowest in the cycle around it
    depth: np.ndarray  # f[C]  that lowest below the cycle's mean F_c (N/mm)


def release_dips(record: Record, cycle: int) -> Dips:
    """The dips in F_c against the release steps of the tied pairs.

    ``cycle``: the rows one element's travel takes (the releases come once
    per element). For each release with a whole cycle around it (half before,
    half after), the row of F_c's lowest value in that cycle, counted from the
    release, and how far it lies below the cycle's mean. Were the dips not
    the releases' doing, the lags would spread over the cycle."""
    released = np.asarray(record.released)
    force = np.asarray(record.force, np.float64)[:, 0]
    releases = np.flatnonzero(np.diff(released) > 0) + 1
    half = max(1, cycle // 2)
    lag, depth = [], []
    for row in releases:
        if row - half < 0 or row + half > len(force):
            continue
        around = force[row - half : row + half]
        lowest = int(np.argmin(around))
        lag.append(lowest - half)
        depth.append(float(around.mean() - around[lowest]))
    return Dips(releases, np.asarray(lag, np.int64), np.asarray(depth, np.float64))


def _inside(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """bool[K]: points strictly inside a closed polygon (even-odd rule, on the host)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    px, py = points[:, None, 0], points[:, None, 1]
    crosses = (a[None, :, 1] > py) != (b[None, :, 1] > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = a[None, :, 0] + (py - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (
            b[None, :, 1] - a[None, :, 1]
        )
    return (crosses & (px < at)).sum(axis=1) % 2 == 1


def chip_thickness(model: Model, state: State) -> float:
    """The steady chip's thickness (mm): the median distance from its free
    surface's nodes to its underside (the released nodes of the parting line),
    for the material cut in the later half of the run, more than two uncut
    thicknesses behind the edge."""
    cut, mesh = model.cut, model.mesh
    x = np.asarray(state.body.x, np.float64)
    reference = np.asarray(mesh.quads.nodes, np.float64)
    kept = np.asarray(held(mesh, state.alive))
    front = float(tool_position(cut, model.start_x, state.step)) - cut.edge_radius
    underside = np.asarray(mesh.chip_line)[np.asarray(state.released)]
    underside = underside[kept[underside]]
    top = np.asarray(mesh.top)
    start = front + 2 * cut.uncut
    cut_at = reference[top, 0]
    steady = top[(cut_at > start) & (cut_at < start + 0.5 * cut.travel) & kept[top]]
    if len(steady) == 0 or len(underside) < 2:
        return float("nan")
    return float(np.median(_distance_to(x[steady], x[underside], closed=False)))


def _distance_to(points: np.ndarray, polygon: np.ndarray, closed: bool = True) -> np.ndarray:
    """f[K]: each point's distance to a polygon's boundary (a closed one, or an
    open polyline with ``closed=False``)."""
    if closed:
        a, b = polygon, np.roll(polygon, -1, axis=0)
    else:
        a, b = polygon[:-1], polygon[1:]
    p = points[:, None, :]
    t = np.sum((p - a) * (b - a), -1) / np.maximum(np.sum((b - a) ** 2, -1), 1e-30)
    closest = a + np.clip(t, 0, 1)[..., None] * (b - a)
    return np.linalg.norm(p - closest, axis=-1).min(axis=1)


def deepest_in_tool(model: Model, rake_deg: float, frames) -> float:
    """The deepest any workpiece node lies inside the tool (mm) over the
    frames, by point-in-polygon on the host: the check that owes nothing to
    the contact search. Each node is tested against the tool as its side
    meets it (``CHIP_SIDE``, ``BASE_SIDE``)."""
    cut, mesh = model.cut, model.mesh
    side = np.asarray(mesh.side)
    deepest = 0.0
    for frame in frames:
        surface = tool_surface(
            cut, tool_position(cut, model.start_x, frame.step), math.radians(rake_deg)
        )
        nodes = np.asarray(surface.nodes, np.float64)
        x = np.asarray(frame.x, np.float64)
        kept = np.asarray(held(mesh, jnp.asarray(frame.alive)))
        for label in (0, 1):
            # Side 0 (the uncut layer) meets body 1's outline, side 1 body 0's.
            outline = nodes[(1 - label) * TOOL_NODES : (2 - label) * TOOL_NODES]
            points = x[kept & (side == label)]
            inside = _inside(points, outline)
            if inside.any():
                deepest = max(deepest, float(_distance_to(points[inside], outline).max()))
    return deepest


def _steady_elements(model: Model, state: State) -> np.ndarray:
    """bool[E]: the uncut layer's live elements cut in the steady part of the
    run (the chip of the later half, more than two uncut thicknesses behind
    the edge)."""
    cut, mesh = model.cut, model.mesh
    reference = np.asarray(mesh.quads.nodes, np.float64)[np.asarray(mesh.quads.quads)]
    centre = reference.mean(axis=1)
    front = float(tool_position(cut, model.start_x, state.step)) - cut.edge_radius
    start = front + 2 * cut.uncut
    layer = centre[:, 1] > cut.parting_y
    window = (centre[:, 0] > start) & (centre[:, 0] < start + 0.5 * cut.travel)
    return layer & window & np.asarray(state.alive)


def _material_name(material: materials.JohnsonCook) -> str:
    if material == materials.AISI_1045:
        return "AISI 1045 (Johnson-Cook, Jaspers and Dautzenberg 2002)"
    fit = ", ".join(f"{name}={getattr(material, name):g}" for name in "ABnCm")
    return f"Johnson-Cook ({fit})"


def summary(model: Model, state: State, record: Record, frames, seconds: float, rake_deg, mu):
    """What the run measured, and the analyses set beside it (plain numbers;
    docs/simulation.md's "The demo's summary.json" lists every key).

    Forces are the means (N per mm of width) over ``steady_window``'s
    window: from where the forces are steady to the end, or, when they are
    not steady in the run, the last 40 % of the steps, with the drift there
    (``forces_steady``, ``force_window_mm``, ``*_drift_percent``); the
    dips of F_c at the pair releases, by ``release_dips``. The chip's
    thickness, strain and temperature are those of the steady chip
    (``_steady_elements``); Merchant's shear stress is the Johnson–Cook flow
    stress over sqrt 3 at the steady chip's median plastic strain and
    temperature and the 90th percentile of the uncut layer's plastic strain
    rate over the last frame (the primary shear zone's).
    """
    cut = model.cut
    rows = len(record.force)
    # Row k of the record is the step from k to k + 1.
    travel = tool_travel(cut, np.arange(1, rows + 1))
    window = steady_window(travel, record.force, cut.element)
    cutting_force, thrust = (float(v) for v in window.mean)
    cycle = cut.element_steps
    dips = release_dips(record, cycle)
    # A dip is the release's when F_c's lowest in the cycle comes within a
    # tenth of the cycle after it.
    after = (dips.lag >= 0) & (dips.lag <= cycle // 10)
    thickness = chip_thickness(model, state)
    ratio = cut.uncut / thickness
    phi = machining.shear_angle_from_chip(ratio, rake_deg)
    beta = machining.friction_angle_from_forces(cutting_force, thrust, rake_deg)
    steady = _steady_elements(model, state)
    strain = np.asarray(state.body.points.plastic_strain, np.float64)[steady]
    temperature = np.asarray(state.body.points.temperature, np.float64)[steady]
    last, before = frames[-1], frames[-2]
    elapsed = (last.step - before.step) * cut.dt
    rates = (last.plastic_strain - before.plastic_strain).mean(axis=1) / elapsed
    layer = np.asarray(model.mesh.quads.nodes)[np.asarray(model.mesh.quads.quads)].mean(1)[:, 1]
    flowing = rates[(layer > cut.parting_y) & last.alive & (rates > 0)]
    rate = float(np.percentile(flowing, 90)) if flowing.size else 1.0
    eps, hot = float(np.median(strain)), float(np.median(temperature))
    flow = float(cut.work_material.flow_stress(eps, rate, hot))
    tau = flow / math.sqrt(3)
    merchant_fc, merchant_ft = machining.merchant_forces(tau, cut.uncut, 1.0, rake_deg, beta)
    depth = max(
        float(np.max(record.tool_depth)),
        float(np.max(record.own_depth)),
        deepest_in_tool(model, rake_deg, frames),
    )
    k_c11, m_c = machining.KIENZLE_CK45
    landed = np.flatnonzero(np.asarray(record.landed) > 0)
    lands_at = travel_at(model, int(landed[0])) if landed.size else None
    return {
        "material": _material_name(cut.work_material),
        "cutting_speed_m_per_min": cut.speed,
        "uncut_chip_thickness_mm": cut.uncut,
        "rake_deg": float(rake_deg),
        "friction": float(mu),
        "friction_shear_factor": cut.shear_factor,
        "cutting_force_N_per_mm": cutting_force,
        "thrust_force_N_per_mm": thrust,
        "forces_steady": window.steady,
        "force_window_mm": [float(travel[window.start]), float(travel[-1])],
        "cutting_force_drift_percent": float(window.drift[0]),
        "thrust_force_drift_percent": float(window.drift[1]),
        "pair_releases": int(len(dips.releases)),
        "release_dip_cycles": int(len(dips.lag)),
        "release_dips_after_release": int(np.sum(after)),
        "release_dip_lag_steps": float(np.median(dips.lag)) if len(after) else float("nan"),
        "release_dip_N_per_mm": float(np.median(dips.depth)) if len(after) else float("nan"),
        "chip_thickness_mm": thickness,
        "chip_thickness_ratio": thickness / cut.uncut,
        "shear_angle_deg": phi,
        "friction_angle_deg": beta,
        "max_penetration_over_element": depth / cut.element,
        "nodes": int(model.mesh.quads.nodes.shape[0]),
        "elements": int(model.mesh.quads.quads.shape[0]),
        "eroded_elements": int(np.sum(~np.asarray(state.alive))),
        # The travel (mm) at which the chip first touched the workpiece or
        # itself away from the edge (None: it did not), and how many nodes at most.
        "chip_lands_at_travel_mm": lands_at,
        "chip_landing_contacts_max": int(np.max(record.landed, initial=0)),
        "steps": int(state.step),
        "time_step_s": cut.dt,
        "mass_scaling": cut.mass_scaling,
        "steps_per_second": int(state.step) / seconds,
        "chip_plastic_strain": eps,
        "chip_temperature_C": hot - 273.15,
        "shear_zone_strain_rate_per_s": rate,
        "merchant_shear_stress_MPa": tau,
        "merchant_shear_angle_deg": machining.merchant_shear_angle(rake_deg, beta),
        "merchant_cutting_force_N_per_mm": merchant_fc,
        "merchant_thrust_force_N_per_mm": merchant_ft,
        "kienzle_cutting_force_N_per_mm": machining.kienzle_force(cut.uncut),
        "kienzle_band_N_per_mm": [
            machining.kienzle_force(cut.uncut, constants=(1500.0, m_c)),
            machining.kienzle_force(cut.uncut, constants=(k_c11, m_c)),
        ],
        "overflow": bool(np.any(record.overflow)),
    }
