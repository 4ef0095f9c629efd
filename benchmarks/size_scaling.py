"""Run time, memory and compile time against problem size, on the rough die (issue 15).

The rough-die scene (docs/scenes.md: the die ``y = 0.1 sin(2 pi x)`` cut into
M equal steps over ``[0, 20]``, a grid of N slaves over ``[0, 20] x [-0.25,
0.25]``, radius 0.02), float32, in two sweeps that meet at (10^5, 10^4):

- against N: N = 10^3, 3 10^3, 10^4, ..., 10^6 slaves at M = 10^4 segments;
- against M: M = 10^2, 3 10^2, 10^3, ..., 10^5 segments at N = 10^5 slaves.

N is the grid's own count for the target (``nx * ny``, within a few per cent
of it); every slope uses the counts the scenes have. On each scene, in one
process, each method is compiled, its first answer checked, then all are
timed round-robin (``benchmarks.harness._run.run_methods``, as ``peers.py``:
median and 10th-90th percentile, every call ended by ``block_until_ready``;
20 rounds up to 10^5 slaves, 5 above; ``--repeats`` for all):

- ``bucket_sort (sized)``: the bucket sort with its ``Sizes`` measured once
  outside the timer (``jaxcontact._pipeline.sizes.measure``) and its whole search,
  broad phase included, inside (``_run.sized_contact``);
- ``Search.closest (reused state)``: ``Search(radius=0.02, skin=0.01)``
  allocated at ``x`` and called on that same ``x``, so the skin rule holds
  and the candidates are kept; the state goes in and out of the jitted step,
  as in a simulation (``benchmarks/search_step.py``'s (b));
- the same two with the compact result (``compact=True``: a ``ContactList``
  of the found contacts, its capacity measured outside the timer);
- ``all_to_all``: only where ``N * M <= 2 10^8`` pairs (10 ns a pair on one
  core of this project's machine: 2 s a call at most); elsewhere its row
  says "not run";
- ``numba grid (1 thread)``: the hand-written grid of
  ``benchmarks.peer_codes.numba_grid``, the fastest CPU peer of ``peers.py``
  (cell edge half the median segment length plus the radius, rebuilt every
  call), when numba imports.

What is measured, and why:

- **time**, and its **slope**: the least-squares slope of log(median)
  against log N (or log M) over every point of the sweep, and over its last
  decade (the points within a factor 10 of the largest), where the fixed
  costs weigh least and the algorithm's order shows: 1 for ``all_to_all`` in
  N and in M; for a grid, 1 in N, and in M 0 while the slaves' work
  dominates, rising to 1 once the cells, which cannot shrink below the
  radius, hold more segments in proportion to M.
- **memory**: XLA's own account of each compiled program
  (``compiled.memory_analysis()``): temporaries plus outputs, what one call
  allocates beyond its arguments (``_run.memory_fields``). The Search
  step's state is an argument and an output. The numba grid is not an XLA
  program: it has no figure here.
- **compile time**: tracing, lowering and compiling each jitted program
  (``jax.jit(f).lower(...).compile()``), which happens once per shape and
  method: a new N, M or set of ``Sizes`` is a new program. Issue 15's target
  is at most 1 s per shape. numba compiles once per dtype, on the first
  scene (0 afterwards).
- **check**: each answer against ``all_to_all`` in float64 on the same
  float32 numbers (``benchmarks.harness.answers``); ``ties`` are a segment
  equally near as the reference's, not errors.

Nothing is capped: the full run takes 4 to 7 minutes on this project's 2
cores, depending on what else runs (its own time is in the record's notes).
Unpinned, a method's time depends on whether XLA gets the second core, which
other load on a 2-core machine decides; run it pinned too for slopes that
show the algorithm.

The record's tables: each method's slopes, then per scene each method's
median time, XLA memory (temporaries + outputs; against N), compile time and
answer; every row's full detail is in its ``data``. The figure: time against
N, time against M and memory against N, log-log.

    python benchmarks/size_scaling.py
    taskset -c 0 python benchmarks/size_scaling.py --out benchmarks/results/pinned
    python benchmarks/size_scaling.py --quick --out /tmp/scaling  # N <= 10^4: a smoke test
"""

from __future__ import annotations

import functools
import pathlib
import sys
import time
from typing import NamedTuple

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run, answers, report
from benchmarks.harness.internals import measure, measure_contacts
from benchmarks.peer_codes import baselines
from jaxcontact import Search, all_to_all
from jaxcontact.scenes import rough_die_scene

