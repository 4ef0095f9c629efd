"""Issue 25's targets 1 and 2, scene by scene: ``Search.closest`` beside the numba grid.

    python benchmarks/targets.py                                            # both cores
    taskset -c 0 python benchmarks/targets.py --out benchmarks/results/pinned
    python benchmarks/targets.py --quick --out /tmp/targets                 # a smoke test

On every reference scene (float32, ``docs/scenes.md``; ``jax_enable_x64`` off, as a float32
simulation runs) one process times, round-robin (``jaxcontact._timing.time_interleaved``:
compiled ahead, its compile time apart, two warm-up runs, then ``--repeats`` rounds, 40 by
default, every call ended by ``block_until_ready``; median and 10th-90th percentile):

- ``Search.closest`` as a simulation step calls it, jitted, its state allocated on the scene
  (``Search(radius).allocate``), in both result forms, the dense ``Contact`` and the compact
  ``ContactList``:
  - **whole search** (``skin=0``): every call runs the broad and the narrow phase with the
    allocated sizes. This is the like-for-like comparison with the numba grid, which bins
    and searches at every call;
  - **reused state** (``skin = radius / 2``, every call on the allocation's positions): the
    skin check, then the narrow phase on the candidates kept since ``allocate``. It is a
    simulation's step while nothing has moved a skin.
- on an accelerator, where the cell search runs in tiles (``narrow.tiled``), the whole search
  with the cell lists searched in chunks instead, the CPU's design, as its baseline
  (``CHUNKED``; scenes with cells only);
- the hand-written numba grid (``benchmarks.peer_codes.numba_grid``) on one thread, and on
  two (``prange``) unless the process is pinned to one core. It is built and searched on
  every call; it compiles once per dtype (a note gives the time).

Before anything runs, glibc's allocator is set to keep freed pages (``_run.reuse_pages``):
with its start values each call's large buffers are mapped afresh, at up to 4x the call's
time for the dense form at 10^6 nodes and 5x for the numba grid on the chip's outline at
10^5, depending on what ran before in the process (the archive's ``malloc.py``, commit
``5928bf7f76cc``).

The first table: each method's time, the numba grid's (one thread) median over it (1 or more
meets target 1: at least as fast), and its answer's check. The second, each ``Search`` step's
compiled program (``benchmarks.harness.program``): the trace, lowering and XLA compile
(target 2: at most 1 s), the kernels XLA's CPU runtime runs per call, the largest trip count
of its sequential (``while``) loops ("unknown" where XLA does not know it; a dash: no loop),
and the bytes XLA's cost analysis says one call accesses (a loop body once) beside the least
any program moves (its inputs' and outputs' bytes).

Checks: every ``Search`` answer is compared with the whole-search dense form's (``segment``
and ``found``, row for row, the compact form through ``to_contact``): "equal", or the rows
that differ and how close their gaps are (on the rough die at 10^6 x 10^5 the compact form
picked the other segment at a vertex for 1 slave, the two gaps equal to 2e-9 in float32: the
two programs round the pair distance in differently fused loops). The numba grid's answer
equals it on ``found`` and ``segment`` but for exact vertex ties (its rule is the lower
index). On the self-contact scene (``scenes.curling_chip``: every node of the chip's outline
is a slave, ``Pairs(slave_node, self_contact=True)``) the numba grid applies the same rule
(``numba_grid.closest(pairs=...)``: no segment through the slave's own node, none within four
radii of it along its outline, the arc lengths computed at every call as its grid is), and its
answer is compared like the others.
"""

from __future__ import annotations

import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run, program, report
from benchmarks.harness.timing import compiled_call, time_interleaved
from benchmarks.peer_codes import baselines
from jaxcontact import Pairs, Search
from jaxcontact._pipeline import narrow
from jaxcontact.scenes import curling_chip, cutting_scene, rough_die_scene

