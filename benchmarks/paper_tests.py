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

The figure's two panels (Fig. 8: time against nodes; Fig. 9: time against
travel) draw the paper's own averages (Matlab, Intel Core i5-2430M: bucket
sort 0.02 s, all-to-all 0.64 s) as reference lines. Writes
``<out>/paper_tests.json`` and ``<out>/paper_tests.png`` (default ``--out
benchmarks/results``) and prints the record's markdown.

    python benchmarks/paper_tests.py            # both tests at the paper's sizes
    python benchmarks/paper_tests.py --quick    # two small grids, three travels
    taskset -c 0 python benchmarks/paper_tests.py --out benchmarks/results/pinned
"""

from __future__ import annotations

import functools
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run, answers, report
from benchmarks.harness.internals import largest, measure
from benchmarks.harness.timing import compiled_call, time_interleaved
from benchmarks.peer_codes import baselines
from jaxcontact import all_to_all, swept
from jaxcontact.scenes import paper_scene

TEST1_SIZES = (1, 9, 30, 99, 173, 250, 286)
TEST2_TRAVELS = tuple(0.5 * step for step in range(21))
PAPER_AVERAGE_S = {"bucket sort (paper)": 0.02, "all-to-all (paper)": 0.64}
METHODS = ("all_to_all", "bucket_sort (sized)", "swept", "bucket_swept (sized)")
CLOSEST, CROSSING = METHODS[:2], METHODS[2:]
# The paper detects by paths crossing the tool and by closest points both; its averages stand
# beside the dense and the binned methods of either kind.
PAPER = dict(zip(METHODS, ("all-to-all (paper)", "bucket sort (paper)") * 2, strict=True))
TESTS = ("paper Test 1", "paper Test 2")


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
    """Method -> ``(wrong rows, what the check found)``: closest points against all_to_all in
    float64 (missed, false and wrong-segment rows are wrong; ties are not), paths against
    the float64 brute force (every row whose segment differs is wrong)."""
    x = np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    reference = answers.reference_contact(x, scene.surface, scene.radius)
    x_prev, x64, start64, end64 = (np.asarray(a, np.float64) for a in (scene.x_prev, x, start, end))
    crossing = baselines.brute_crossing(np, x_prev, x64, start64, end64)
    checks = {}
    for name, result in results.items():
        if name in CLOSEST:
            mismatch = _run.check(result, x, start, end, reference)
            wrong = mismatch.missed + mismatch.false + mismatch.wrong_segment
            checks[name] = (wrong, answers.describe(mismatch))
        else:
            wrong = int(np.sum(np.asarray(result.segment) != crossing[0]))
            checks[name] = (wrong, f"{int(crossing[2].sum()):,} crossed, {wrong:,} rows differ")
    return checks


def _rows(test, scene, position, timings, checks) -> list[dict]:
    """One row per method: its timing and its check against the float64 answer."""
    rows = []
    for name in METHODS:
        timing = timings[name]
        wrong, check = checks[name]
        rows.append(
            {
                "test": test,
                "position": position,
                "nodes": int(scene.x.shape[0]),
                "segments": int(scene.surface.segments.shape[0]),
                "method": name,
                "compile s": timing.compile_s,
                "median ms": timing.median_s * 1e3,
                "p10 ms": timing.p10_s * 1e3,
                "p90 ms": timing.p90_s * 1e3,
                "runs": timing.runs,
                "wrong": wrong,
                "check": check,
            }
        )
    return rows


def run_test1(sizes, repeats) -> list[dict]:
    rows = []
    for n in _run.progress(sizes, "paper Test 1"):
        scene = paper_scene(n, length=10.0, d=5.0)
        calls = _detectors(scene, _sizes(scene))
        timings = time_interleaved(calls, repeats=repeats)
        results = {name: fn(*args) for name, (fn, args) in calls.items()}
        rows += _rows(TESTS[0], scene, n, timings, _checks(scene, results))
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
        rows += _rows(TESTS[1], scene, d, timings, _checks(scene, results))
    return rows


def _column(method) -> str:
    return f"{method} ms"


def _check_cell(cells, methods) -> str:
    """One cell for ``methods``' checks at one position: the one text when they agree."""
    texts = {cells[m]["check"] for m in methods}
    if len(texts) == 1:
        return texts.pop()
    return "; ".join(f"{m}: {cells[m]['check']}" for m in methods)


def position_table(rows, test, position, title, note) -> dict:
    """One row per position of ``test``: each method's median, the checks of both kinds."""
    columns = [position, *(() if test == TESTS[1] else ("nodes",))]
    columns += [_column(m) for m in METHODS] + ["closest points", "paths"]
    table_rows = []
    for at in dict.fromkeys(r["position"] for r in rows if r["test"] == test):
        cells = {r["method"]: r for r in rows if (r["test"], r["position"]) == (test, at)}
        entry = {position: at, "nodes": cells[METHODS[0]]["nodes"]}
        entry.update({_column(m): cells[m]["median ms"] for m in METHODS})
        entry["closest points"] = _check_cell(cells, CLOSEST)
        entry["paths"] = _check_cell(cells, CROSSING)
        table_rows.append(entry)
    return report.table(columns, table_rows, title=title, note=note)


