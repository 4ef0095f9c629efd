"""``jaxcontact demo`` (``--scene cutting``, the default): the orthogonal cut, run and drawn.

Runs ``cutting.run`` with a progress bar on stderr (whole lines when stderr is not a
terminal), prints the summary (``cutting.summary``) as a table and writes it to
``OUT/summary.json``. With matplotlib installed (the ``bench`` extra) it
also draws ``OUT/chip.png`` (the chip at the end, by plastic strain and by
temperature), ``OUT/forces.png`` (the forces against the travel, beside
Merchant's and Kienzle's) and ``OUT/chip.gif`` (the chip forming).

The report says what its numbers are: whether the forces reached a steady
state and over which window they are averaged (``cutting.steady_window``),
what the raw cutting force's dips are (the pair releases of node separation,
measured by ``cutting.release_dips``), and what Kienzle's band's edges are.
The run makes the steps the header announces, and the travel labels come
from ``cutting.tool_travel``. docs/simulation.md documents every key of
summary.json.

The pictures are drawn in the tool's frame: x from the cutting edge's lowest
point, y from the parting line (the depth of cut), both in mm.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import textwrap
import time
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact.problems import cutting
from jaxcontact.problems.cutting import machining

__all__ = [
    "CURL",
    "FRAMES",
    "RAKE_LIMIT",
    "TRAVEL",
    "add_arguments",
    "check",
    "demo_keys",
    "dips_note",
    "draw_chip",
    "draw_forces",
    "draw_gif",
    "element_size",
    "main",
    "make_cut",
    "positive",
    "print_table",
    "window_note",
]

_DEFAULT = cutting.Cutting()  # the default cut: the options' defaults are its numbers
TRAVEL = _DEFAULT.travel  # mm, the default tool travel
RAKE_LIMIT = 30.0  # degrees either way
# The picture's window around the tool (mm): left of the edge, right of it, below the line.
_LEFT, _RIGHT, _BELOW = 0.5, 0.2, 0.1
_STRAIN_MAX = 3.0  # the plastic strain colour scale's top
# The chip-breaker cut of ``--curl`` (the smallest breaker found, in a study of
# several, on which the chip curls and lands cleanly): a backwall (land, angle°, length, mm),
# 2 elements through h, the travel, and the uncut length left ahead (mm).
CURL = {
    "breaker": (0.25, 30.0, 0.5),
    "element": 0.05,
    "travel": 3.2,
    "ahead": 1.5,
    "edge_radius": 0.002,
}
FRAMES = 40  # the run in this many calls, a frame after each: the GIF's frames
_BAR = 30  # characters of the progress bar
_LINES = 10  # off a terminal, the progress as a whole line each tenth of the run
_EDGES = (0.15, 0.15, 0.15, 0.5)  # the elements' edges: dark grey, half transparent
_CAPTION = 165  # characters a line of the forces figure's caption (8 pt across 11 inches)


def _number(least: float = 0.0, most: float | None = None, strict: bool = True):
    """An argparse type: a finite float above ``least`` (or at least it), at most ``most``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"must be finite; got {text}")
        if strict and not value > least:
            raise argparse.ArgumentTypeError(f"must be more than {least:g}; got {value:g}")
        if not strict and not value >= least:
            raise argparse.ArgumentTypeError(f"must be at least {least:g}; got {value:g}")
        if most is not None and not value <= most:
            raise argparse.ArgumentTypeError(f"must be at most {most:g}; got {value:g}")
        return value

    return parse


positive = _number()  # an argparse type: a finite float above 0