FULL = (
    ("cutting, tool in", 10_000, 18.0),
    ("cutting, tool in", 81_939, 18.0),
    ("cutting, tool clear", 81_939, 20.5),
    ("cutting, tool in", 1_000_000, 18.0),
    ("rough die", 10_000, 1_000),
    ("rough die", 100_000, 10_000),
    ("rough die", 1_000_000, 100_000),
    ("chip outline, self-contact", 10_000, None),
    ("chip outline, self-contact", 100_000, None),
)
QUICK = (
    ("cutting, tool in", 10_000, 18.0),
    ("rough die", 10_000, 1_000),
    ("chip outline, self-contact", 10_000, None),
)
# FULL without the rough die at 10^6 x 10^5: the scenes of the archive's threads.py and
# malloc.py (commit 5928bf7f76cc).
WITHOUT_LARGEST_DIE = tuple(s for s in FULL if not (s[0] == "rough die" and s[1] > 10**5))
WHOLE = "Search.closest (whole search)"
WHOLE_COMPACT = "Search.closest (compact, whole search)"
REUSED = "Search.closest (reused state)"
REUSED_COMPACT = "Search.closest (compact, reused state)"
SEARCHES = (WHOLE, WHOLE_COMPACT, REUSED, REUSED_COMPACT)
# On an accelerator, where the cell search runs in tiles: the whole search with the cell
# lists searched in chunks instead (``narrow.tiled``), the design the CPU keeps.
CHUNKED = "Search.closest (whole search, cell lists in chunks)"
NUMBA = "numba grid (1 thread)"
NUMBA2 = "numba grid (prange, 2 threads)"
PEERS = (NUMBA, NUMBA2)
TARGET_COMPILE_S = 1.0  # issue 25's target 2
TIME_COLUMNS = ("scene", "method", "median ms", "p10 ms", "p90 ms", "numba / this", "check")
PROGRAM_COLUMNS = (
    "scene",
    "method",
    "compile s",
    "kernels",
    "loop trips",
    "accessed MiB",
    "in + out MiB",
    "accessed / (in + out)",
)


def build(kind: str, size: int, parameter):
    """``(x, surface, radius, pair)``: the scene, and the pair rule's keywords (or {})."""
    if kind.startswith("chip"):
        scene = curling_chip(size)
        pair = {"pairs": Pairs(scene.slave_node, self_contact=True)}
        return scene.x, scene.surface, scene.radius, pair
    scene = (
        rough_die_scene(size, parameter) if kind == "rough die" else cutting_scene(size, parameter)
    )
    return scene.x, scene.surface, scene.radius, {}


def label(kind: str, size: int, parameter) -> str:
    """A scene's name in the tables: its kind, nodes, and a rough die's segments."""
    return f"{kind}, {size:,} nodes" + (f" x {parameter:,}" if kind == "rough die" else "")


def step(search: Search, x, surface, pair):
    """``(jitted step, args)``: ``search.closest`` on its own allocation at ``x``;
    ``pair`` (the pair rule's keywords, or {}) goes in as a traced argument."""
    state = search.allocate(x, surface, **pair)

    def closest(state, x, surface, pair):
        return search.closest(state, x, surface, **pair)[0]

    return jax.jit(closest), (state, x, surface, pair)


def search_steps(x, surface, radius, pair) -> dict:
    """``{name: (jitted step, args)}`` of the four ``SEARCHES``."""
    forms = {
        WHOLE: (0.0, False),
        WHOLE_COMPACT: (0.0, True),
        REUSED: (radius / 2, False),
        REUSED_COMPACT: (radius / 2, True),
    }
    return {
        name: step(Search(radius=radius, skin=skin, compact=compact), x, surface, pair)
        for name, (skin, compact) in forms.items()
    }


def whole_search_steps(x, surface, radius, pair) -> dict:
    """``{"dense" | "compact": (jitted step, args)}``: the whole search (``skin=0``) in both
    result forms (the archive's ``threads.py`` and ``malloc.py`` timed them; commit
    ``5928bf7f76cc``)."""
    steps = search_steps(x, surface, radius, pair)
    return {"dense": steps[WHOLE], "compact": steps[WHOLE_COMPACT]}