def means_table(rows) -> dict:
    """Each method's mean of its medians over each test, beside the paper's averages."""
    table_rows = []
    for name in METHODS:
        means = []
        for test in TESTS:
            medians = [r["median ms"] for r in rows if (r["test"], r["method"]) == (test, name)]
            means.append(float(np.mean(medians)) if medians else None)
        paper = PAPER[name]
        method = paper.removesuffix(" (paper)")
        table_rows.append([name, *means, PAPER_AVERAGE_S[paper] * 1e3, method])
    columns = ["method", "Test 1 mean ms", "Test 2 mean ms", "paper's average ms", "paper's method"]
    note = (
        "The paper's averages: Matlab on an Intel Core i5-2430M, over its tests; it reports one "
        "bucket-sort and one all-to-all average, set here beside the closest-point and the "
        "path-crossing forms of each."
    )
    return report.table(columns, table_rows, title="Means over each test", note=note)


def verdict(rows) -> str:
    """The checks in one line: every answer agrees with its float64 reference, or which not."""
    wrong = [r for r in rows if r["wrong"]]
    if not wrong:
        return (
            f"All {len(rows)} answers (each method at each position) agree with their float64 "
            "reference (closest points: all_to_all in float64; paths: a float64 NumPy brute "
            "force)."
        )
    listed = "; ".join(
        f"{r['test']} at {r['position']:g}, {r['method']}: {r['check']}" for r in wrong
    )
    return f"**{len(wrong)} answers differ from their float64 reference**: {listed}."


def run(args) -> dict:
    """Both tests; ``--quick``: grids of 9 and 30, Test 2 at 30 with three travels."""
    repeats = args.repeats or (5 if args.quick else 20)
    sizes = (9, 30) if args.quick else TEST1_SIZES
    rows = run_test1(sizes, repeats)
    n2, travels = (30, TEST2_TRAVELS[::10]) if args.quick else (250, TEST2_TRAVELS)
    rows += run_test2(n2, travels, repeats)
    medians = f"Medians of {repeats} interleaved runs (float32, jit), compile time apart"
    checks = (
        "closest points checked against all_to_all in float64, paths against a float64 "
        "NumPy brute force."
    )
    nodes = rows[-1]["nodes"]
    tables = [
        means_table(rows),
        position_table(
            rows,
            TESTS[0],
            "n",
            "Test 1 (Fig. 8): the workpiece refined, n x n faces, d = 5",
            f"{medians}; {checks}",
        ),
        position_table(
            rows,
            TESTS[1],
            "d mm",
            f"Test 2 (Fig. 9): the tool moved, {nodes:,} nodes",
            f"{medians}, one compilation for every travel; {checks}",
        ),
    ]
    spread = ("test", "position", "method", "compile s", "p10 ms", "p90 ms", "runs")
    return {
        "title": "Paper tests (Figs. 8 and 9)",
        "tables": tables,
        "data": {
            "paper average s": PAPER_AVERAGE_S,
            "spread": [{key: r[key] for key in spread} for r in rows],
        },
        "notes": [verdict(rows)],
    }


def draw(record, plt):
    """Fig. 8 (time against nodes, log axes) and Fig. 9 (time against travel), each method's
    median and the paper's averages; one legend, right of the data."""
    from benchmarks.harness import style

    figure, (fig8, fig9) = plt.subplots(1, 2, figsize=(13, 4.8))
    used = {}
    averages = record["data"]["paper average s"]
    for axes, index, x_key in ((fig8, 1, "nodes"), (fig9, 2, "d mm")):
        found = record["tables"][index]
        rows = [dict(zip(found["columns"], row, strict=True)) for row in found["rows"]]
        xs = [r[x_key] for r in rows]
        for name in METHODS:
            ys = [r[_column(name)] / 1e3 for r in rows]
            axes.plot(xs, ys, **style.style(name, used), label=style.canonical(name))
        for label, seconds in averages.items():
            axes.axhline(seconds, **style.style(label, used, kind="guide"), label=label)
            axes.annotate(
                f"{seconds:g} s",
                (1.0, seconds),
                xycoords=("axes fraction", "data"),
                xytext=(-3, 3),
                textcoords="offset points",
                ha="right",
                fontsize=8,
                color="#404040",
            )
        axes.set_yscale("log")
        axes.set_ylabel("run time per call (s), compile apart")
        axes.grid(True, which="major", alpha=0.3)
    fig8.set(xscale="log", xlabel="workpiece nodes", title="Test 1 (Fig. 8): refined workpiece")
    fig9.set(xlabel="tool travel d (mm)", title="Test 2 (Fig. 9): moving tool")
    # Travels from 0: the first points clear of the spine, no negative tick.
    fig9.set_xlim(left=-0.015 * max(fig9.lines[0].get_xdata()))
    style.legend_outside(fig9)
    return figure


if __name__ == "__main__":
    sys.exit(_run.suite("paper_tests", run, draw, __doc__.splitlines()[0]))
