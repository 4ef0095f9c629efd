"""``jaxcontact demo --scene hertz``: the indentation solved, set against Hertz and drawn.

Solves at ``--across`` elements across the contact (twice: the second time
compiled), prints the FE a and p0 against Hertz's, and draws the pressure
profile into ``OUT/hertz_pressure_<across>.png`` when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np

from jaxcontact._timing import pinned_note
from jaxcontact.problems._output import write_png
from jaxcontact.problems.hertz.config import Indentation
from jaxcontact.problems.hertz.model import Solver, run

__all__ = ["ACROSS", "draw", "main"]

ACROSS = 24  # the demo's mesh: elements across the contact width 2a


def main(args: argparse.Namespace) -> int:
    """Solves the indentation at ``--across`` elements across the contact, prints the FE
    a and p0 against Hertz's, and draws the pressure profile."""
    jax.config.update("jax_enable_x64", True)  # the scene needs float64 (model.run says why)
    problem = Indentation()
    started = time.perf_counter()
    result = run(problem, args.across)
    first_s = time.perf_counter() - started
    started = time.perf_counter()
    run(problem, args.across)  # compiled: the solve alone
    solve_s = time.perf_counter() - started
    exact = result.exact
    print(
        f"hertz: rigid cylinder R={problem.radius:g} mm pressed with P={problem.force:g} N/mm "
        f"into a block E={problem.young:g} MPa, nu={problem.poisson:g} (plane strain, "
        "frictionless, float64)"
    )
    print(
        f"block 20a x 10a, bottom fixed, sides free: {result.nodes:,} nodes, "
        f"{result.across} elements across 2a (h = {result.element:.4g} mm = "
        f"{result.element / exact.half_width:.3g} a); penalty "
        f"{Solver().penalty:g} E*/h"
    )
    print(f"jax {jax.__version__} on {jax.devices()[0].device_kind}; {pinned_note()}")
    print("                 FE          Hertz       error")
    print(
        f"  a (mm)        {result.half_width:<11.5g} {exact.half_width:<11.5g} "
        f"{100 * result.half_width_error:+.2f} %"
    )
    print(
        f"  p0 (MPa)      {result.peak:<11.5g} {exact.peak:<11.5g} {100 * result.peak_error:+.2f} %"
    )
    print(f"  p(x), relative L2 error over the contact: {100 * result.l2_error:.2f} %")
    print(
        f"  {result.active} nodes pressed; deepest penetration "
        f"{result.penetration / exact.half_width:.2g} a; contact force {result.force:.6g} N/mm"
    )
    print(
        f"  Newton: {result.newton_steps} steps, force residual {result.residual:.2g} N/mm; "
        f"{first_s:.1f} s with compilation, {solve_s:.2f} s compiled"
    )
    write_png(args.out, f"hertz_pressure_{result.across}.png", lambda path: draw(result, path))
    return 0


def draw(result, path: str) -> None:
    """The FE nodal pressures over Hertz's p(x), and their difference, into ``path``."""
    import matplotlib.pyplot as plt

    exact = result.exact
    a, p0 = exact.half_width, exact.peak
    shown = np.abs(result.x) <= 1.5 * a
    x = result.x[shown] / a
    curve = np.linspace(-1.5, 1.5, 601)
    figure, (profile, difference) = plt.subplots(
        2, 1, figsize=(8, 7), dpi=150, sharex=True, height_ratios=(3, 1.3), layout="constrained"
    )
    profile.plot(curve, exact.pressure(curve * a) / p0, c="black", lw=1.2, label="Hertz p(x)")
    profile.plot(x, result.pressure[shown] / p0, "o", c="tab:blue", ms=4, label="FE nodal pressure")
    profile.set(ylabel="p / p0 (Hertz's)", ylim=(0, 1.15))
    profile.legend(loc="upper right", fontsize=8)
    profile.set_title(
        f"{result.across} elements across 2a: a {100 * result.half_width_error:+.2f} %, "
        f"p0 {100 * result.peak_error:+.2f} %, L2 {100 * result.l2_error:.2f} %",
        fontsize=10,
    )
    error = (result.pressure[shown] - exact.pressure(result.x[shown])) / p0
    difference.axhline(0, c="black", lw=0.8)
    difference.plot(x, error, "o-", c="tab:blue", ms=3, lw=0.8)
    difference.set(xlabel="x / a (Hertz's a)", ylabel="(FE - Hertz) / p0")
    problem = result.problem
    figure.suptitle(
        f"Rigid cylinder (R = {problem.radius:g} mm, P = {problem.force:g} N/mm) on an elastic "
        f"block (E = {problem.young:g} MPa, ν = {problem.poisson:g}):\n"
        "the contact pressure against Hertz's (Johnson 1985, §4.3), plane strain",
        fontsize=10,
    )
    figure.savefig(path)
    plt.close(figure)
