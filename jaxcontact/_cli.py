"""The ``jaxcontact`` command line.

``jaxcontact demo`` runs the orthogonal cutting simulation
(``jaxcontact.problems.cutting.demo``: a chip forms; it prints the summary and
writes summary.json, chip.png, forces.png and chip.gif);
``jaxcontact demo --scene ploughing`` runs the ploughing simulation
(``jaxcontact.problems.ploughing.demo``); ``jaxcontact demo --scene paper`` runs the source
paper's scene (the repository's docs/scenes.md, Test 1) through both
exhaustive detectors (``all_to_all``, ``swept``), prints what they found and
how long they took, and draws the scene near the tool tip; ``jaxcontact demo
--scene hertz`` presses a rigid cylinder into an elastic block
(``jaxcontact.problems.hertz.demo``), prints a and p0 against Hertz's and draws the
pressure. An option of one scene given with another is refused. ``jaxcontact bench`` times
jaxcontact's own forms on the reference scenes (``jaxcontact._selftime``);
the comparisons with other libraries are the repository's ``benchmarks/``
folder, not installed. Each subcommand is registered in ``_parser``.
"""

from __future__ import annotations

import argparse
import functools
import sys

import jax
import numpy as np

from jaxcontact import _selftime, all_to_all, swept
from jaxcontact._timing import pinned_note, time_call
from jaxcontact.problems._output import write_png
from jaxcontact.problems.cutting import demo as _cutting_demo
from jaxcontact.problems.hertz import demo as _hertz_demo
from jaxcontact.problems.ploughing import demo as _demo_sim
from jaxcontact.scenes import paper_scene

# Drawn around the tool tip T = (50.9, 7): the rake and clearance faces, the
# nodes pushed into them and the paths that cross them all fall inside.
_ZOOM_X = (45.0, 56.0)
_ZOOM_Y = (5.5, 11.5)
# One drawn path per this many crossed nodes: every path would fill the band solid.
_PATH_STRIDE = 12


def _demo(args: argparse.Namespace) -> int:
    if args.scene == "cutting":
        return _cutting_demo.main(args)
    if args.scene == "ploughing":
        return _demo_sim.main(args)
    if args.scene == "hertz":
        return _hertz_demo.main(args)
    if args.dtype == "float64":
        jax.config.update("jax_enable_x64", True)
    scene = paper_scene(args.n, length=10.0, d=5.0, dtype=np.dtype(args.dtype))
    detect = jax.jit(functools.partial(all_to_all, radius=scene.radius))
    sweep = jax.jit(swept)
    # Timed first: once a jitted function has run, its compiled form is cached.
    detect_time = time_call(detect, scene.x, scene.surface)
    sweep_time = time_call(sweep, scene.x_prev, scene.x, scene.surface)
    contact = detect(scene.x, scene.surface)
    crossing = sweep(scene.x_prev, scene.x, scene.surface)

    print(
        f"paper scene, Test 1: n={args.n} ({scene.x.shape[0]:,} nodes), "
        f"face length 10, d=5, radius {scene.radius:g}, {args.dtype}"
    )
    print(f"jax {jax.__version__} on {jax.devices()[0].device_kind}; {pinned_note()}")
    print(f"  found   {int(contact.found.sum()):>7,}  (closest segment within the radius)")
    print(f"  active  {int(contact.active.sum()):>7,}  (found and penetrating, gap < 0)")
    print(f"  crossed {int(crossing.crossed.sum()):>7,}  (path x_prev -> x crosses the tool)")
    for name, timing in (("all_to_all", detect_time), ("swept", sweep_time)):
        print(
            f"  {name:<10}  compile {timing.compile_s:6.3f} s   "
            f"run {timing.median_s * 1e3:8.3f} ms median of {timing.runs} "
            f"(p10 {timing.p10_s * 1e3:.3f}, p90 {timing.p90_s * 1e3:.3f})"
        )

    write_png(
        args.out, f"paper_scene_n{args.n}.png", lambda path: _draw(scene, contact, crossing, path)
    )
    return 0


def _draw(scene, contact, crossing, path: str) -> None:
    """Draws the scene near the tool tip into the PNG at ``path``.

    Two panels over the same window, because most active nodes are also
    crossed ones and one set of markers would hide the other: the closest-point
    result of ``all_to_all`` above, the paths and crossings of ``swept`` below.
    """
    import matplotlib.pyplot as plt

    x_prev, x = np.asarray(scene.x_prev), np.asarray(scene.x)
    tool = np.asarray(scene.surface.nodes)
    found, active = np.asarray(contact.found), np.asarray(contact.active)
    crossed = np.asarray(crossing.crossed)
    in_view = (
        (x[:, 0] >= _ZOOM_X[0])
        & (x[:, 0] <= _ZOOM_X[1])
        & (x[:, 1] >= _ZOOM_Y[0])
        & (x[:, 1] <= _ZOOM_Y[1])
    )

    figure, (closest, paths) = plt.subplots(
        2, 1, figsize=(10, 11), dpi=150, sharex=True, layout="constrained"
    )
    for axes in (closest, paths):
        axes.scatter(*x[in_view].T, s=0.5, c="0.8", lw=0, label="workpiece nodes (moved by d)")
    closest.scatter(*x[found & ~active].T, s=4, c="tab:blue", lw=0, label="found, gap ≥ 0")
    closest.scatter(*x[active].T, s=4, c="tab:red", lw=0, label="active: found, gap < 0")
    closest.set_title(
        f"all_to_all(x, tool, radius={scene.radius:g}): "
        f"found {found.sum():,}, active {active.sum():,}",
        fontsize=11,
    )

    for index in np.flatnonzero(crossed)[::_PATH_STRIDE]:
        paths.plot(*np.stack([x_prev[index], x[index]]).T, lw=0.5, c="tab:orange", alpha=0.7)
    paths.plot([], [], lw=0.8, c="tab:orange", label=f"path x_prev → x (1 in {_PATH_STRIDE})")
    paths.scatter(*x[crossed].T, s=5, c="tab:orange", lw=0, label="crossed nodes (at x)")
    paths.scatter(
        *np.asarray(crossing.point)[crossed].T,
        s=6,
        c="tab:purple",
        lw=0,
        zorder=4,
        label="first crossing points",
    )
    paths.set_title(f"swept(x_prev, x, tool): crossed {crossed.sum():,}", fontsize=11)

    for axes in (closest, paths):
        axes.plot(*tool.T, c="black", lw=1.2, zorder=3, label="tool R → T → C")
        axes.annotate(
            "T",
            tool[1],
            xytext=(-16, -16),
            textcoords="offset points",
            bbox={"fc": "white", "ec": "none", "pad": 1},
        )
        axes.set(xlim=_ZOOM_X, ylim=_ZOOM_Y, ylabel="y (mm)", aspect="equal")
        axes.legend(loc="upper left", fontsize=8, markerscale=2.5, framealpha=0.95)
    paths.set_xlabel("x (mm)")
    figure.suptitle(
        f"Paper scene, Test 1: {x.shape[0]:,} nodes, face length 10, d = 5 (near the tool tip)"
    )
    figure.savefig(path)
    plt.close(figure)


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1; got {value}")
    return value


