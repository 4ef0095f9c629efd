"""Closest point, jaxcontact beside its peers: the same closest-segment query, timed in one process.

    python benchmarks/peers.py [--quick] [--out DIR] [--repeats K] [--slow S]
    taskset -c 0 python benchmarks/peers.py --out benchmarks/results/pinned

Scenes (docs/scenes.md): the cutting scene with the tool in the workpiece
(``x_tip = 18``) from 10^3 to 10^6 nodes, the same with the tool clear of it
(``x_tip = 20.5``), and the rough die from (10^4, 10^3) to (10^6, 10^5). On
each, ``all_to_all`` and ``bucket_sort (sized)`` (float32, jit: the bucket
sort with its ``Sizes`` measured outside the timer, its whole search, broad
phase included, inside), ``bucket_sort (sized, compact)`` (the same search
returning the found contacts only, a ``ContactList``) and every peer of ``baselines.PEERS`` that is
installed are run round-robin; ``ratio`` is a method's median over
``bucket_sort (sized)``'s. Every answer is checked against ``all_to_all``
in float64, and each kind of disagreement is its own column (missed, false, ties
at a shared vertex, wrong segment, largest gap error).

A method is skipped, with the reason in its row, where it would hold more
than ``PAIR_BUDGET`` slave-segment pairs at once (the dense NumPy plane) or
evaluate more than ``DENSE_BUDGET`` pairs per call (``all_to_all``). A method
whose first call takes longer than ``--slow`` seconds is timed by that one
call only. A method run on no scene (a peer not installed, or one a pinned run
cannot give its threads) is left out of the tables and named in the record's notes.

The record (``<out>/peers.json``) holds a table of ratios (method by scene), a
table per scene (median, ratio, compile seconds, XLA's memory, the answer's
check) and every row in full under ``data["runs"]``; the figure
(``<out>/peers.png``) is each method's median against the slave count, one
panel per scene family. ``swept_peers.py`` builds its record with the same
functions.
"""

from __future__ import annotations

import functools
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run, answers, report
from benchmarks.harness.internals import measure, measure_contacts
from benchmarks.peer_codes import baselines
from jaxcontact import all_to_all
from jaxcontact.scenes import cutting_scene, rough_die_scene

# The library's bucket sort, as timed here: fixed sizes, measured outside the timer.
LIBRARY = "bucket_sort (sized)"
# The same with the compact result (a ``ContactList`` of the found contacts).
COMPACT = "bucket_sort (sized, compact)"
PAIR_BUDGET = 5e7  # NumPy (N, M, 2) float32 temporaries: about 0.4 GB each
DENSE_BUDGET = 1.2e9  # all_to_all pairs per call: a few seconds on a CPU core

FULL_SCENES = (
    *(("cutting, tool in (x_tip=18)", n, 18.0) for n in (1_000, 10_000, 81_939, 1_000_000)),
    *(("cutting, tool clear (x_tip=20.5)", n, 20.5) for n in (81_939, 1_000_000)),
    *(("rough die", n, m) for n, m in ((10**4, 10**3), (10**5, 10**4), (10**6, 10**5))),
)
QUICK_SCENES = (
    ("cutting, tool in (x_tip=18)", 10_000, 18.0),
    ("cutting, tool clear (x_tip=20.5)", 10_000, 20.5),
    ("rough die", 10**4, 10**3),
)


# Left out of --quick runs, which must finish in two minutes on 2 cores.
QUICK_SKIPS = {"jax-md cell list": "skipped in --quick: importing jax-md alone takes about 15 s"}

# Row fields that are numbers (``run_methods`` leaves "" where there is none, and keeps some as
# formatted text), and those that are counts.
REALS = ("compile_s", "temp_mib", "out_mib", "args_mib", "median_ms", "p10_ms", "p90_ms")
REALS += ("ratio", "max_gap_error", "wrong_by", "max_t_error")
COUNTS = ("nodes", "segments", "runs", "missed", "false", "ties", "wrong_segment")
COUNTS += ("found", "crossed")


def build(kind, size, parameter):
    if kind == "rough die":
        return rough_die_scene(size, parameter)
    return cutting_scene(size, parameter)