def numba_closest(x, surface, radius, threads: int = 1, pair=None):
    """The numba grid's closest query on ``threads``: ``_run.numba_peer``'s
    ``(fn, args)``, or why it cannot run (a str). ``pair``: the scene's pair-rule keywords
    ({} or None for none), given to the numba grid as its own rule."""
    start, end = _run.endpoints(surface)
    rule = None
    if pair:
        pairs = pair["pairs"]
        segments = np.asarray(surface.segments)
        nodes = len(np.asarray(surface.nodes))
        rule = (np.asarray(pairs.slave_node), segments, nodes, pairs.self_contact)
    args = (np.asarray(x), start, end)
    return _run.numba_peer("closest", threads, x.dtype, args, radius=radius, pairs=rule)


def _rows(result, num_rows: int):
    """``(segment, found, gap)`` as NumPy arrays of N rows, from either result form."""
    if hasattr(result, "to_contact"):
        result = result.to_contact(num_rows)
    return np.asarray(result.segment), np.asarray(result.found), np.asarray(result.gap)


def search_check(rows, reference) -> str:
    """A ``Search`` form's rows against the whole-search dense form's: "equal", or
    how many found slaves differ and by how much their gaps do (float32 picks
    either of two segments whose distances agree to rounding, at a vertex)."""
    segment, found, gap = rows
    other = found & reference[1] & (segment != reference[0])
    missed, false = int(np.sum(reference[1] & ~found)), int(np.sum(found & ~reference[1]))
    if missed == false == int(np.sum(other)) == 0:
        return "equal"
    apart = float(np.max(np.abs(gap[other] - reference[2][other]), initial=0))
    return (
        f"DIFFERS: missed {missed}, false {false}, other segment {int(np.sum(other))} "
        f"(gaps within {apart:.1e})"
    )


def numba_check(got, reference) -> str:
    """The numba grid's ``(segment, gap, found)`` against the whole-search dense form's rows."""
    segment, found = np.asarray(got[0]), np.asarray(got[2])
    missed = int(np.sum(reference[1] & ~found))
    false = int(np.sum(found & ~reference[1]))
    other = int(np.sum(found & reference[1] & (segment != reference[0])))
    if missed == false == other == 0:
        return "equal"
    return f"missed {missed}, false {false}, other segment {other}"


def run_scene(kind: str, size: int, parameter, repeats: int, peers=None) -> dict:
    """One scene: ``{"rows": [one dict per method], "skipped": {peer: why not run}}``; the
    four ``SEARCHES`` and the ``peers`` (default ``PEERS``).

    Each ``Search`` step is compiled here, once: that compile is timed (``compile_s``),
    described (``program.describe``) and run, so no second compile meets JAX's caches.
    """
    x, surface, radius, pair = build(kind, size, parameter)
    calls, compile_s, shapes, skipped = {}, {}, {}, {}
    steps = search_steps(x, surface, radius, pair)
    if narrow.tiled() and steps[WHOLE][1][0].sizes["closest"].use_cells:
        steps[CHUNKED] = step(Search(radius=radius, skin=0.0), x, surface, pair)
    chosen = narrow.TILED
    for name, (jitted, args) in steps.items():
        narrow.TILED = False if name == CHUNKED else chosen
        if name == CHUNKED:
            jax.clear_caches()  # the inner jitted stages were traced with the tiles
        try:
            compiled, compile_s[name] = compiled_call(jitted, args)
        finally:
            narrow.TILED = chosen
            if name == CHUNKED:
                jax.clear_caches()
        shapes[name] = program.describe(compiled)
        calls[name] = (compiled, args)
    for name in PEERS if peers is None else peers:
        # The peers of peers.py: not installed, or more threads than cores allowed, a note.
        # The numba grid applies the scene's pair rule too.
        peer = baselines.unavailable(name) or numba_closest(
            x, surface, radius, 2 if name == NUMBA2 else 1, pair
        )
        if isinstance(peer, str):
            skipped[name] = peer
            continue
        calls[name] = peer
        compile_s[name] = peer[0].compile_s
    timings = time_interleaved(calls, repeats=repeats)
    reference = _rows(calls[WHOLE][0](*calls[WHOLE][1]), len(x))
    numba = timings.get(NUMBA)
    rows = []
    for name, timing in timings.items():
        fn, args = calls[name]
        if name in shapes:
            check = search_check(_rows(fn(*args), len(x)), reference)
        else:
            check = numba_check(fn(*args), reference)
        shape = shapes.get(name)
        rows.append(
            {
                "scene": label(kind, size, parameter),
                "method": name,
                "median_ms": timing.median_s * 1e3,
                "p10_ms": timing.p10_s * 1e3,
                "p90_ms": timing.p90_s * 1e3,
                "runs": timing.runs,
                "numba_over_this": numba.median_s / timing.median_s if numba else None,
                "compile_s": compile_s[name],
                "check": check,
                **(_program_fields(shape) if shape else {}),
            }
        )
    fastest = min(timings[name].median_s for name in SEARCHES)
    print(
        f"{label(kind, size, parameter)}: fastest Search form {fastest * 1e3:.3f} ms"
        + (f", numba grid {numba.median_s * 1e3:.3f} ms" if numba else ""),
        file=sys.stderr,
        flush=True,
    )
    return {"rows": rows, "skipped": skipped}