def _whole(least: int):
    """An argparse type: an integer at least ``least``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
        if value < least:
            raise argparse.ArgumentTypeError(f"must be at least {least}; got {value}")
        return value

    return parse


_rake = _number(-RAKE_LIMIT, RAKE_LIMIT, strict=False)


def add_arguments(parser, shared: bool = True) -> None:
    """The cutting demo's options on ``parser`` (an ``ArgumentParser`` or a group).

    ``shared``: also ``--travel``, ``--out`` and ``--dtype``, which the
    ``jaxcontact demo`` command owns itself, as other scenes take them too.
    """
    parser.add_argument(
        "--speed",
        type=positive,
        default=_DEFAULT.speed,
        help=f"cutting speed in m/min (default {_DEFAULT.speed:g})",
    )
    parser.add_argument(
        "--uncut",
        type=positive,
        default=_DEFAULT.uncut,
        help=f"uncut chip thickness h in mm, a whole number of elements "
        f"(default {_DEFAULT.uncut:.2f})",
    )
    parser.add_argument(
        "--rake",
        type=_rake,
        default=0.0,
        help=f"rake angle in degrees, -{RAKE_LIMIT:g} to {RAKE_LIMIT:g} (default 0)",
    )
    parser.add_argument(
        "--mu",
        type=_number(0.0, strict=False),
        default=cutting.MU,
        help=f"Coulomb friction on the tool, 0 or more (default {cutting.MU:g})",
    )
    parser.add_argument(
        "--edge-radius",
        type=positive,
        default=None,
        help=f"the cutting edge's radius in mm (default {_DEFAULT.edge_radius:g}; "
        f"{CURL['edge_radius']:g} with --curl)",
    )
    parser.add_argument(
        "--element",
        type=positive,
        default=None,
        help=f"element edge in mm (default {_DEFAULT.element:g}; {CURL['element']:g} with --curl)",
    )
    parser.add_argument(
        "--fine", action="store_true", help="halve the element edge (about 8x longer)"
    )
    parser.add_argument(
        "--mass-scaling",
        type=positive,
        default=_DEFAULT.mass_scaling,
        help=f"the density's factor (default {_DEFAULT.mass_scaling:g}; 1: none)",
    )
    parser.add_argument(
        "--frames",
        type=_whole(2),
        default=FRAMES,
        help=f"run the cut in this many chunks, a frame after each: chip.gif's "
        f"({FRAMES + 1} of them at most; default {FRAMES})",
    )
    parser.add_argument(
        "--curl",
        action="store_true",
        help=f"the chip-breaker cut: a backwall {CURL['breaker'][0]:g} mm up the rake face, "
        f"turned {CURL['breaker'][1]:g}° towards the chip, curls the chip onto the workpiece "
        f"ahead; elements {CURL['element']:g} mm and travel {CURL['travel']:g} mm unless "
        "given (about 4 min on 2 cores)",
    )
    parser.add_argument("--no-pictures", action="store_true", help="write summary.json only")
    parser.add_argument("--no-gif", action="store_true", help="leave out chip.gif")
    if shared:
        parser.add_argument(
            "--travel",
            type=positive,
            default=None,
            help=f"tool travel in mm (default {TRAVEL:g}; {CURL['travel']:g} with --curl)",
        )
        parser.add_argument("--out", default="jaxcontact-demo", help="folder for the files")
        parser.add_argument(
            "--dtype",
            choices=("float32", "float64"),
            default=_DEFAULT.dtype,
            help=f"default {_DEFAULT.dtype}",
        )


def element_size(args: argparse.Namespace) -> float:
    """The element edge the options ask for (mm)."""
    element = args.element
    if element is None:
        element = CURL["element"] if getattr(args, "curl", False) else _DEFAULT.element
    return element / 2 if args.fine else element


def check(args: argparse.Namespace) -> str | None:
    """What is wrong with the options together (``None``: nothing), for ``parser.error``."""
    element = element_size(args)
    rows = args.uncut / element
    if round(rows) < 1 or abs(rows - round(rows)) > 1e-6 * max(1.0, rows):
        return (
            f"--uncut {args.uncut:g} mm must be a whole number of elements of "
            f"{element:g} mm (--element{', halved by --fine' if args.fine else ''})"
        )
    return None


def make_cut(args: argparse.Namespace) -> cutting.Cutting:
    """The ``cutting.Cutting`` the options describe."""
    curl = getattr(args, "curl", False)
    travel = getattr(args, "travel", None)
    if travel is None:
        travel = CURL["travel"] if curl else TRAVEL
    edge_radius = args.edge_radius
    if edge_radius is None:
        edge_radius = CURL["edge_radius"] if curl else _DEFAULT.edge_radius
    return cutting.Cutting(
        speed=args.speed,
        uncut=args.uncut,
        travel=travel,
        element=element_size(args),
        edge_radius=edge_radius,
        mass_scaling=args.mass_scaling,
        breaker=CURL["breaker"] if curl else None,
        ahead=CURL["ahead"] if curl else None,
        dtype=getattr(args, "dtype", _DEFAULT.dtype),
    )


class _Progress:
    """A text progress bar on stderr: on a terminal redrawn in place (``\\r``); off one (a
    log file, a pipe) written as whole lines, one each tenth of the run, since a log would
    keep every redraw on one long line."""

    def __init__(self, stream=None):
        self.stream = sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", None)
        self.in_place = bool(isatty is not None and isatty())
        self.tenths = -1  # off a terminal: the last tenth of the run written
        self.started = time.perf_counter()
        self.calls: list[tuple[int, float]] = []  # (steps done, when)

    def __call__(self, done: int, total: int) -> None:
        now = time.perf_counter()
        if done > 0:
            self.calls.append((done, now))
        share = min(1.0, done / total) if total else 1.0
        filled = round(share * _BAR)
        elapsed = now - self.started
        note = "  (compiling)" if done == 0 else ""
        line = (
            f"[{'#' * filled}{'.' * (_BAR - filled)}] {share:4.0%}  "
            f"{done}/{total} steps  {elapsed:.0f} s{note}"
        )
        if self.in_place:
            self.stream.write(f"\r{line}   ")
            if done >= total:
                self.stream.write("\n")
        else:
            # Integer tenths: a share such as 0.7 must not round below its tenth.
            tenths = _LINES * min(done, total) // total if total else _LINES
            if tenths <= self.tenths:
                return
            self.tenths = tenths
            self.stream.write(line + "\n")
        self.stream.flush()

    def rate(self) -> float:
        """Steps per second after the first chunk (which compiles): NaN with one chunk."""
        if len(self.calls) < 2:
            return float("nan")
        (first, since), (last, until) = self.calls[0], self.calls[-1]
        return (last - first) / (until - since)


def _plain(value):
    """``value`` for JSON: NaN and infinities become ``None`` (null)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _shown(value) -> str:
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.4g}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_shown(v) for v in value) + "]"
    return str(value)