LIBRARY = "bucket_sort (sized)"
COMPACT = "bucket_sort (sized, compact)"
SEARCH = "Search.closest (reused state)"
COMPACT_SEARCH = "Search.closest (compact, reused state)"
DENSE = "all_to_all"
NUMBA = "numba grid (1 thread)"
METHODS = (LIBRARY, COMPACT, SEARCH, COMPACT_SEARCH, DENSE, NUMBA)
SKIN = 0.01  # benchmarks/search_step.py's skin on the rough die: half the radius
PAIR_BUDGET = 2e8  # all_to_all's slave-segment pairs per call, at most
TARGET_COMPILE_S = 1.0  # issue 15: compile time per shape


class Sweeps(NamedTuple):
    """The two sweeps: N at a fixed M, and M at a fixed N (targets: scene arguments)."""

    nodes: tuple  # N of the sweep against N
    nodes_at: int  # ... at this M
    segments: tuple  # M of the sweep against M
    segments_at: int  # ... at this N

    def against_nodes(self) -> list[tuple[int, int]]:
        return [(n, self.nodes_at) for n in self.nodes]

    def against_segments(self) -> list[tuple[int, int]]:
        return [(self.segments_at, m) for m in self.segments]

    def scenes(self) -> list[tuple[int, int]]:
        """Every ``(N, M)`` of either sweep, once: a scene both share is run once."""
        return list(dict.fromkeys(self.against_nodes() + self.against_segments()))


def _half_decades(low: int, high: int) -> tuple:
    """``low, 3 low, 10 low, ...`` up to ``high``: 1 and 3 in each decade."""
    sizes = []
    while low <= high:
        sizes += [low, 3 * low] if 3 * low <= high else [low]
        low *= 10
    return tuple(sizes)


FULL = Sweeps(_half_decades(10**3, 10**6), 10**4, _half_decades(10**2, 10**5), 10**5)
QUICK = Sweeps((10**3, 10**4), 10**3, (10**2, 10**3), 10**4)


def methods(scene, names=METHODS) -> dict:
    """name -> ``(fn, args)``, or why it is not run on ``scene``: the methods ``names`` lists."""
    x, surface, radius = scene.x, scene.surface, scene.radius
    pairs = x.shape[0] * surface.segments.shape[0]

    def sized(compact=False):
        sizes = measure(x, surface, radius=radius)
        if compact:
            sizes = measure_contacts(x, surface, radius, None, sizes, slack=1.5)
        return _run.sized_contact(radius, sizes), (x, surface)

    def reused(compact=False):
        search = Search(radius=radius, skin=SKIN, compact=compact)
        return jax.jit(search.closest), (search.allocate(x, surface), x, surface)

    def dense():
        if pairs > PAIR_BUDGET:
            return f"not run: N*M too large ({pairs:.1e} pairs > {PAIR_BUDGET:.0e})"
        return jax.jit(functools.partial(all_to_all, radius=radius)), (x, surface)

    def numba():
        start, end = _run.endpoints(surface)
        prepare = baselines.PEERS[NUMBA][1]
        return baselines.unavailable(NUMBA) or prepare(np.asarray(x), start, end, radius)

    built = {LIBRARY: sized, SEARCH: reused, DENSE: dense, NUMBA: numba}
    built |= {COMPACT: lambda: sized(True), COMPACT_SEARCH: lambda: reused(True)}
    return {name: built[name]() for name in names}


def run_scene(num_nodes, num_segments, repeats, slow_s, names=METHODS) -> list[dict]:
    """The methods ``names`` lists (``LIBRARY`` among them) on one rough die; one row each."""
    scene = rough_die_scene(num_nodes, num_segments)
    x = np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    reference = answers.reference_contact(x, scene.surface, scene.radius)

    def check(result):
        fields = _run.reference_fields(result, x, start, end, reference)
        state = result[-1]
        if hasattr(state, "rebuilds"):  # the Search step's state: were the candidates kept?
            fields["rebuilds"] = int(state.rebuilds)
            if fields["rebuilds"]:
                fields["note"] += f"; candidates found again {fields['rebuilds']} times"
        return fields

    rows = _run.run_methods(
        methods(scene, names),
        check,
        repeats=repeats,
        slow_s=slow_s,
        library=LIBRARY,
        scene="rough die",
        nodes=len(x),
        segments=len(start),
        dtype=str(x.dtype),
    )
    return [{**clean(row), "scene_key": [num_nodes, num_segments]} for row in rows]


# ``_run``'s row fields that it formats as text, numbers in a record.
_NUMBERS = ("ratio", "max_gap_error", "wrong_by")


def clean(row: dict) -> dict:
    """A ``_run`` row as JSON scalars: empty fields (not run, no XLA program) None, the
    fields ``_run`` formats as text numbers again."""
    row = {key: None if value == "" else value for key, value in row.items()}
    return {**row, **{key: float(row[key]) for key in _NUMBERS if row.get(key) is not None}}


