"""The source paper's Tests 1 and 2 (docs/scenes.md, scene 1), as its Figs. 8 and 9 plot them.

Test 1 refines the workpiece (face length 10, d = 5) from 4 to 82,369 nodes;
Test 2 moves the tool (63,001 nodes, face length 20) from d = 0 to 10 in 21
steps. Each position is answered by ``all_to_all``, ``bucket_sort (sized)``,
``swept`` and ``bucket_swept (sized)`` (float32, jit), timed round-robin,
compile time apart. "(sized)": the bucket sort with its ``Sizes`` measured
outside the timer (``jaxcontact._pipeline.sizes.measure``) and its whole search, broad
phase included, inside. In Test 2 every method compiles once: the sizes are
measured for all 21 positions together (the largest of each capacity,
``_sizes.largest``), as a simulation would size them. Closest points are
checked against ``all_to_all`` in float64 (``answers.reference_contact``), crossings
against a float64 NumPy brute force (``baselines.brute_crossing``).

The plots draw the paper's own averages (Matlab, Intel Core i5-2430M: bucket
sort 0.02 s, all-to-all 0.64 s) as reference lines.

    python benchmarks/paper_tests.py [--quick] [--out DIR]
"""

from __future__ import annotations

import functools
import os
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run, answers
from benchmarks.harness.internals import largest, measure
from benchmarks.harness.timing import compiled_call, time_interleaved
from benchmarks.peer_codes import baselines
from jaxcontact import all_to_all, swept
from jaxcontact.scenes import paper_scene

TEST1_SIZES = (1, 9, 30, 99, 173, 250, 286)
TEST2_TRAVELS = tuple(0.5 * step for step in range(21))
PAPER_AVERAGE_S = {"bucket sort (paper)": 0.02, "all-to-all (paper)": 0.64}
METHODS = ("all_to_all", "bucket_sort (sized)", "swept", "bucket_swept (sized)")


def _detectors(scene, sizes):
    """name -> (jitted fn, args) for the four methods on ``scene``."""
    contact_sizes, path_sizes = sizes
    return {
        "all_to_all": (
            jax.jit(functools.partial(all_to_all, radius=scene.radius)),
            (scene.x, scene.surface),
        ),
        "bucket_sort (sized)": (
            _run.sized_contact(scene.radius, contact_sizes),
            (scene.x, scene.surface),
        ),
        "swept": (jax.jit(swept), (scene.x_prev, scene.x, scene.surface)),
        "bucket_swept (sized)": (
            _run.sized_crossing(path_sizes),
            (scene.x_prev, scene.x, scene.surface),
        ),
    }


def _sizes(scene):
    """``(contact sizes, path sizes)`` for ``scene``, measured on the host."""
    return (
        measure(scene.x, scene.surface, radius=scene.radius),
        measure(scene.x, scene.surface, x_prev=scene.x_prev),
    )


def _checks(scene, results) -> dict:
    """Method -> ``Mismatch`` (closest point) or a crossing count line (paths)."""
    x = np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    reference = answers.reference_contact(x, scene.surface, scene.radius)
    x_prev, x64, start64, end64 = (np.asarray(a, np.float64) for a in (scene.x_prev, x, start, end))
    crossing = baselines.brute_crossing(np, x_prev, x64, start64, end64)
    checks = {}
    for name, result in results.items():
        if name in ("all_to_all", "bucket_sort (sized)"):
            checks[name] = _run.check(result, x, start, end, reference)
        else:
            wrong = int(np.sum(np.asarray(result.segment) != crossing[0]))
            checks[name] = f"{int(crossing[2].sum()):,} crossed; {wrong:,} rows differ (float64)"
    return checks


def _rows(test, scene, position, timings, checks) -> list[dict]:
    """One row per method: its timing and its check against the float64 answer."""
    rows = []
    nodes, segments = scene.x.shape[0], scene.surface.segments.shape[0]
    for name in METHODS:
        check = checks[name]
        mismatch = check if isinstance(check, answers.Mismatch) else None
        note = answers.describe(check) if mismatch else check
        rows.append(
            _run.row(test, nodes, segments, name, timings[name], mismatch, position=position)
        )
        rows[-1].update(dtype="float32", note=note)
    return rows


def run_test1(sizes, repeats) -> list[dict]:
    rows = []
    for n in _run.progress(sizes, "paper Test 1"):
        scene = paper_scene(n, length=10.0, d=5.0)
        calls = _detectors(scene, _sizes(scene))
        timings = time_interleaved(calls, repeats=repeats)
        results = {name: fn(*args) for name, (fn, args) in calls.items()}
        rows += _rows("paper Test 1", scene, f"n={n}", timings, _checks(scene, results))
    return rows