def print_table(summary: dict, stream=None) -> None:
    """The summary, one ``key  value`` a line, the values aligned."""
    stream = sys.stdout if stream is None else stream
    width = max(len(key) for key in summary)
    for key, value in summary.items():
        print(f"  {key:<{width}}  {_shown(value)}", file=stream)


def _conditions(cut: cutting.Cutting, rake_deg: float, mu: float) -> str:
    return f"v = {cut.speed:g} m/min, h = {cut.uncut:g} mm, rake {rake_deg:g}°, μ = {mu:g}"


def demo_keys(cut: cutting.Cutting, rate: float, seconds: float) -> dict:
    """What summary.json holds beyond ``cutting.summary``: the run's steps per second
    after the first chunk (``rate``), the cut's travel
    (mm, as asked; the run's last step reaches it to within a step's motion), element
    (mm) and dtype, and the run's seconds."""
    return {
        "steps_per_second_after_compile": rate,
        "travel_mm": cut.travel,
        "element_mm": cut.element,
        "dtype": cut.dtype,
        "run_seconds": seconds,
    }


def main(args: argparse.Namespace) -> int:
    """The ``demo`` subcommand for the cutting simulation; returns the exit status."""
    problem = check(args)
    if problem is not None:
        print(f"jaxcontact demo: error: {problem}", file=sys.stderr)
        return 2
    cut = make_cut(args)
    if cut.dtype == "float64":
        jax.config.update("jax_enable_x64", True)
    # cutting.run makes exactly cut.steps steps (the last chunk's extra steps
    # dropped), after which the tool has moved cut.travel to within one step.
    print(
        f"cutting AISI 1045: {_conditions(cut, args.rake, args.mu)}, travel {cut.travel:g} mm, "
        f"elements {cut.element:g} mm, mass scaling {cut.mass_scaling:g}, {cut.dtype}: "
        f"{cut.steps:,} steps of dt = {cut.dt:.3g} s"
    )
    print(f"jax {jax.__version__} on {jax.devices()[0].device_kind}", flush=True)
    progress = _Progress()
    progress(0, cut.steps)
    model, state, record, frames, seconds = cutting.run(
        cut, args.rake, args.mu, chunks=args.frames, progress=progress
    )
    with warnings.catch_warnings():
        # A cut too short for a steady chip measures none: NaN, and NumPy's
        # warnings about the empty means behind it.
        warnings.simplefilter("ignore", RuntimeWarning)
        summary = cutting.summary(model, state, record, frames, seconds, args.rake, args.mu)
    summary.update(demo_keys(cut, progress.rate(), seconds))
    print_table(summary)
    print(f"  forces: {window_note(summary)}")
    print(f"  {dips_note(summary, cut.element, cut.element_steps)}")
    if not math.isfinite(summary["chip_thickness_mm"]):
        print(
            "  (no steady chip: the cut is too short to measure one; "
            "chip, shear angle and Merchant's forces are nan)"
        )
    if summary["chip_lands_at_travel_mm"] is not None:
        print(f"  the chip landed on the workpiece at {summary['chip_lands_at_travel_mm']:.2f} mm")
    elif cut.breaker is None:
        print(
            "  (the chip did not curl back onto the workpiece: on a plain rake face it "
            "climbs straight; --curl puts a chip breaker on the tool)"
        )
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "summary.json")
    with open(path, "w") as file:
        json.dump({key: _plain(value) for key, value in summary.items()}, file, indent=2)
        file.write("\n")
    print(f"wrote {path}")
    if args.no_pictures:
        return 0
    try:
        import matplotlib
    except ImportError:
        print('pictures skipped: matplotlib is not installed (pip install "jaxcontact[bench]").')
        return 0
    matplotlib.use("Agg")  # headless: no display needed
    drawn = [
        draw_chip(model, frames[-1], args.rake, args.mu, os.path.join(args.out, "chip.png")),
        draw_forces(model, record, summary, os.path.join(args.out, "forces.png")),
    ]
    if not args.no_gif:
        drawn.append(
            draw_gif(model, frames, args.rake, args.mu, os.path.join(args.out, "chip.gif"))
        )
    for path in drawn:
        print(f"wrote {path} ({os.path.getsize(path) / 1e3:,.0f} kB)")
    return 0