def _skip_reason(name, x, start, end, radius, quick) -> str | None:
    """Why ``name`` is not run on this scene, or None."""
    if quick and name in QUICK_SKIPS:
        return QUICK_SKIPS[name]
    pairs = len(x) * len(start)
    if name == "NumPy dense" and pairs > PAIR_BUDGET:
        return f"skipped: (N, M) plane of {pairs:.0e} pairs > {PAIR_BUDGET:.0e}"
    if name.startswith("NumPy box-then-dense"):
        low = np.minimum(start, end).min(axis=0) - radius
        high = np.maximum(start, end).max(axis=0) + radius
        inside = int(np.all((x >= low) & (x <= high), axis=1).sum())
        if inside * len(start) > PAIR_BUDGET:
            return f"skipped: {inside:,} slaves in the box x {len(start):,} segments > budget"
    if name == "all_to_all" and pairs > DENSE_BUDGET:
        return f"skipped: {pairs:.0e} pairs per call > {DENSE_BUDGET:.0e}"
    return baselines.unavailable(name) if name in baselines.PEERS else None


def _methods(scene):
    """name -> (fn, args): the library's two detectors, then the peers."""
    radius = scene.radius
    sizes = measure(scene.x, scene.surface, radius=radius)
    compact_sizes = measure_contacts(scene.x, scene.surface, radius, None, sizes, slack=1.5)
    methods = {
        "all_to_all": (
            jax.jit(functools.partial(all_to_all, radius=radius)),
            (scene.x, scene.surface),
        ),
        LIBRARY: (_run.sized_contact(radius, sizes), (scene.x, scene.surface)),
        # The compact form (``Search(compact=True)``): the found contacts only,
        # in a capacity measured once outside the timer, as the other sizes.
        COMPACT: (_run.sized_contact(radius, compact_sizes), (scene.x, scene.surface)),
    }
    for name, (_, prepare) in baselines.PEERS.items():
        methods[name] = prepare
    return methods


def answer_fields(result, x, start, end, reference) -> dict:
    """``answers.compare``'s counts of how ``result`` differs from ``reference``, and a note
    that says ``overflow`` where a ``Contact`` set it (the counts say the rest)."""
    mismatch = _run.check(result, x, start, end, reference)
    overflow = bool(getattr(_run.contact_of(result), "overflow", False))
    return {**mismatch._asdict(), "note": "overflow" if overflow else ""}


def run_scene(kind, size, parameter, repeats, slow_s, quick=False) -> list[dict]:
    """Every method on one scene: checked, then timed round-robin; one row per method, its
    fields JSON scalars (``scalars``).

    ``kind`` is ``"rough die"`` (``parameter``: its segment count) or a
    cutting scene (``parameter``: the tool tip's x); ``size`` the slave count.
    """
    scene = build(kind, size, parameter)
    x = np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    reference = answers.reference_contact(x, scene.surface, scene.radius)
    methods = {
        name: _skip_reason(name, x, start, end, scene.radius, quick) or method
        for name, method in _methods(scene).items()
    }
    rows = _run.run_methods(
        methods,
        lambda result: answer_fields(result, x, start, end, reference),
        repeats=repeats,
        slow_s=slow_s,
        library=LIBRARY,
        prepare_args=(x, start, end, scene.radius),
        scene=kind,
        nodes=len(x),
        segments=len(start),
        position=None if kind == "rough die" else parameter,
        dtype=str(x.dtype),
        found=int(reference.found.sum()),
    )
    return [scalars(entry) for entry in rows]


def scalars(entry: dict) -> dict:
    """A ``run_methods`` row as JSON scalars: numbers as numbers, None where there is none
    (``""`` in the row), the note without a leading separator."""
    out = {}
    for key, value in entry.items():
        if key == "note":
            out[key] = str(value).removeprefix("; ")
        elif isinstance(value, str) and value == "":
            out[key] = None
        elif key in REALS:
            out[key] = float(value)
        elif key in COUNTS:
            out[key] = int(value)
        elif isinstance(value, np.generic):
            out[key] = value.item()
        else:
            out[key] = value
    return out


def _scenes(runs) -> list[tuple]:
    """The runs' scenes, ``(scene, nodes, segments)``, in the order they ran."""
    return list(dict.fromkeys((r["scene"], r["nodes"], r["segments"]) for r in runs))


def short(scene: str) -> str:
    """A scene family's name in a column head: ``"tool in"``, ``"rough die"``, ``"paper Test 1"``.

    Example:
      >>> short("cutting, tool in (x_tip=18)"), short("paper Test 2 (length 20, d=10)")
      ('tool in', 'paper Test 2')
    """
    return scene.removeprefix("cutting, ").split(" (")[0]