def slope(sizes, times) -> float | None:
    """Least-squares slope of log ``times`` against log ``sizes`` (None below two points).

    Example:
      >>> round(slope([10, 100, 1000], [2.0, 20.0, 200.0]), 6)
      1.0
    """
    if len(sizes) < 2:
        return None
    return float(np.polyfit(np.log(sizes), np.log(times), 1)[0])


def time_ms(row) -> float | None:
    """A row's median time in ms; None where the method was not run."""
    return row["median_ms"]


def memory_mib(row) -> float | None:
    """A row's XLA temporaries + outputs in MiB; None where there is no XLA program."""
    return None if row["temp_mib"] is None else row["temp_mib"] + row["out_mib"]


def points(rows, method, axis: str, value=time_ms) -> tuple[list, list]:
    """``(sizes, values)`` of ``method``'s rows that have a ``value``; ``axis``: ``"nodes"``
    or ``"segments"``."""
    found = [(r[axis], value(r)) for r in rows if r["method"] == method]
    # Sorted by size: the scene both sweeps share comes in the other sweep's order.
    found = sorted((size, number) for size, number in found if number is not None)
    return [size for size, _ in found], [number for _, number in found]


def slopes(rows, method, axis: str, value=time_ms) -> tuple[float | None, float | None]:
    """``method``'s slope over every point of a sweep, and over its last decade."""
    sizes, values = points(rows, method, axis, value)
    top = [i for i, size in enumerate(sizes) if size * 10 >= max(sizes)]
    last = slope([sizes[i] for i in top], [values[i] for i in top])
    return slope(sizes, values), last


def sweep_rows(rows, sweeps: Sweeps) -> tuple[list, list]:
    """``(against N, against M)``: ``rows`` of each sweep's scenes, in the sweep's order."""
    order = {tuple(key): at for at, key in enumerate(sweeps.scenes())}
    rows = sorted(rows, key=lambda r: order[tuple(r["scene_key"])])
    against_n = {tuple(key) for key in sweeps.against_nodes()}
    against_m = {tuple(key) for key in sweeps.against_segments()}
    return (
        [r for r in rows if tuple(r["scene_key"]) in against_n],
        [r for r in rows if tuple(r["scene_key"]) in against_m],
    )


def slope_table(against_n, against_m, names, sweeps: Sweeps) -> dict:
    """One row per method: its time's slopes in N and in M, over all points and the last
    decade, the points each used, and its memory's slope in N over the last decade."""
    rows = []
    for name in names:
        in_n, in_m = slopes(against_n, name, "nodes"), slopes(against_m, name, "segments")
        count_n = len(points(against_n, name, "nodes")[0])
        count_m = len(points(against_m, name, "segments")[0])
        held = slopes(against_n, name, "nodes", memory_mib)[1]
        rows.append([name, *in_n, *in_m, count_n, count_m, held])
    columns = [
        "method",
        "time in N: all points",
        "last decade",
        "time in M: all points",
        "last decade",
        "points in N",
        "points in M",
        "memory in N: last decade",
    ]
    note = (
        f"Least-squares slope of log(median time) against log N (M = {sweeps.nodes_at:,}) "
        f"and against log M (N = {sweeps.segments_at:,}), over every point run and over the "
        "last decade of each sweep (the points within a factor 10 of its largest); and of "
        "log(XLA temporaries + outputs) against log N over its last decade."
    )
    return report.table(columns, rows, title="Slopes", note=note)


def scene_table(rows, names, value, title, note=None) -> dict:
    """One row per scene (N, M), one column per method, each cell ``value(row)``."""
    by_scene = {}
    for row in rows:
        by_scene.setdefault(tuple(row["scene_key"]), {})[row["method"]] = row
    cells = []
    for mine in by_scene.values():
        first = next(iter(mine.values()))
        cells.append(
            [first["nodes"], first["segments"]]
            + [value(mine[name]) if name in mine else None for name in names]
        )
    return report.table(["N", "M", *names], cells, title=title, note=note)


def answer(row) -> str:
    """A row's answer against the float64 reference, in words (``answers.describe``)."""
    return "not run" if row["median_ms"] is None else row["note"]


def tables(rows, sweeps: Sweeps, names) -> list[dict]:
    against_n, against_m = sweep_rows(rows, sweeps)
    return [
        slope_table(against_n, against_m, names, sweeps),
        scene_table(
            rows,
            names,
            time_ms,
            "Median time (ms)",
            f"A dash: not run ({DENSE} where N x M is over {PAIR_BUDGET:.0e} pairs).",
        ),
        scene_table(
            against_n,
            names,
            memory_mib,
            f"Memory against N (MiB; M = {sweeps.nodes_at:,})",
            "XLA's account of each compiled program (compiled.memory_analysis()): "
            "temporaries + outputs, what one call allocates beyond its arguments. The numba "
            "grid is not an XLA program.",
        ),
        scene_table(
            rows,
            names,
            lambda row: row["compile_s"],
            "Compile time per shape (s)",
            f"Trace, lower and compile (issue 15's target: at most {TARGET_COMPILE_S:g} s). "
            "numba compiles once per dtype, in the first scene.",
        ),
        scene_table(
            rows,
            names,
            answer,
            "Answers against all_to_all in float64",
            "ties: a segment exactly as near as the reference's, not an error.",
        ),
    ]