# -- pictures ----------------------------------------------------------------


def _origin(model, step: int) -> np.ndarray:
    """The tool frame's origin at ``step``: the edge's lowest point's x, the parting line's y."""
    x = float(cutting.tool_position(model.cut, model.start_x, step))
    return np.array([x, model.cut.parting_y])


def _tool(model, step: int, rake_deg: float) -> np.ndarray:
    """f[K, 2]: the tool's outline at ``step``, in the tool frame."""
    cut = model.cut
    origin = _origin(model, step)
    lowest = jnp.asarray([origin[0], cut.parting_y - cut.edge_radius], jnp.dtype(cut.dtype))
    outline = cutting.tool_outline(
        lowest, math.radians(rake_deg), cut.edge_radius, cut.dtype, cut.rake_face, cut.breaker
    )
    return np.asarray(outline, np.float64) - origin


def _elements(model, frame) -> tuple[np.ndarray, np.ndarray]:
    """The live elements' corners in the tool frame (f[E', 4, 2]) and their indices."""
    alive = np.flatnonzero(frame.alive)
    quads = np.asarray(model.mesh.quads.quads)[alive]
    corners = np.asarray(frame.x, np.float64)[quads] - _origin(model, frame.step)
    return corners, alive


def _left(model) -> float:
    """How far the picture reaches left of the edge (mm): farther for a chip
    breaker's cut, whose chip curls over the uncut workpiece ahead."""
    return 1.6 if model.cut.breaker is not None else _LEFT