STAGE_COLUMNS = (
    "scene",
    "kept slaves",
    "with a list",
    "cull ms",
    "binning ms",
    "pairs (chunks)",
    "chunks ms",
    "ns / pair (chunks)",
    "pairs (tiles)",
    "tiles ms",
    "ns / pair (tiles)",
    "numba grid ms",
)


def stage_row(kind: str, size: int, parameter, repeats: int) -> dict | None:
    """Where the whole search's time goes on a scene with cells, stage by stage (the reason
    for target 1's misses): the cull with the kept rows, the binning of the segments into
    cell lists, and the narrow phase both ways, the chunks (the CPU's) and the tiles (an
    accelerator's), each its own jitted program at the scene's allocated sizes, timed
    interleaved with the numba grid's whole query. Pairs: those each narrow phase scores
    (the chunks: every kept slave's list, as long as it is; the tiles: every tile's list to
    the cell capacity, for its 8 slots). The plain closest kernel (no pair rule), so the
    chip's rows are a bound for its ruled search. None on a scene without cells."""
    from benchmarks.harness import internals

    x, surface, radius, pair = build(kind, size, parameter)
    sizes = Search(radius=radius).allocate(x, surface, **pair).sizes["closest"]
    if not sizes.use_cells:
        return None
    reach = jax.numpy.asarray(radius, x.dtype)

    @jax.jit
    def cull(x, surface):
        found = internals.resolve_segments(surface)
        boxes, blocks = internals.broad_phase(
            x, x, None, found, reach, sizes.block_size, sizes.block_capacity
        )
        (kept,), ok = internals.kept_rows(blocks, None, x)
        return found, boxes, kept, ok

    found, boxes, kept, ok = cull(x, surface)

    @jax.jit
    def binning(kept, ok, found, boxes):
        return internals.list_candidates(kept, ok, found, boxes, sizes)[0]

    listed = binning(kept, ok, found, boxes)
    kernel = internals.ruled(internals.CLOSEST.kernel, None)
    chunks = jax.jit(lambda *a: internals.search_listed(kernel, (a[0], None), *a[1:], sizes))
    tiles = jax.jit(lambda *a: internals.search_tiles(kernel, (a[0], None), *a[1:], sizes)[0])
    numba = numba_closest(x, surface, radius)
    calls = {
        "cull": (cull, (x, surface)),
        "binning": (binning, (kept, ok, found, boxes)),
        "chunks": (chunks, (kept, found, listed)),
        "tiles": (tiles, (kept, found, listed)),
    }
    if not isinstance(numba, str):
        calls[NUMBA] = numba
    timings = time_interleaved(calls, repeats=repeats)
    count = np.minimum(np.asarray(listed.count), sizes.cell_capacity)
    tile_pairs = sizes.tile_capacity * sizes.cell_capacity * 8

    def ms(name):
        return timings[name].median_s * 1e3 if name in timings else None

    return {
        "scene": label(kind, size, parameter),
        "kept slaves": int(np.sum(np.asarray(ok))),
        "with a list": int(np.sum(count > 0)),
        "cull ms": ms("cull"),
        "binning ms": ms("binning"),
        "pairs (chunks)": int(count.sum()),
        "chunks ms": ms("chunks"),
        "ns / pair (chunks)": ms("chunks") * 1e6 / max(int(count.sum()), 1),
        "pairs (tiles)": tile_pairs,
        "tiles ms": ms("tiles"),
        "ns / pair (tiles)": ms("tiles") * 1e6 / tile_pairs,
        "numba grid ms": ms(NUMBA),
    }


