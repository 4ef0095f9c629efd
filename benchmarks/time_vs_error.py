"""Run time against error: what each precision and each bucket sort's sizes buy, and what it costs.

Part 1: on the cutting scene (tool in, ``x_tip = 18``) and the rough die, run
``all_to_all`` and ``bucket_sort (sized)`` in float32 and float64, and
``bucket_sort (sized)`` with sizes of shrinking capacity (blocks kept,
segments per cell) and other cell sizes, all round-robin. "(sized)": the
bucket sort with ``Sizes`` measured outside the timer
(``jaxcontact._pipeline.sizes.measure``), its whole search inside. Each is checked
against all_to_all in float64 on the float64 scene: missed and false contacts,
wrong segments, the largest gap error. Sizes too small for the scene set
``overflow`` and miss contacts: the Pareto plot shows that trade.

Part 2: the float32 gap error against a coordinate offset (the whole scene
moved by ``(o, o)``, ``o`` from 1 to 10^6): against the float64 scene, and
against the float64 answer for the rounded float32 inputs (the library's own
arithmetic).

The figure: per scene, run time against wrong rows (missed + false + wrong
segment) and against the largest gap error, each with its Pareto front; right,
part 2's float32 gap error against the offset, against the float64 scene and
against the rounded inputs, on one scale. Writes ``<out>/time_vs_error.json``
and ``<out>/time_vs_error.png`` (default ``--out benchmarks/results``) and
prints the record's markdown.

    python benchmarks/time_vs_error.py            # both scenes (the die's all_to_all: 8 s a call)
    python benchmarks/time_vs_error.py --quick    # the cutting scene at 5,000 nodes, fewer sizes
    taskset -c 0 python benchmarks/time_vs_error.py --out benchmarks/results/pinned
"""

from __future__ import annotations

import dataclasses
import functools
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import _run, answers, report
from benchmarks.harness.internals import measure
from benchmarks.harness.timing import time_interleaved
from jaxcontact import all_to_all, bucket_sort
from jaxcontact.scenes import Scene, cutting_scene, rough_die_scene

OFFSETS = (0.0, 1.0, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6)


def _cast(scene: Scene, dtype) -> Scene:
    surface = scene.surface._replace(nodes=scene.surface.nodes.astype(dtype))
    return scene._replace(
        x_prev=scene.x_prev.astype(dtype), x=scene.x.astype(dtype), surface=surface
    )


def _shrunk(sizes, **factors):
    """``sizes`` with each named capacity multiplied by its factor (at least 1)."""
    fields = {name: max(1, int(getattr(sizes, name) * f)) for name, f in factors.items()}
    return dataclasses.replace(sizes, **fields)


def variants(scene64: Scene, quick: bool) -> dict:
    """name -> (fn, args) for every precision and sizes compared on ``scene64``."""
    calls = {}
    radius = scene64.radius
    for dtype in (jnp.float32, jnp.float64):
        scene = _cast(scene64, dtype)
        bits = "f32" if dtype == jnp.float32 else "f64"
        args = (scene.x, scene.surface)
        calls[f"all_to_all {bits}"] = (jax.jit(functools.partial(all_to_all, radius=radius)), args)
        sizes = measure(scene.x, scene.surface, radius=radius)
        calls[f"bucket_sort (sized) {bits}"] = (_run.sized_contact(radius, sizes), args)
    scene = _cast(scene64, jnp.float32)
    args = (scene.x, scene.surface)
    chosen = {}
    default = measure(scene.x, scene.surface, radius=radius)
    for factor in (0.5,) if quick else (0.75, 0.5, 0.25):
        chosen[f"bucket_sort (sized) f32, blocks x{factor}"] = _shrunk(
            default, block_capacity=factor
        )
    cells = measure(scene.x, scene.surface, radius=radius, use_cells=True)
    for factor in (0.5,) if quick else (0.5, 0.25):
        chosen[f"bucket_sort (sized) f32 cells, per-cell capacity x{factor}"] = _shrunk(
            cells, cell_capacity=factor
        )
    for factor in () if quick else (0.5, 2.0):
        chosen[f"bucket_sort (sized) f32 cells, cell edge x{factor}"] = measure(
            scene.x, scene.surface, radius=radius, use_cells=True, cell_factor=factor
        )
    for name, sizes in chosen.items():
        calls[name] = (_run.sized_contact(radius, sizes), args)
    return calls


def _fields(mismatch) -> dict:
    """A ``Mismatch`` as table cells."""
    return {
        "missed": mismatch.missed,
        "false": mismatch.false,
        "wrong segment": mismatch.wrong_segment,
        "ties": mismatch.ties,
        "max gap error": mismatch.max_gap_error,
    }