def _top(corners: np.ndarray, left: float) -> float:
    """The highest point of the elements inside the window's width (mm, tool frame)."""
    x, y = corners[..., 0], corners[..., 1]
    inside = (x > -left) & (x < _RIGHT)
    return float(y[inside].max()) if inside.any() else 0.0


def _window(axes, top: float, left: float) -> None:
    axes.set(
        xlim=(-left, _RIGHT),
        ylim=(-_BELOW, top),
        aspect="equal",
        xlabel="x from the cutting edge (mm)",
        ylabel="y from the parting line (mm)",
    )


def draw_chip(model, frame, rake_deg: float, mu: float, path: str) -> str:
    """The chip at ``frame``: elements by plastic strain (left) and temperature (right)."""
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    cut = model.cut
    corners, alive = _elements(model, frame)
    left = _left(model)
    top = _top(corners, left) + 0.05
    tool = _tool(model, frame.step, rake_deg)
    strain = np.asarray(frame.plastic_strain, np.float64)[alive].mean(axis=1)
    celsius = np.asarray(frame.temperature, np.float64)[alive].mean(axis=1) - 273.15
    height = 3.2 * (top + _BELOW) / (left + _RIGHT) + 1.6
    figure, panels = plt.subplots(
        1, 2, figsize=(12, max(3.5, height)), dpi=150, layout="constrained"
    )
    scales = (
        (strain, "viridis", (0.0, _STRAIN_MAX), "equivalent plastic strain"),
        (celsius, "inferno", (float(celsius.min()), float(celsius.max())), "temperature (°C)"),
    )
    for axes, (values, cmap, clim, label) in zip(panels, scales, strict=True):
        shaded = PolyCollection(corners, array=values, cmap=cmap, edgecolors=_EDGES, linewidths=0.2)
        shaded.set_clim(*clim)
        axes.add_collection(shaded)
        axes.fill(*tool.T, fc="0.7", ec="black", lw=0.8, zorder=3)
        _window(axes, top, left)
        axes.set_title(label)
        figure.colorbar(shaded, ax=axes, label=label, shrink=0.9)
    travel = cutting.travel_at(model, frame.step)
    figure.suptitle(
        f"Orthogonal cutting of AISI 1045, {_conditions(cut, rake_deg, mu)}: "
        f"after {travel:.2f} mm of travel ({frame.step:,} steps)"
    )
    figure.savefig(path)
    plt.close(figure)
    return path


def _moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """The centred moving average of ``values`` over ``window`` samples (shorter at the ends)."""
    kernel = np.ones(window)
    total = np.convolve(values, kernel, mode="same")
    count = np.convolve(np.ones_like(values), kernel, mode="same")
    return total / count


def _percent(value: float) -> str:
    return "nan" if not math.isfinite(value) else f"{value:+.1f} %"