def run(args) -> dict:
    """Runs both sweeps; the record's title, tables, figure data and notes."""
    began = time.perf_counter()
    sweeps = QUICK if args.quick else FULL
    slow_s = args.slow or (3.0 if args.quick else 30.0)
    rows, scenes = [], sweeps.scenes()
    for done, (num_nodes, num_segments) in enumerate(_run.progress(scenes, "size scaling"), 1):
        count = args.repeats or (5 if args.quick else (20 if num_nodes <= 10**5 else 5))
        rows += run_scene(num_nodes, num_segments, count, slow_s)
        if done < len(scenes):
            # Every scene's rows kept as soon as they are measured, so a run stopped part way
            # (a lent GPU's time ran out on one: 11 of 13 scenes in 330 s) leaves them behind.
            _run.keep_partial(
                "size_scaling",
                args,
                found(rows, sweeps, f"Partial: {done} of {len(scenes)} scenes."),
            )
    minutes = (time.perf_counter() - began) / 60
    return found(rows, sweeps, f"The whole run took {minutes:.1f} min.")


def found(rows, sweeps: Sweeps, note: str) -> dict:
    """``run``'s answer for ``rows`` (of ``sweeps``' scenes, or the first of them)."""
    kept = all(row.get("rebuilds") in (None, 0) for row in rows)
    notes = [
        f"Rough die, float32; medians of interleaved runs; nothing capped. {note}",
    ]
    if kept:
        notes.append("Every Search step kept its candidates (found again 0 times).")
    data = {"rows": rows, "sweeps": sweeps._asdict(), "methods": list(METHODS)}
    return {
        "title": "Size scaling: time, memory and compile time against N and M (rough die)",
        "tables": tables(rows, sweeps, METHODS),
        "data": data,
        "notes": notes,
    }


def draw(record, plt):
    """Time against N, time against M and memory against N, log-log, one line per method
    (one look per method: ``benchmarks.harness.style``), slope-1 guides; one legend."""
    from matplotlib.ticker import NullFormatter

    from benchmarks.harness import style

    data = record["data"]
    sweeps = Sweeps(
        **{key: tuple(v) if isinstance(v, list) else v for key, v in data["sweeps"].items()}
    )
    against_n, against_m = sweep_rows(data["rows"], sweeps)
    figure, (by_n, by_m, memory) = plt.subplots(1, 3, figsize=(15, 4.8))
    used = {}
    for name in data["methods"]:
        looks = style.style(name, used)
        for axes, rows, axis in ((by_n, against_n, "nodes"), (by_m, against_m, "segments")):
            sizes, times = points(rows, name, axis)
            if sizes:
                axes.plot(sizes, times, **looks, label=name)
        sizes, held = points(against_n, name, "nodes", memory_mib)
        if sizes:
            memory.plot(sizes, held, **looks, label=name)
    at_m, at_n = sweeps.nodes_at, sweeps.segments_at
    by_n.set(xlabel="slave nodes N", ylabel="median (ms)", title=f"time against N, M = {at_m:,}")
    by_m.set(xlabel="segments M", ylabel="median (ms)", title=f"time against M, N = {at_n:,}")
    memory.set(
        xlabel="slave nodes N",
        ylabel="XLA temporaries + outputs (MiB)",
        title=f"memory against N, M = {at_m:,}",
    )
    for axes in (by_n, by_m, memory):
        axes.set(xscale="log", yscale="log")
    guide = style.style("slope 1", used)
    for axes in (by_n, by_m):
        # A slope-1 guide through the middle of what is drawn, to read the slopes by eye.
        (low, high), (bottom, top) = axes.get_xlim(), axes.get_ylim()
        middle = np.sqrt(bottom * top / (low * high))
        axes.plot([low, high], [low * middle, high * middle], **guide, label="slope 1")
        axes.set_xlim(low, high)
        axes.set_ylim(bottom, top)
    for axes in (by_n, by_m, memory):
        axes.grid(True, which="both", alpha=0.3)
        style.plain_log_labels(axes.yaxis)
        style.plain_log_labels(axes.xaxis)
        axes.xaxis.set_minor_formatter(NullFormatter())  # sizes: decades are enough
    style.legend_outside(memory, "right")
    return figure


if __name__ == "__main__":
    options = ((("--slow",), {"type": float, "default": None, "help": "s: time slower ones once"}),)
    sys.exit(_run.suite("size_scaling", run, draw, __doc__.splitlines()[0], options=options))