def run_tradeoff(label, scene64, repeats, quick) -> list[dict]:
    """Every variant on ``scene64``, timed round-robin, each checked against all_to_all in
    float64; one row each (the table's columns, and the spread and ``wrong by`` beside)."""
    x64 = np.asarray(scene64.x)
    start, end = _run.endpoints(scene64.surface)
    reference = answers.reference_contact(x64, scene64.surface, scene64.radius)
    calls = variants(scene64, quick)
    timings = time_interleaved(calls, repeats=repeats)
    rows = []
    for name, (fn, args) in calls.items():
        result = fn(*args)
        mismatch = _run.check(result, x64, start, end, reference)
        timing = timings[name]
        rows.append(
            {
                "scene": label,
                "nodes": len(x64),
                "method": name,
                "median ms": timing.median_s * 1e3,
                **_fields(mismatch),
                "overflow": bool(result.overflow),
                "p10 ms": timing.p10_s * 1e3,
                "p90 ms": timing.p90_s * 1e3,
                "runs": timing.runs,
                "wrong by": mismatch.wrong_by,
            }
        )
    return rows


def run_offsets(num_nodes, offsets, with_bucket) -> list[dict]:
    """float32 gap error of the cutting scene moved by ``(o, o)``, for each offset ``o``:
    against the float64 scene, and against the float64 answer for the rounded inputs."""
    base = cutting_scene(num_nodes, 18.0, dtype=jnp.float64)
    detectors = {"all_to_all f32": jax.jit(functools.partial(all_to_all, radius=base.radius))}
    if with_bucket:
        # Not timed here: the one-call form, its sizes measured for each scene.
        detectors["bucket_sort f32"] = functools.partial(bucket_sort, radius=base.radius)
    rows = []
    for offset in _run.progress(offsets, "offsets"):
        moved = base._replace(
            x=base.x + offset,
            surface=base.surface._replace(nodes=base.surface.nodes + offset),
        )
        scene = _cast(moved, jnp.float32)
        start, end = _run.endpoints(moved.surface)
        exact = answers.reference_contact(np.asarray(moved.x), moved.surface, base.radius)
        start32, end32 = _run.endpoints(scene.surface)
        x32 = np.asarray(scene.x)
        rounded = answers.reference_contact(x32, scene.surface, base.radius)
        for name, detect in detectors.items():
            result = detect(scene.x, scene.surface)
            mismatch = _run.check(result, np.asarray(moved.x), start, end, exact)
            own = _run.check(result, x32, start32, end32, rounded)
            rows.append(
                {
                    "offset o": offset,
                    "method": name,
                    **_fields(mismatch),
                    "own max gap error": own.max_gap_error,
                    "own check": answers.describe(own),
                }
            )
    return rows


TRADEOFF = ("scene", "nodes", "method", "median ms", "missed", "false", "wrong segment", "ties")
TRADEOFF += ("max gap error", "overflow")
OFFSET = ("offset o", "method", "missed", "false", "wrong segment", "ties", "max gap error")
OFFSET += ("own max gap error", "own check")
TITLES = ("Run time against error", "float32 gap error against coordinate offset")


def run(args) -> dict:
    """Both parts; ``--quick``: the cutting scene at 5,000 nodes, fewer sizes and offsets."""
    quick = args.quick
    repeats = args.repeats or (5 if quick else 20)
    cutting_nodes = 5_000 if quick else 81_939
    # The die's all_to_all evaluates 10^9 pairs a call: 5 runs, not 20.
    scenes = [
        ("cutting, x_tip=18", lambda: cutting_scene(cutting_nodes, 18.0, dtype=jnp.float64), 1),
        ("rough die", lambda: rough_die_scene(10**5, 10**4, dtype=jnp.float64), 0.25),
    ]
    timed = []
    for label, build, share in _run.progress(scenes[:1] if quick else scenes, "time vs error"):
        timed += run_tradeoff(label, build(), max(3, round(repeats * share)), quick)
    offsets = OFFSETS[::2] if quick else OFFSETS
    shifted = run_offsets(cutting_nodes, offsets, with_bucket=not quick)
    tradeoff_note = (
        'Medians of interleaved runs; "(sized)": the bucket sort at sizes measured outside '
        "the timer, its whole search inside. Each answer checked against all_to_all in "
        "float64 on the float64 scene: missed and false contacts, wrong segments (farther "
        "than the closest), ties (another segment at the same distance), the largest gap "
        "error. `overflow`: the sizes were too small for the scene (contacts may be missed)."
    )
    offset_note = (
        "The cutting scene moved by `(o, o)`, searched in float32. `max gap error` and the "
        "counts: against the float64 scene; `own max gap error` and `own check`: against the "
        "float64 answer for the rounded float32 inputs (the library's own arithmetic)."
    )
    spread = ("scene", "method", "p10 ms", "p90 ms", "runs", "wrong by")
    return {
        "title": "Run time against error",
        "tables": [
            report.table(TRADEOFF, timed, title=TITLES[0], note=tradeoff_note),
            report.table(OFFSET, shifted, title=TITLES[1], note=offset_note),
        ],
        "data": {"spread": [{key: row[key] for key in spread} for row in timed]},
        "notes": [],
    }