def window_note(summary: dict) -> str:
    """What the forces' means are taken over, in words (the printout's line and the
    forces figure's caption): the steady window's start, or the drift where none is."""
    start, end = summary["force_window_mm"]
    drift = (
        f"F_c drifts {_percent(summary['cutting_force_drift_percent'])}, "
        f"F_t {_percent(summary['thrust_force_drift_percent'])} across it"
    )
    if summary["forces_steady"]:
        return (
            f"steady from {start:.3f} mm of travel (to {end:.3f} mm; {drift}, within "
            f"±{100 * cutting.STEADY_DRIFT:g} %): the means are over that window"
        )
    return (
        f"no steady state in the run (no window to its end drifts within "
        f"±{100 * cutting.STEADY_DRIFT:g} %): the means are over the last "
        f"{100 * cutting.LAST:g} % of the steps, {start:.3f} to {end:.3f} mm; {drift}"
    )


def dips_note(summary: dict, element: float, cycle: int) -> str:
    """What the raw F_c's dips are, with the run's own evidence, in words."""
    if not math.isfinite(summary["release_dip_N_per_mm"]):
        return "(too few pair releases to measure F_c's dips at them)"
    return (
        f"The raw F_c dips once per element of travel ({element:g} mm, {cycle:,} steps), "
        f"as node separation releases a pair of the parting line: in "
        f"{summary['release_dips_after_release']} of {summary['release_dip_cycles']} element "
        f"cycles around a release, F_c's lowest comes within {cycle // 10} steps after it "
        f"(a median {summary['release_dip_lag_steps']:.0f} steps after, "
        f"{summary['release_dip_N_per_mm']:.0f} N/mm below the cycle's mean)"
    )


def draw_forces(model, record, summary: dict, path: str) -> str:
    """The cutting and thrust forces against the travel, beside Merchant's and Kienzle's:
    raw (faint), averaged over one element of travel (which takes out the dip at each
    pair release, marked), the averaging window with its fitted lines (the drift)."""
    import matplotlib.pyplot as plt

    cut = model.cut
    force = np.asarray(record.force, np.float64)
    steps = len(force)
    # Row k of the record is the step from k to k + 1.
    travel = cutting.tool_travel(cut, np.arange(1, steps + 1))
    cycle = cut.element_steps
    start, end = summary["force_window_mm"]
    first = int(np.searchsorted(travel, start))
    figure, axes = plt.subplots(figsize=(11, 5.6), dpi=150, layout="constrained")
    axes.axvspan(
        start,
        end,
        color="0.9",
        zorder=0,
        label=(
            "steady: the means' window"
            if summary["forces_steady"]
            else f"no steady state: the last {100 * cutting.LAST:g} %"
        )
        + f" from {start:.3f} mm",
    )
    low, high = summary["kienzle_band_N_per_mm"]
    k_c11, m_c = machining.KIENZLE_CK45
    axes.axhspan(
        low,
        high,
        color="tab:green",
        alpha=0.2,
        lw=0,
        label=f"Kienzle, Ck45: {low:.0f} to {high:.0f} N/mm at h = {cut.uncut:g} mm\n"
        f"(k_c1.1 = 1500 to {k_c11:g} N/mm², m_c = {m_c:g};\n"
        f"{k_c11:g}: König and Klocke; 1500: handbooks' low end)",
    )
    quantities = (
        (0, "F_c", "cutting", "tab:blue", "cutting_force"),
        (1, "F_t", "thrust", "tab:orange", "thrust_force"),
    )
    for column, symbol, name, colour, key in quantities:
        axes.plot(travel, force[:, column], c=colour, lw=0.4, alpha=0.25)
        axes.plot(
            travel,
            _moving_average(force[:, column], cycle),
            c=colour,
            lw=1.5,
            label=f"{name} force {symbol}: mean {summary[f'{key}_N_per_mm']:,.0f} N/mm",
        )
        # The least-squares line over the window: its change across it is the drift.
        if steps - first >= 2:
            slope, offset = np.polyfit(travel[first:], force[first:, column], 1)
            ends = np.array([travel[first], travel[-1]])
            axes.plot(
                ends,
                offset + slope * ends,
                c=colour,
                ls=":",
                lw=1.5,
                label=f"{symbol}'s fitted line there: "
                f"{_percent(summary[f'{key}_drift_percent'])} across it",
            )
        theory = summary[f"merchant_{key}_N_per_mm"]
        if math.isfinite(theory):
            axes.axhline(
                theory, c=colour, ls="--", lw=1.2, label=f"Merchant's {symbol} ({theory:,.0f} N/mm)"
            )
    axes.plot([], [], c="0.5", lw=0.5, alpha=0.6, label="raw (each step)")
    releases = cutting.release_dips(record, cycle).releases
    axes.plot(
        travel[releases],
        np.full(len(releases), 0.02),
        ls="",
        marker="|",
        ms=10,
        c="0.25",
        transform=axes.get_xaxis_transform(),
        label="a parting-line pair released",
    )
    axes.set(
        xlabel="tool travel (mm)",
        ylabel="force on the tool (N per mm of width)",
        xlim=(0, travel[-1]),
        ylim=(0, None),
    )
    axes.set_title(
        f"{_conditions(cut, summary['rake_deg'], summary['friction'])}:\nthe forces on the "
        f"tool over {travel[-1]:.3f} mm of travel ({steps:,} steps)"
    )
    axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    caption = (
        "Thick lines: the force averaged over one element of travel, which takes out the dip "
        "of each release (faint: the raw force).",
        dips_note(summary, cut.element, cycle) + ".",
        "Shaded: " + window_note(summary) + ".",
    )
    figure.supxlabel(
        "\n".join(textwrap.fill(line, _CAPTION) for line in caption),
        fontsize=8,
        x=0.01,
        ha="left",
        multialignment="left",
    )
    figure.savefig(path)
    plt.close(figure)
    return path