def _at_least_two(text: str) -> int:
    value = int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"must be at least 2; got {value}")
    return value


class _Options:
    """An argument group that keeps the options added to it, for ``_check_demo``."""

    def __init__(self, parser: argparse.ArgumentParser, title: str):
        self.group = parser.add_argument_group(title)
        self.actions: list[argparse.Action] = []

    def add_argument(self, *names, **options) -> argparse.Action:
        action = self.group.add_argument(*names, **options)
        self.actions.append(action)
        return action


def _check_demo(parser: argparse.ArgumentParser, scenes: dict, args: argparse.Namespace) -> None:
    """Refuses an option given for a scene that does not take it, and the
    cutting scene's options that do not fit together (``parser.error``: exit 2)."""
    for option, (dest, default, owners) in scenes.items():
        if args.scene not in owners and getattr(args, dest) != default:
            default = " (the default)" if args.scene == parser.get_default("scene") else ""
            parser.error(
                f"{option} is an option of --scene {' and '.join(owners)}, not of "
                f"--scene {args.scene}{default}: add --scene {owners[0]}"
            )
    if args.scene == "cutting" and (problem := _cutting_demo.check(args)) is not None:
        parser.error(problem)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="jaxcontact", description="2D node-to-segment contact detection in JAX."
    )
    commands = parser.add_subparsers(dest="command", required=True)
    demo = commands.add_parser(
        "demo",
        help="run the cutting simulation (or --scene ploughing, paper, hertz) and draw it",
        description="Runs a simulation or a scene and draws it: by default the orthogonal "
        "cutting simulation (a chip forms), which prints its summary and writes summary.json, "
        "chip.png, forces.png and chip.gif into --out. Each option below its scene's heading "
        "belongs to that scene only.",
    )
    demo.add_argument(
        "--scene",
        choices=("cutting", "ploughing", "paper", "hertz"),
        default="cutting",
        help="cutting: orthogonal cutting, a chip forms (default); ploughing: a tool ploughing "
        "an elastic workpiece; paper: the paper's scene, Test 1; hertz: a cylinder pressed "
        "into an elastic block, against Hertz (always float64)",
    )
    demo.add_argument("--out", default="jaxcontact-demo", help="folder for the files it writes")
    demo.add_argument(
        "--dtype", choices=("float32", "float64"), default="float32", help="default float32"
    )
    # Taken by both simulations, with their own defaults.
    demo.add_argument(
        "--travel",
        type=_cutting_demo.positive,
        default=None,
        help=f"cutting and ploughing: tool travel in mm (default {_cutting_demo.TRAVEL:g} "
        f"cutting, {_demo_sim.TRAVEL:g} ploughing)",
    )
    cutting = _Options(demo, "cutting (--scene cutting, the default)")
    _cutting_demo.add_arguments(cutting, shared=False)
    ploughing = _Options(demo, "ploughing (--scene ploughing)")
    _demo_sim.add_arguments(ploughing, travel=False)
    paper = _Options(demo, "paper (--scene paper)")
    paper.add_argument("--n", type=_positive_int, default=250, help="(n+1)^2 nodes (default 250)")
    hertz = _Options(demo, "hertz (--scene hertz)")
    hertz.add_argument(
        "--across",
        type=_at_least_two,
        default=_hertz_demo.ACROSS,
        help=f"elements across the contact width 2a (default {_hertz_demo.ACROSS})",
    )
    scenes = {"--travel": ("travel", None, ("cutting", "ploughing"))}
    groups = (("cutting", cutting), ("ploughing", ploughing), ("paper", paper), ("hertz", hertz))
    for name, options in groups:
        for action in options.actions:
            scenes[action.option_strings[0]] = (action.dest, action.default, (name,))
    demo.set_defaults(run=_demo, check=functools.partial(_check_demo, demo, scenes))
    bench = commands.add_parser(
        "bench",
        help="time jaxcontact's own forms on the reference scenes; write a CSV and a PNG",
        description=_selftime.__doc__.splitlines()[0],
    )
    _selftime.add_arguments(bench)
    bench.set_defaults(run=_selftime.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Runs the command line; returns the exit status."""
    args = _parser().parse_args(argv)
    if hasattr(args, "check"):
        args.check(args)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