def _program_fields(shape: program.Shape) -> dict:
    return {
        "kernels": shape.kernels,
        "kinds": shape.kinds,
        "loops": list(shape.loops),
        "loop_trips": program.largest_trip(shape.loops),
        "bytes_accessed": shape.bytes_accessed,
        "minimum_bytes": shape.minimum_bytes,
    }


def _mib(count) -> float | None:
    return None if count is None else count / 2**20


def tables(rows: list[dict]) -> list[dict]:
    """The record's two tables: every method's time and check; each ``Search`` step's
    compiled program."""
    timed = [
        [
            row["scene"],
            row["method"],
            row["median_ms"],
            row["p10_ms"],
            row["p90_ms"],
            row["numba_over_this"],
            row["check"],
        ]
        for row in rows
    ]
    programs = [
        [
            row["scene"],
            row["method"],
            row["compile_s"],
            row["kernels"],
            row["loop_trips"],
            _mib(row["bytes_accessed"]),
            _mib(row["minimum_bytes"]),
            None if row["bytes_accessed"] is None else row["bytes_accessed"] / row["minimum_bytes"],
        ]
        for row in rows
        if row["method"] in (*SEARCHES, CHUNKED)
    ]
    return [
        report.table(
            TIME_COLUMNS,
            timed,
            title="Time per call (float32)",
            note="numba / this: the numba grid's (1 thread) median over the row's; 1 or more "
            "meets target 1. check: against the whole-search dense form's rows.",
        ),
        report.table(
            PROGRAM_COLUMNS,
            programs,
            title="The compiled Search.closest steps",
            note=f"compile s: trace, lowering and XLA compile (target 2: at most "
            f"{TARGET_COMPILE_S:g} s). kernels: thunks run per call. loop trips: the largest "
            "trip count of its while loops (unknown: XLA does not know it; a dash: no loop). "
            "accessed: XLA's cost analysis of one call (a loop's body counted once); in + out: "
            "its inputs' and outputs' bytes, the least any program moves.",
        ),
    ]


def stage_tables(stages) -> list[dict]:
    """The stage table (``stage_row``), where stages were measured (on the CPU)."""
    if not stages:
        return []
    note = (
        "Each stage its own jitted program at the scene's sizes, the plain closest kernel; "
        "medians of interleaved runs with the numba grid's whole query (1 thread). pairs: "
        "those each narrow phase scores; ns / pair: its time over them."
    )
    title = "Where the whole search's time goes, on the scenes with cells"
    return [report.table(STAGE_COLUMNS, stages, title=title, note=note)]


def run(args) -> dict:
    repeats = args.repeats or (10 if args.quick else 40)
    scenes = QUICK if args.quick else FULL
    x64 = jax.config.jax_enable_x64
    # A float32 simulation runs with x64 off: indices and weak scalars 32-bit, its programs.
    jax.config.update("jax_enable_x64", False)
    rows, skipped, stages = [], {}, []
    try:
        for done, scene in enumerate(scenes, 1):
            found = run_scene(*scene, repeats)
            rows += found["rows"]
            skipped |= found["skipped"]
            if not narrow.tiled():
                stages += [row for row in [stage_row(*scene, repeats)] if row]
            if done < len(scenes):
                partial = f"{done} of {len(scenes)}"
                _run.keep_partial("targets", args, _found(rows, skipped, repeats, partial, stages))
    finally:
        jax.config.update("jax_enable_x64", x64)
    return _found(rows, skipped, repeats, stages=stages)