def left_out(runs) -> dict:
    """method -> why, for each method that ran on no scene (the first scene's reason)."""
    reasons = {}
    for entry in runs:
        reasons.setdefault(entry["method"], entry["note"] if entry["median_ms"] is None else None)
        if entry["median_ms"] is not None:
            reasons[entry["method"]] = None
    return {name: why for name, why in reasons.items() if why is not None}


def left_out_note(runs) -> list[str]:
    """The record's note naming the methods run on no scene, and why; none if every one ran."""
    gone = left_out(runs)
    if not gone:
        return []
    return ["Run on no scene here: " + "; ".join(f"{n} ({why})" for n, why in gone.items()) + "."]


def ratio_table(runs, library: str, note: str) -> dict:
    """Each method's median over ``library``'s, one column per scene (None: not run there)."""
    scenes = _scenes(runs)
    heads = [f"{short(s)}, N={n:,}" for s, n, _ in scenes]
    if len(set(heads)) < len(heads):
        heads = [f"{short(s)}, N={n:,}, M={m:,}" for s, n, m in scenes]
    ratio = {(r["scene"], r["nodes"], r["segments"], r["method"]): r["ratio"] for r in runs}
    gone = left_out(runs)
    rows = [
        [method, *(ratio.get((*scene, method)) for scene in scenes)]
        for method in dict.fromkeys(r["method"] for r in runs)
        if method not in gone
    ]
    title = f"Median over {library}'s median, per scene (–: not run there)"
    return report.table(["method", *heads], rows, title=title, note=note)


def memory_mib(entry) -> float | None:
    """XLA's temporaries plus outputs of a jitted method's program, MiB (None for the rest)."""
    if entry.get("temp_mib") is None or entry.get("out_mib") is None:
        return None
    return round(entry["temp_mib"] + entry["out_mib"], 3)


def scene_tables(runs, error: str, title) -> list[dict]:
    """One table per scene: each method's median, ratio, compile seconds, memory and the
    check of its answer (``error``: the row field of its largest error, a column of that name
    with spaces); ``title(first_row)`` is the table's title. Methods run on no scene are left
    out (``left_out_note`` names them)."""
    gone = left_out(runs)
    columns = ["method", "median ms", "ratio", "compile s", "memory MiB", "missed", "false"]
    columns += ["ties", "wrong segment", error.replace("_", " "), "note"]
    tables = []
    for scene in _scenes(runs):
        mine = [r for r in runs if (r["scene"], r["nodes"], r["segments"]) == scene]
        rows = [
            [
                r["method"],
                r["median_ms"],
                r["ratio"],
                r["compile_s"],
                memory_mib(r),
                r.get("missed"),
                r.get("false"),
                r.get("ties"),
                r.get("wrong_segment"),
                r.get(error),
                r["note"] or None,
            ]
            for r in mine
            if r["method"] not in gone
        ]
        tables.append(report.table(columns, rows, title=title(mine[0])))
    return tables


NOTE = (
    "float32 inputs; medians of interleaved runs. ratio: a method's median over bucket_sort"
    " (sized)'s (the bucket sort with its sizes measured outside the timer, the whole search"
    " inside). Each answer is checked against all_to_all in float64: missed and false contacts,"
    " ties (another segment at the same distance: a shared vertex), wrong segment (a farther"
    " one) and the largest gap error. compile s: tracing, lowering and compiling (jit and"
    " numba); memory MiB: XLA's temporaries and outputs of a jitted method's program."
)


def scene_title(entry) -> str:
    return (
        f"{entry['scene']}: N = {entry['nodes']:,} slave nodes, M = {entry['segments']:,}"
        f" segments, {entry['found']:,} in contact"
    )


def run(args) -> dict:
    """Every scene of ``args`` (``quick``, ``repeats``, ``slow``): the record's title, tables,
    figure data and notes."""
    slow_s = args.slow or (3.0 if args.quick else 30.0)
    runs = []
    for kind, size, parameter in _run.progress(
        QUICK_SCENES if args.quick else FULL_SCENES, "peers"
    ):
        count = args.repeats or (5 if args.quick else (20 if size <= 10**5 else 5))
        runs += run_scene(kind, size, parameter, count, slow_s, args.quick)
    return {
        "title": "Closest point: jaxcontact and its peers",
        "tables": [
            ratio_table(runs, LIBRARY, NOTE),
            *scene_tables(runs, "max_gap_error", scene_title),
        ],
        "data": {"library": LIBRARY, "runs": runs},
        "notes": left_out_note(runs),
    }