def draw_gif(model, frames, rake_deg: float, mu: float, path: str) -> str:
    """The chip forming, frame by frame, in a window that follows the tool."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import PillowWriter
    from matplotlib.collections import PolyCollection

    cut = model.cut
    if len(frames) > FRAMES + 1:
        frames = [
            frames[i] for i in np.linspace(0, len(frames) - 1, FRAMES + 1).round().astype(int)
        ]
    shown = [_elements(model, frame) for frame in frames]
    left = _left(model)
    top = max(_top(corners, left) for corners, _ in shown) + 0.05
    figure, axes = plt.subplots(figsize=(6.4, 4.2), layout="constrained")
    shaded = PolyCollection(
        shown[0][0], array=np.zeros(len(shown[0][1])), cmap="viridis", edgecolors=_EDGES
    )
    shaded.set_linewidth(0.2)
    shaded.set_clim(0.0, _STRAIN_MAX)
    axes.add_collection(shaded)
    (tool,) = axes.fill(*_tool(model, 0, rake_deg).T, fc="0.7", ec="black", lw=0.8, zorder=3)
    _window(axes, top, left)
    figure.colorbar(shaded, ax=axes, label="equivalent plastic strain", shrink=0.9)
    title = axes.set_title("", fontsize=9)
    writer = PillowWriter(fps=10)
    with writer.saving(figure, path, dpi=80):
        for frame, (corners, alive) in zip(frames, shown, strict=True):
            shaded.set_verts(corners)
            shaded.set_array(np.asarray(frame.plastic_strain, np.float64)[alive].mean(axis=1))
            tool.set_xy(_tool(model, frame.step, rake_deg))
            travel = cutting.travel_at(model, frame.step)
            title.set_text(f"{_conditions(cut, rake_deg, mu)}\ntravel {travel:.3f} mm")
            writer.grab_frame()
    plt.close(figure)
    return path


if __name__ == "__main__":
    _parser = argparse.ArgumentParser(description="The orthogonal cutting demo, run and drawn.")
    add_arguments(_parser)
    _args = _parser.parse_args()
    if (_problem := check(_args)) is not None:
        _parser.error(_problem)
    sys.exit(main(_args))