def run_test2(n, travels, repeats) -> list[dict]:
    scenes = [paper_scene(n, length=20.0, d=d) for d in travels]
    contact_sizes, path_sizes = _sizes(scenes[0])
    for scene in scenes[1:]:
        contact_sizes = largest(contact_sizes, measure(scene.x, scene.surface, radius=scene.radius))
        path_sizes = largest(path_sizes, measure(scene.x, scene.surface, x_prev=scene.x_prev))
    sizes = (contact_sizes, path_sizes)
    # Compiled once for all positions: they share shapes and sizes.
    compiled, compile_s = {}, {}
    for name, (fn, args) in _detectors(scenes[0], sizes).items():
        compiled[name], compile_s[name] = compiled_call(fn, args)
    rows = []
    for d, scene in _run.progress(list(zip(travels, scenes, strict=True)), "paper Test 2"):
        calls = {
            name: (compiled[name], args) for name, (_, args) in _detectors(scene, sizes).items()
        }
        timings = time_interleaved(calls, repeats=repeats)
        timings = {name: t._replace(compile_s=compile_s[name]) for name, t in timings.items()}
        results = {name: fn(*args) for name, (fn, args) in calls.items()}
        rows += _rows("paper Test 2", scene, f"d={d:g}", timings, _checks(scene, results))
    return rows


def averages(rows) -> str:
    """Markdown: each method's mean of its medians over each test, beside the paper's averages."""
    lines = [
        "| method | Test 1 mean (ms) | Test 2 mean (ms) | paper's average (Matlab, i5-2430M) |",
        "|---|---:|---:|---:|",
    ]
    # The paper detects by paths crossing the tool and by closest points both; its
    # averages stand beside the dense and the binned methods of either kind.
    dense, binned = "640 ms (all-to-all)", "20 ms (bucket sort)"
    paper = dict(zip(METHODS, (dense, binned, dense, binned), strict=True))
    for name in METHODS:
        means = []
        for test in ("paper Test 1", "paper Test 2"):
            medians = [r["median_ms"] for r in rows if (r["scene"], r["method"]) == (test, name)]
            means.append(f"{np.mean(medians):.3f}" if medians else "—")
        lines.append(f"| {name} | {means[0]} | {means[1]} | {paper[name]} |")
    return "\n".join(lines)


def plot(rows, out) -> list[str]:
    """Fig. 8 (time against nodes, log axes) and Fig. 9 (time against travel) as PNGs; one
    look per method (``benchmarks.harness.style``), the legend right of the data."""
    plt = _run.pyplot(out)
    if plt is None:
        return []
    from benchmarks.harness import style

    paths = []
    for test, xlabel, figure_name in (
        ("paper Test 1", "workpiece nodes", "paper_test1.png"),
        ("paper Test 2", "tool travel d (mm)", "paper_test2.png"),
    ):
        chosen = [r for r in rows if r["scene"] == test]
        if not chosen:
            continue
        figure, axes = plt.subplots(figsize=(8.5, 4.5), layout="constrained")
        used = {}
        for name in dict.fromkeys(r["method"] for r in chosen):  # METHODS, as run
            mine = [r for r in chosen if r["method"] == name]
            if test == "paper Test 1":
                xs = [r["nodes"] for r in mine]
            else:
                xs = [float(r["position"][2:]) for r in mine]
            ys = [r["median_ms"] / 1e3 for r in mine]
            axes.plot(xs, ys, **style.style(name, used), label=f"jaxcontact {name}")
        for label, seconds in PAPER_AVERAGE_S.items():
            looks = style.style(label, used, kind="guide")
            axes.axhline(seconds, **looks, label=f"{label}: {seconds} s avg")
        if test == "paper Test 1":
            axes.set_xscale("log")
        else:
            # Travels from 0: the first points clear of the spine, no negative tick.
            axes.set_xlim(left=-0.015 * max(xs))
        axes.set_yscale("log")
        axes.set(xlabel=xlabel, ylabel="run time per call (s), compile apart", title=test)
        axes.grid(True, which="major", alpha=0.3)
        style.legend_outside(axes)
        paths.append(os.path.join(out, figure_name))
        figure.savefig(paths[-1], dpi=120)
        plt.close(figure)
    return paths


def run(quick: bool, out: str, repeats: int | None = None) -> str:
    """Runs both tests, writes CSV/markdown/PNGs into ``out``; returns the markdown."""
    repeats = repeats or (5 if quick else 20)
    sizes = (9, 30) if quick else TEST1_SIZES
    rows = run_test1(sizes, repeats)
    n2, travels = (30, TEST2_TRAVELS[::10]) if quick else (250, TEST2_TRAVELS)
    rows += run_test2(n2, travels, repeats)
    pictures = plot(rows, out)
    columns = ("scene", "position", "nodes", "method", "compile_s", "median_ms", "p10_ms")
    body = [
        averages(rows),
        "",
        _run.markdown(rows, (*columns, "p90_ms", "note")),
    ]
    note = f"float32, jit, median of {repeats} interleaved runs."
    text = _run.section("paper_tests", "Paper tests (Figs. 8 and 9)", quick, note, body, pictures)
    _run.write(out, "paper_tests", rows, text)
    return text


def main(argv=None) -> int:
    return _run.main(run, __doc__.splitlines()[0], argv)