def _found(rows, skipped, repeats, partial=None, stages=()) -> dict:
    notes = [
        f"float32; median of {repeats} interleaved rounds after 2 warm-up runs, compile apart."
    ]
    # numba compiles on its first scene only; later scenes' compile_s is about 0.
    first = {}
    for row in rows:
        if row["method"] in (NUMBA, NUMBA2):
            first.setdefault(row["method"], row)
    if first:
        compiled = ", ".join(f"{r['compile_s']:.2f} s ({name})" for name, r in first.items())
        notes.append(f"The numba grid compiles once per dtype and thread count: {compiled}.")
    notes += [f"{name}: {why}." for name, why in skipped.items()]
    if partial:
        notes.insert(0, f"Partial: {partial} scenes.")
    return {
        "title": "Search.closest beside the numba grid, scene by scene (issue 25's targets)",
        "tables": tables(rows) + stage_tables(stages),
        "data": {"rows": rows, "target_compile_s": TARGET_COMPILE_S, "stages": list(stages)},
        "notes": notes,
    }


def draw(record, plt):
    """Three panels, one row per scene: each method's median (p10-p90 bars), each ``Search``
    step's compile time (target 2 dotted), and its bytes accessed over its inputs' and
    outputs' bytes."""
    from matplotlib.ticker import LogLocator, NullFormatter

    from benchmarks.harness import style

    rows = record["data"]["rows"]
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    figure, (timed, compiled, moved) = plt.subplots(
        1, 3, figsize=(14, 2.0 + 0.55 * len(scenes)), sharey=True
    )
    used, offset = {}, np.linspace(-0.3, 0.3, len(methods))
    for shift, method in zip(offset, methods, strict=True):
        looks = style.style(method, used)
        mine = {r["scene"]: r for r in rows if r["method"] == method}
        at = [scenes.index(s) + shift for s in mine]
        median = [r["median_ms"] for r in mine.values()]
        spread = [
            [r["median_ms"] - r["p10_ms"] for r in mine.values()],
            [r["p90_ms"] - r["median_ms"] for r in mine.values()],
        ]
        timed.errorbar(median, at, xerr=spread, **{**looks, "linestyle": "none"}, label=method)
        if method in (*SEARCHES, CHUNKED):
            compile_s = [r["compile_s"] for r in mine.values()]
            compiled.plot(compile_s, at, **{**looks, "linestyle": "none"})
            ratio = [
                r["bytes_accessed"] / r["minimum_bytes"] if r["bytes_accessed"] else np.nan
                for r in mine.values()
            ]
            moved.plot(ratio, at, **{**looks, "linestyle": "none"})
    compiled.axvline(record["data"]["target_compile_s"], color="#7f7f7f", linestyle=":")
    timed.set(xscale="log", xlabel="median per call (ms)", title="time per call (bars: p10-p90)")
    compiled.set(xlabel="compile (s)", title="Search steps: compile (dotted: target)")
    compiled.set_xlim(left=0)
    moved.set(
        xscale="log",
        xlabel="XLA bytes accessed / (inputs + outputs)",
        title="Search steps: bytes accessed",
    )
    for axis in (timed.xaxis, moved.xaxis):
        # Labelled plainly: 1, 2 and 5 in each decade on a short span, decades alone on a
        # long one (the times span five), so that no two labels run into each other.
        low, high = axis.axes.get_xlim()
        subs = (1,) if high / low > 300 else (1, 2, 5)
        axis.set_major_locator(LogLocator(subs=subs))
        style.plain_log_labels(axis)
        axis.set_minor_formatter(NullFormatter())
    timed.set_yticks(range(len(scenes)), [s.replace(", ", ",\n", 1) for s in scenes], fontsize=8)
    timed.set_ylim(len(scenes) - 0.5, -0.5)
    for axes in (timed, compiled, moved):
        axes.grid(True, axis="x", which="both", alpha=0.3)
        for between in range(1, len(scenes)):
            axes.axhline(between - 0.5, color="#dddddd", linewidth=0.8)
    style.legend_outside(moved, "right", panels=[timed])
    return figure


if __name__ == "__main__":
    sys.exit(_run.suite("targets", run, draw, __doc__.splitlines()[0]))