def _family_title(scene: str, points) -> str:
    """A panel's title: the family, and M as a share of N where one holds for every point."""
    shares = {round(n / m) for n, m in points if m}
    if len({m for _, m in points}) > 1 and len(shares) == 1:
        return f"{scene}, M = N/{shares.pop()}"
    return scene


def draw_medians(record, plt, xlabel: str = "slave nodes N"):
    """Each method's median against the node count, log axes, one panel per scene family with
    two sizes or more, and one panel holding the scenes run at one size (a marker per method
    beside its scene); one look per method (``benchmarks.harness.style``), one legend right
    of the panels. From ``record["data"]["runs"]`` alone."""
    from benchmarks.harness import style

    runs = [r for r in record["data"]["runs"] if r["median_ms"] is not None]
    methods = list(dict.fromkeys(r["method"] for r in runs))
    families = {}
    for scene, nodes, segments in _scenes(runs):
        families.setdefault(scene, []).append((nodes, segments))
    grown = [s for s, points in families.items() if len(points) > 1]
    single = [(s, *points[0]) for s, points in families.items() if len(points) == 1]
    count = max(len(grown) + bool(single), 1)  # one empty panel where nothing was timed
    figure, panels = plt.subplots(1, count, figsize=(4.6 * count + 3.4, 4.5), squeeze=False)
    panels, used = list(panels[0]), {}
    for axes, scene in zip(panels, grown, strict=False):
        for name in methods:  # every panel in one order
            points = sorted(
                (r["nodes"], r["median_ms"])
                for r in runs
                if (r["scene"], r["method"]) == (scene, name)
            )
            if points:
                axes.plot(*zip(*points, strict=True), **style.style(name, used), label=name)
        axes.set(xscale="log", xlabel=xlabel)
        axes.set_title(_family_title(scene, families[scene]), fontsize=9)
    if single:
        axes = panels[-1]
        width = 0.6 / max(len(methods), 1)
        for offset, name in enumerate(methods):
            points = [
                (at - 0.3 + (offset + 0.5) * width, r["median_ms"])
                for at, key in enumerate(single)
                for r in runs
                if (r["scene"], r["nodes"], r["segments"], r["method"]) == (*key, name)
            ]
            if points:
                looks = {**style.style(name, used), "linestyle": "none"}
                axes.plot(*zip(*points, strict=True), **looks, label=name)
        axes.set_xticks(range(len(single)))
        axes.set_xticklabels([f"{short(s)}\nN={n:,}, M={m:,}" for s, n, m in single], fontsize=8)
        axes.set_xlim(-0.5, len(single) - 0.5)
        axes.set_title("scenes run at one size each", fontsize=9)
    for axes in panels:
        axes.set(yscale="log", ylabel="median (ms)")
        axes.grid(True, which="major", alpha=0.3)
        style.plain_log_labels(axes.yaxis)
        _minor_labels_at_2_and_5(axes.yaxis)
    style.legend_outside(panels[-1])
    figure.suptitle(record["title"], fontsize=10)
    return figure


def _minor_labels_at_2_and_5(axis) -> None:
    """Of a log ``axis``'s labelled minor ticks (``plain_log_labels`` labels them all on an
    axis of less than two decades), only 2 and 5 of each decade keep their labels: the nine
    labels of a decade crowd (0.9 beside 1)."""
    import math

    from matplotlib.ticker import FuncFormatter, NullFormatter

    labels = axis.get_minor_formatter()
    if isinstance(labels, NullFormatter):
        return

    def label(value, position=None):
        if value <= 0:
            return ""
        mantissa = value / 10 ** math.floor(math.log10(value) + 1e-9)
        return labels(value, position) if min(abs(mantissa - 2), abs(mantissa - 5)) < 1e-6 else ""

    axis.set_minor_formatter(FuncFormatter(label))


def draw(record, plt):
    return draw_medians(record, plt)


OPTIONS = ((("--slow",), {"type": float, "default": None, "help": "s: time a slower method once"}),)

if __name__ == "__main__":
    sys.exit(_run.suite("peers", run, draw, __doc__.splitlines()[0], options=OPTIONS))
