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

    python benchmarks/time_vs_error.py [--quick] [--out DIR]
"""

from __future__ import annotations

import dataclasses
import functools
import os
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import _run, answers
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


def run_tradeoff(label, scene64, repeats, quick) -> list[dict]:
    x64 = np.asarray(scene64.x)
    start, end = _run.endpoints(scene64.surface)
    reference = answers.reference_contact(x64, scene64.surface, scene64.radius)
    calls = variants(scene64, quick)
    timings = time_interleaved(calls, repeats=repeats)
    rows = []
    for name, (fn, args) in calls.items():
        result = fn(*args)
        mismatch = _run.check(result, x64, start, end, reference)
        entry = _run.row(label, len(x64), len(start), name, timings[name], mismatch)
        overflow = " (overflow)" if bool(result.overflow) else ""
        entry.update(dtype=str(args[0].dtype), note=answers.describe(mismatch) + overflow)
        rows.append(entry)
    return rows


def run_offsets(num_nodes, offsets, with_bucket) -> list[dict]:
    """float32 gap error of the cutting scene moved by ``(o, o)``, for each offset ``o``."""
    base = cutting_scene(num_nodes, 18.0, dtype=jnp.float64)
    detectors = {"all_to_all": jax.jit(functools.partial(all_to_all, radius=base.radius))}
    rows = []
    for offset in _run.progress(offsets, "offsets"):
        moved = base._replace(
            x=base.x + offset,
            surface=base.surface._replace(nodes=base.surface.nodes + offset),
        )
        scene = _cast(moved, jnp.float32)
        if with_bucket:
            # Not timed here: the one-call form, its sizes measured for this scene.
            detectors["bucket_sort"] = functools.partial(bucket_sort, radius=base.radius)
        start, end = _run.endpoints(moved.surface)
        exact = answers.reference_contact(np.asarray(moved.x), moved.surface, base.radius)
        start32, end32 = _run.endpoints(scene.surface)
        x32 = np.asarray(scene.x)
        rounded = answers.reference_contact(x32, scene.surface, base.radius)
        for name, detect in detectors.items():
            result = detect(scene.x, scene.surface)
            mismatch = _run.check(result, np.asarray(moved.x), start, end, exact)
            own = _run.check(result, x32, start32, end32, rounded)
            entry = _run.row("cutting, moved by (o, o)", len(x32), len(start), name, None, mismatch)
            entry.update(position=f"o={offset:g}", dtype="float32")
            entry["note"] = (
                f"{answers.describe(mismatch)}; against its rounded inputs: "
                f"{answers.describe(own)}, max gap error {own.max_gap_error:.3g}"
            )
            rows.append(entry)
    return rows


def _wrong_rows(row) -> int:
    return row["missed"] + row["false"] + row["wrong_segment"]


def plot(rows, out) -> list[str]:
    """Pareto plots (run time against wrong rows, and against the largest gap error) per
    scene, and the float32 gap error against the offset; one look per method (``style``)."""
    plt = _run.pyplot(out)
    if plt is None:
        return []
    from benchmarks.harness import style

    paths = []
    tradeoff = [r for r in rows if r["median_ms"] != ""]
    scenes = list(dict.fromkeys(r["scene"] for r in tradeoff))
    figure, panels = plt.subplots(
        2, len(scenes), figsize=(5.5 * len(scenes) + 3.5, 8), squeeze=False
    )
    used = {}
    for column, scene in enumerate(scenes):
        mine = [r for r in tradeoff if r["scene"] == scene]
        for axes, metric in (
            (panels[0][column], _wrong_rows),
            (panels[1][column], lambda r: max(float(r["max_gap_error"]), 1e-17)),
        ):
            points = sorted((r["median_ms"], metric(r)) for r in mine)
            front, best = [], np.inf
            for time_ms, error in points:  # Pareto front: no faster point is as accurate
                if error < best:
                    front.append((time_ms, error))
                    best = error
            for row in mine:  # in the order run: the same legend order in every panel
                looks = {**style.style(row["method"], used), "linestyle": "none"}
                looks["markersize"] += 3
                axes.plot(row["median_ms"], metric(row), **looks, label=row["method"], zorder=2)
            front_looks = style.style("Pareto front", used)
            axes.plot(*zip(*front, strict=True), **front_looks, label="Pareto front", zorder=1)
            axes.set_xscale("log")
            axes.set(xlabel="median run time (ms)", title=scene)
            axes.grid(True, which="major", alpha=0.3)
        counts, errors = panels[0][column], panels[1][column]
        style.count_axis(counts, max(_wrong_rows(r) for r in mine))
        counts.set_ylabel("wrong rows: missed + false + wrong segment\n(0, then log above 1)")
        errors.set_yscale("log")
        exact = any(float(r["max_gap_error"]) == 0 for r in mine)
        errors.set_ylabel("largest gap error" + (" (0 drawn at 1e-17)" if exact else ""))
        for axes in (counts, errors):
            style.plain_log_labels(axes.xaxis)
    style.legend_outside(panels[0][-1])
    figure.tight_layout()
    paths.append(os.path.join(out, "time_vs_error.png"))
    figure.savefig(paths[-1], dpi=120)
    plt.close(figure)

    offsets = [r for r in rows if r["position"].startswith("o=")]
    if offsets:
        figure, axes = plt.subplots(figsize=(8, 4.5), layout="constrained")
        used = {}
        names = list(dict.fromkeys(r["method"] for r in offsets))
        for index, name in enumerate(names):
            mine = [r for r in offsets if r["method"] == name]
            xs = [max(float(r["position"][2:]), 0.1) for r in mine]
            looks = style.style(name, used)
            # Methods may agree exactly: each earlier one drawn wider, to show beneath.
            wider = len(names) - 1 - index
            looks["markersize"] += 4 * wider
            looks["linewidth"] += 2.5 * wider
            axes.plot(xs, [float(r["max_gap_error"]) for r in mine], **looks, label=name)
        grid = np.logspace(0, 6, 50)
        ulp = "one float32 ulp of o"
        axes.plot(grid, np.spacing(np.float32(grid)), **style.style(ulp, used), label=ulp)
        axes.set(
            xscale="log",
            yscale="log",
            xlabel="coordinate offset o",
            ylabel="largest float32 gap error",
            title="float32 gap error against offset",
        )
        top = max(float(r["position"][2:]) for r in offsets)
        style.log_axis_from_zero(axes.xaxis, 0.1, top)
        axes.grid(True, which="major", alpha=0.3)
        style.legend_outside(axes)
        paths.append(os.path.join(out, "gap_error_vs_offset.png"))
        figure.savefig(paths[-1], dpi=120)
        plt.close(figure)
    return paths


def run(quick: bool, out: str, repeats: int | None = None) -> str:
    """Runs both parts, writes CSV/markdown/PNGs into ``out``; returns the markdown."""
    repeats = repeats or (5 if quick else 20)
    cutting_nodes = 5_000 if quick else 81_939
    # The die's all_to_all evaluates 10^9 pairs a call: 5 runs, not 20.
    scenes = [
        ("cutting, x_tip=18", lambda: cutting_scene(cutting_nodes, 18.0, dtype=jnp.float64), 1),
        ("rough die", lambda: rough_die_scene(10**5, 10**4, dtype=jnp.float64), 0.25),
    ]
    rows = []
    for label, build, share in _run.progress(scenes[:1] if quick else scenes, "time vs error"):
        rows += run_tradeoff(label, build(), max(3, round(repeats * share)), quick)
    offsets = OFFSETS[::2] if quick else OFFSETS
    rows += run_offsets(5_000 if quick else 81_939, offsets, with_bucket=not quick)
    pictures = plot(rows, out)
    timed = [r for r in rows if r["median_ms"] != ""]
    shifted = [r for r in rows if r["median_ms"] == ""]
    columns = (
        "scene",
        "nodes",
        "method",
        "median_ms",
        "p10_ms",
        "p90_ms",
        "runs",
        "missed",
        "false",
    )
    body = [
        _run.markdown(timed, (*columns, "wrong_segment", "ties", "max_gap_error", "note")),
        "",
        "### float32 gap error against coordinate offset",
        "",
        _run.markdown(shifted, ("position", "method", "missed", "false", "max_gap_error", "note")),
    ]
    note = "medians of interleaved runs; errors against all_to_all in float64 on the float64 scene."
    text = _run.section("time_vs_error", "Run time against error", quick, note, body, pictures)
    _run.write(out, "time_vs_error", rows, text)
    return text


def main(argv=None) -> int:
    return _run.main(run, __doc__.splitlines()[0], argv)