def _rows(record, title) -> list[dict]:
    (found,) = [t for t in record["tables"] if t["title"] == title]
    return [dict(zip(found["columns"], row, strict=True)) for row in found["rows"]]


def _wrong_rows(row) -> int:
    return row["missed"] + row["false"] + row["wrong segment"]


def _error(row) -> float:
    return max(row["max gap error"], 1e-17)  # a log axis: an exact answer drawn at 1e-17


def _front(points):
    """The Pareto front of ``(time, error)`` points: no faster point is as accurate."""
    front, best = [], np.inf
    for time_ms, error in sorted(points):
        if error < best:
            front.append((time_ms, error))
            best = error
    return front


def draw(record, plt):
    """Per scene, run time against wrong rows (top) and against the largest gap error (below),
    with their Pareto fronts; right, the float32 gap error against the offset, against the
    float64 scene (top) and against the rounded inputs' own answer (below)."""
    from benchmarks.harness import style

    tradeoff, shifted = _rows(record, TITLES[0]), _rows(record, TITLES[1])
    scenes = list(dict.fromkeys(r["scene"] for r in tradeoff))
    figure, panels = plt.subplots(
        2, len(scenes) + 1, figsize=(5 * len(scenes) + 8.5, 8), squeeze=False
    )
    used = {}
    for column, scene in enumerate(scenes):
        mine = [r for r in tradeoff if r["scene"] == scene]
        counts, errors = panels[0][column], panels[1][column]
        for axes, metric in ((counts, _wrong_rows), (errors, _error)):
            for row in mine:  # in the order run: the same legend order in every panel
                looks = {**style.style(row["method"], used), "linestyle": "none"}
                looks["markersize"] += 3
                axes.plot(row["median ms"], metric(row), **looks, label=row["method"], zorder=2)
            front = _front((r["median ms"], metric(r)) for r in mine)
            looks = style.style("Pareto front", used)
            axes.plot(*zip(*front, strict=True), **looks, label="Pareto front", zorder=1)
            axes.set_xscale("log")
            axes.set(xlabel="median run time (ms)", title=scene)
            axes.grid(True, which="major", alpha=0.3)
        style.count_axis(counts, max(_wrong_rows(r) for r in mine))
        counts.set_ylabel("wrong rows: missed + false + wrong segment\n(0, then log above 1)")
        errors.set_yscale("log")
        exact = any(r["max gap error"] == 0 for r in mine)
        errors.set_ylabel("largest gap error" + (" (0 drawn at 1e-17)" if exact else ""))
        for axes in (counts, errors):
            style.plain_log_labels(axes.xaxis)

    against, own = panels[0][-1], panels[1][-1]
    names = list(dict.fromkeys(r["method"] for r in shifted))
    top = max(r["offset o"] for r in shifted)
    for axes, key in ((against, "max gap error"), (own, "own max gap error")):
        for index, name in enumerate(names):
            mine = [r for r in shifted if r["method"] == name]
            looks = style.style(name, used)
            # Methods may agree exactly: each earlier one drawn wider, to show beneath.
            wider = len(names) - 1 - index
            looks["markersize"] += 4 * wider
            looks["linewidth"] += 2.5 * wider
            xs = [max(r["offset o"], 0.1) for r in mine]  # 0 drawn at 0.1
            axes.plot(xs, [max(r[key], 1e-17) for r in mine], **looks, label=name)
        axes.set(xscale="log", yscale="log", xlabel="coordinate offset o")
        style.log_axis_from_zero(axes.xaxis, 0.1, top)
        axes.grid(True, which="major", alpha=0.3)
    grid = np.logspace(0, np.log10(max(top, 10)), 50)
    ulp = "one float32 ulp of o"
    against.plot(grid, np.spacing(np.float32(grid)), **style.style(ulp, used), label=ulp)
    against.set(ylabel="largest float32 gap error", title="float32, against the float64 scene")
    own.set(ylabel="largest float32 gap error", title="float32, against its rounded inputs")
    low = min(own.get_ylim()[0], against.get_ylim()[0])
    high = max(own.get_ylim()[1], against.get_ylim()[1])
    for axes in (against, own):
        axes.set_ylim(low, high)  # one scale: the offset's share of the error at a glance
    style.legend_outside(against)
    return figure


if __name__ == "__main__":
    sys.exit(_run.suite("time_vs_error", run, draw, __doc__.splitlines()[0]))
