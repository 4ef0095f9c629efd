"""``jaxcontact demo --scene ploughing``: the ploughing simulation run, timed and drawn.

Runs ``ploughing.simulate`` once for its results (growing the search sizes
on overflow), then times it: the whole scan, and the same scan with
detection replaced by a fixed contact result (``scan(..., detect=False)``:
the same elastic update, the same force assembly, no ``Search.closest``),
the two in alternation. The detection share is the median
over those pairs of ``1 - without / with``: what detection adds to a step,
measured in the compiled loop where it runs.
The numbers are printed; the PNGs are drawn only when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import NamedTuple

import jax
import numpy as np

from jaxcontact import all_to_all
from jaxcontact._timing import Timing, pinned_note
from jaxcontact.problems.ploughing.config import Ploughing
from jaxcontact.problems.ploughing.model import History, scan, setup, simulate, tool_surface
from jaxcontact.sim.elements.triangle import stresses, von_mises

__all__ = ["Summary", "TRAVEL", "add_arguments", "main", "run_demo"]


class Summary(NamedTuple):
    """What the demo measured (all plain Python numbers)."""

    nodes: int
    steps: int
    steps_per_s: float  # the full run, median of the timed repeats
    detection_share: float  # 1 - time without detection / time with it
    rebuilds: int  # candidate lists found again over the run
    most_active: int  # most active slaves at one step
    penetration_ratio: float  # deepest penetration / grid spacing
    mean_force: tuple[float, float]  # mean cutting and thrust force (N per mm)
    first_s: float  # compilation and the first run


def _at_least(least: int, kind):
    def parse(text: str):
        value = kind(text)
        if not value >= least:
            raise argparse.ArgumentTypeError(f"must be at least {least}; got {value}")
        return value

    return parse


TRAVEL = 0.5  # mm, the default tool travel


def add_arguments(parser: argparse.ArgumentParser, travel: bool = True) -> None:
    """The simulation demo's options, on the ``demo`` subcommand.

    ``travel``: also ``--travel``, which ``jaxcontact demo`` owns itself (the
    cutting scene takes it too, with another default).
    """
    parser.add_argument(
        "--nodes",
        type=_at_least(4, int),
        default=10_000,
        help="workpiece nodes, about (default 10,000)",
    )
    if travel:
        parser.add_argument(
            "--travel", type=float, default=TRAVEL, help=f"tool travel in mm (default {TRAVEL:g})"
        )
    parser.add_argument(
        "--repeats",
        type=_at_least(1, int),
        default=5,
        help="timed runs of the whole scan (default 5)",
    )


def run_demo(
    nodes: int, travel: float, repeats: int, dtype, slaves: str = "surface"
) -> tuple[Summary, tuple]:
    """Sets up, runs and times the simulation; returns the summary and what to draw.

    What to draw: ``(mesh, controls, plan, final, history, with_detection,
    without)``, the last two the ``Timing`` s of the whole scan.
    """
    config = Ploughing(nodes, travel=travel, slaves=slaves, dtype=np.dtype(dtype).name)
    mesh, controls, plan = setup(config)
    start = time.perf_counter()
    final, history, plan = simulate(mesh, controls, plan)
    first_s = time.perf_counter() - start  # compilation and one run

    # ``scan`` is jitted with ``plan`` static: the first call reuses the
    # executable ``simulate`` compiled (called the same way: jit's cache tells
    # an omitted keyword from a passed one).
    calls = (
        lambda: scan(mesh, controls, plan),
        lambda: scan(mesh, controls, plan, detect=False),
    )
    with_detection, without, share = _paired_timings(calls, repeats)
    history = jax.tree.map(np.asarray, history)
    summary = Summary(
        nodes=int(mesh.nodes.shape[0]),
        steps=plan.steps,
        steps_per_s=plan.steps / with_detection.median_s,
        detection_share=share,
        rebuilds=int(final.rebuilds),
        most_active=int(history.active.max()),
        penetration_ratio=float(history.penetration.max()) / plan.search.radius,
        mean_force=tuple(float(f) for f in history.force.mean(axis=0)),
        first_s=first_s,
    )
    return summary, (mesh, controls, plan, final, history, with_detection, without)


def _paired_timings(calls, repeats: int) -> tuple[Timing, Timing, float]:
    """Times the two scans in alternation, ``repeats`` pairs after a warm-up pair.

    Alternating keeps a change of machine load from falling on one of them
    only. Returns their ``Timing`` s (``compile_s``: the warm-up call) and the
    detection share, the median over pairs of ``1 - without / with``.
    """
    warmup = [_elapsed(call) for call in calls]
    runs = np.array([[_elapsed(call) for call in calls] for _ in range(max(1, repeats))])
    timings = []
    for column, first in zip(runs.T, warmup, strict=True):
        p10, median, p90 = np.percentile(column, [10, 50, 90])
        timings.append(Timing(first, float(median), float(p10), float(p90), len(column)))
    share = float(np.median(1 - runs[:, 1] / runs[:, 0]))
    return timings[0], timings[1], share


def _elapsed(call) -> float:
    start = time.perf_counter()
    jax.block_until_ready(call())
    return time.perf_counter() - start


def main(args: argparse.Namespace) -> int:
    """The ``demo`` subcommand for the simulation."""
    dtype = np.dtype(args.dtype)
    if dtype == np.float64:
        jax.config.update("jax_enable_x64", True)
    travel = TRAVEL if args.travel is None else args.travel
    summary, drawn = run_demo(args.nodes, travel, args.repeats, dtype)
    mesh, controls, plan, final, history, timed, untimed = drawn
    material = plan.material
    print(
        f"ploughing: {summary.nodes:,} nodes, {mesh.triangles.shape[0]:,} triangles, "
        f"{plan.sizes['closest'].num_slaves:,} slaves; steel E={material.young:g} MPa, "
        f"nu={material.poisson:g}, rho={material.density:g} t/mm3 x {material.mass_scale:g} "
        f"(mass scaling); {args.dtype}"
    )
    print(
        f"tool at {plan.speed / 1e3:g} m/s, depth of cut 1 mm, travel {travel:g} mm: "
        f"{plan.steps} steps of dt={plan.dt:.3g} s; no material separation (the tool ploughs)"
    )
    print(f"jax {jax.__version__} on {jax.devices()[0].device_kind}; {pinned_note()}")
    print(
        f"  steps/s          {summary.steps_per_s:10,.0f}   (whole scan {timed.median_s:.3f} s, "
        f"median of {timed.runs}; compile and first run {summary.first_s:.1f} s)"
    )
    print(
        f"  detection share  {summary.detection_share:10.1%}   (scan without detection: "
        f"{untimed.median_s:.3f} s)"
    )
    print(
        f"  list rebuilds    {summary.rebuilds:10d}   "
        f"(of {plan.steps} steps; skin {plan.search.skin:.3g} mm)"
    )
    print(f"  most active      {summary.most_active:10d}   slaves in contact at one step")
    print(f"  penetration      {summary.penetration_ratio:10.1%}   of the grid spacing, at most")
    print(
        f"  mean force       cutting {summary.mean_force[0]:,.0f} N/mm, "
        f"thrust {summary.mean_force[1]:,.0f} N/mm (per mm of width)"
    )
    try:
        import matplotlib
    except ImportError:
        print('PNGs skipped: matplotlib is not installed (pip install "jaxcontact[bench]").')
        return 0
    matplotlib.use("Agg")
    os.makedirs(args.out, exist_ok=True)
    for path in _draw(mesh, controls, plan, final, history, args.out):
        print(f"wrote {path}")
    return 0


def _draw(mesh, controls, plan, final, history: History, folder: str) -> list[str]:
    """The deformed mesh by von Mises stress with the contact nodes; the force-travel curves."""
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    x = np.asarray(mesh.nodes + final.displacement)
    sigma = stresses(mesh, final.displacement, plan.material)
    stress = np.asarray(von_mises(sigma, plan.material))
    surface = tool_surface(float(history.x_tip[-1]), controls.rake)
    rows = np.arange(len(x)) if plan.all_slaves else np.asarray(mesh.boundary)
    contact = all_to_all(x[rows], surface, radius=plan.search.radius)
    active, found = np.asarray(contact.active), np.asarray(contact.found)
    tool = np.asarray(surface.nodes)
    mesh_path = os.path.join(folder, "ploughing_mesh.png")
    figure, panels = plt.subplots(2, 1, figsize=(10, 9), dpi=150, layout="constrained")
    triangulation = Triangulation(*x.T, np.asarray(mesh.triangles))
    tip_x = float(history.x_tip[-1])
    windows = (((-0.5, 23.5), (-0.5, 7.5)), ((tip_x - 1.5, tip_x + 1.5), (3.2, 5.6)))
    for axes, (xlim, ylim) in zip(panels, windows, strict=True):
        shaded = axes.tripcolor(triangulation, facecolors=stress, cmap="viridis", rasterized=True)
        axes.fill(*tool.T, fc="0.75", ec="black", lw=0.8, zorder=3)
        slaves = x[rows]
        axes.scatter(*slaves[found & ~active].T, s=8, c="tab:blue", zorder=4, label="found, g ≥ 0")
        axes.scatter(*slaves[active].T, s=10, c="tab:red", zorder=4, label="active (gap < 0)")
        axes.set(xlim=xlim, ylim=ylim, aspect="equal", xlabel="x (mm)", ylabel="y (mm)")
    panels[1].triplot(triangulation, lw=0.2, c="white", alpha=0.5)
    panels[1].legend(loc="upper left", fontsize=8)
    figure.colorbar(shaded, ax=panels, label="von Mises stress (MPa)", shrink=0.8)
    figure.suptitle(
        f"Tool ploughing elastic steel: {len(x):,} nodes after {plan.steps} steps "
        f"(travel {plan.x_tip_start - tip_x:.2f} mm; no separation); below: near the tool"
    )
    figure.savefig(mesh_path)
    plt.close(figure)

    force_path = os.path.join(folder, "ploughing_forces.png")
    figure, axes = plt.subplots(figsize=(8, 4.5), dpi=150, layout="constrained")
    travel = plan.x_tip_start - history.x_tip
    axes.plot(travel, history.force[:, 0], label="cutting force (x, opposing the motion)")
    axes.plot(travel, history.force[:, 1], label="thrust force (y)")
    axes.set(xlabel="tool travel (mm)", ylabel="force on the tool (N per mm of width)")
    axes.legend()
    axes.set_title("Contact force on the tool (sum of the penalty forces)")
    figure.savefig(force_path)
    plt.close(figure)
    return [mesh_path, force_path]
