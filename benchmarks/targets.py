"""Issue 25's targets 1 and 2, scene by scene: ``Search.closest`` beside the numba grid.

On every reference scene (float32, ``docs/scenes.md``) one process times,
round-robin (``benchmarks.harness.timing.time_interleaved``: compiled ahead,
its compile time apart, two warm-up runs, then ``--repeats`` rounds, every
call ended by ``block_until_ready``; median and 10th-90th percentile):

- ``Search.closest`` as a simulation step calls it, jitted, its state
  allocated on the scene (``Search(radius).allocate``), in both result
  forms, the dense ``Contact`` and the compact ``ContactList``:
  - **whole search** (``skin=0``): every call runs the broad and the narrow
    phase with the allocated sizes. This is the like-for-like comparison
    with the numba grid, which bins and searches at every call;
  - **candidates reused** (``skin = radius / 2``, every call on the
    allocation's positions): the skin check, then the narrow phase on the
    candidates kept since ``allocate``. It is a simulation's step while
    nothing has moved a skin.
- the hand-written numba grid (``benchmarks.peer_codes.numba_grid``) on one
  thread, and on two unless the process is pinned to one core. It is built
  and searched on every call.

Before anything runs, glibc's allocator is set to keep freed pages
(``_run.reuse_pages``): with its start values each call's large buffers are
mapped afresh, at up to 4x the call's time for the dense form at 10^6 nodes
and 5x for the numba grid on the chip's outline at 10^5, depending on what
ran before in the process (``benchmarks/archive/malloc.py``). Runs before 0.7.4
did not set it.

The ratio column is the numba grid's (one thread) median over each form's:
1 or more meets target 1 (at least as fast). The compile column is the
trace, lowering and XLA compile of the jitted step (target 2: at most 1 s),
and ``kernels`` the thunks XLA's CPU runtime runs per call
(``benchmarks/stages.py``'s count).

Checks: every ``Search`` answer is compared with the whole-search dense
form's (``segment`` and ``found``, row for row, the compact form through
``to_contact``): "equal", or the rows that differ and how close their gaps
are (on the rough die at 10^6 x 10^5 the compact form picked the other
segment at a vertex for 1 slave, the two gaps equal to
2e-9 in float32: the two programs round the pair distance in differently
fused loops). The numba grid's answer equals it on ``found`` and
``segment`` but for exact vertex ties (its rule is the lower index). On the
self-contact scene (``scenes.curling_chip``: every node of the chip's
outline is a slave, ``Pairs(slave_node, self_contact=True)``) the numba grid has no
pair rule: it answers the plain query over the same nodes and segments,
where every node finds its own segments, so its time is a lower bound for a
grid that applied the rule, and its answer is not compared.

    python benchmarks/targets.py --out benchmarks/results                  # both cores
    taskset -c 0 python benchmarks/targets.py --out benchmarks/results/pinned
    python benchmarks/targets.py --quick                                   # a smoke test
"""

from __future__ import annotations

import argparse
import os
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run
from benchmarks.harness.timing import time_interleaved
from jaxcontact import Pairs, Search
from jaxcontact.scenes import curling_chip, cutting_scene, rough_die_scene

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from stages import kernels  # noqa: E402

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
# FULL without the rough die at 10^6 x 10^5: benchmarks/archive/threads.py's and malloc.py's scenes.
WITHOUT_LARGEST_DIE = tuple(s for s in FULL if not (s[0] == "rough die" and s[1] > 10**5))
NUMBA = "numba grid (1 thread)"
NUMBA2 = "numba grid (2 threads)"


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


def step(search: Search, x, surface, pair):
    """``(jitted step, args)``: ``search.closest`` on its own allocation at ``x``;
    ``pair`` (the pair rule's keywords, or {}) goes in as a traced argument."""
    state = search.allocate(x, surface, **pair)

    def closest(state, x, surface, pair):
        return search.closest(state, x, surface, **pair)[0]

    return jax.jit(closest), (state, x, surface, pair)


def whole_search_steps(x, surface, radius, pair) -> dict:
    """``{"dense" | "compact": (jitted step, args)}``: the whole search (``skin=0``)
    in both result forms (``step``)."""
    return {
        "compact" if compact else "dense": step(
            Search(radius=radius, compact=compact), x, surface, pair
        )
        for compact in (False, True)
    }


def numba_closest(x, surface, radius, threads: int = 1):
    """The numba grid's closest query on ``threads``: ``_run.numba_peer``'s
    ``(fn, args)``, or why it cannot run (a str)."""
    start, end = _run.endpoints(surface)
    return _run.numba_peer("closest", threads, x.dtype, (np.asarray(x), start, end), radius=radius)


def _rows(result, num_rows: int):
    """``(segment, found, gap)`` as NumPy arrays of N rows, from either result form."""
    if hasattr(result, "to_contact"):
        result = result.to_contact(num_rows)
    return np.asarray(result.segment), np.asarray(result.found), np.asarray(result.gap)


def _search_check(rows, reference) -> str:
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


def run_scene(kind: str, size: int, parameter, repeats: int, threads: int) -> list[dict]:
    x, surface, radius, pair = build(kind, size, parameter)
    calls = {}
    for skin, how in ((0.0, "whole search"), (radius / 2, "candidates reused")):
        for compact in (False, True):
            search = Search(radius=radius, skin=skin, compact=compact)
            form = "compact" if compact else "dense"
            calls[f"Search.closest, {how}, {form}"] = step(search, x, surface, pair)
    for name, count in ((NUMBA, 1), (NUMBA2, 2)):
        if count > threads:
            continue
        peer = numba_closest(x, surface, radius, count)
        if isinstance(peer, str):
            print(f"{name}: {peer}", file=sys.stderr)
            continue
        calls[name] = peer
    # Timed first: its compile time is then a real compile, not the jit cache's.
    timings = time_interleaved(calls, repeats=repeats)
    reference = None
    checks = {}
    for name, (fn, args) in calls.items():
        if name.startswith("Search"):
            rows = _rows(fn(*args), len(x))
            if reference is None:
                reference = rows
            checks[name] = _search_check(rows, reference)
        elif pair:
            checks[name] = "plain query (no pair rule)"
        else:
            checks[name] = _numba_check(fn(*args), reference)
    best = min(
        (t.median_s for n, t in timings.items() if n.startswith("Search")),
        default=float("nan"),
    )
    numba = timings.get(NUMBA)
    label = f"{kind}, {size:,} nodes" + (f" x {parameter:,}" if kind == "rough die" else "")
    rows = []
    for name, timing in timings.items():
        fn, args = calls[name]
        rows.append(
            {
                "scene": label,
                "method": name,
                "median_ms": timing.median_s * 1e3,
                "p10_ms": timing.p10_s * 1e3,
                "p90_ms": timing.p90_s * 1e3,
                "compile_s": timing.compile_s,
                "kernels": kernels(fn, args) if name.startswith("Search") else "",
                "numba_over_this": numba.median_s / timing.median_s if numba else float("nan"),
                "check": checks[name],
            }
        )
    print(
        f"{label}: fastest Search form {best * 1e3:.3f} ms"
        + (f", numba grid {numba.median_s * 1e3:.3f} ms" if numba else ""),
        file=sys.stderr,
        flush=True,
    )
    return rows


def _numba_check(got, reference) -> str:
    """The numba grid's ``(segment, gap, found)`` against the whole-search dense form's rows."""
    segment, found = np.asarray(got[0]), np.asarray(got[2])
    missed = int(np.sum(reference[1] & ~found))
    false = int(np.sum(found & ~reference[1]))
    other = int(np.sum(found & reference[1] & (segment != reference[0])))
    if missed == false == other == 0:
        return "equal"
    return f"missed {missed}, false {false}, other segment {other}"


def table(rows: list[dict]) -> str:
    lines = [
        "| scene | method | median ms | p10-p90 ms | numba (1 thread) / this | compile s | kernels "
        "| check |",
        "|---|---|---:|---:|---:|---:|---:|---|",
    ]
    for row in rows:
        ratio = row["numba_over_this"]
        lines.append(
            f"| {row['scene']} | {row['method']} | {row['median_ms']:.3f} | "
            f"{row['p10_ms']:.3f}-{row['p90_ms']:.3f} | "
            f"{'' if ratio != ratio else f'{ratio:.2f}'} | {row['compile_s']:.2f} | "
            f"{row['kernels']} | {row['check']} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="three small scenes, 10 rounds")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--out", default=None, help="folder for targets.md")
    args = parser.parse_args()
    repeats = args.repeats or (10 if args.quick else 40)
    threads = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    scenes = QUICK if args.quick else FULL
    # Both jaxcontact and the numba grid at their best: buffers on reused pages
    # (benchmarks/archive/malloc.py), whatever ran before in this process.
    _run.reuse_pages()
    command = "python benchmarks/targets.py" + (" --quick" if args.quick else "")
    header = (
        f"`{command}`; {_run.machine()}; float32; median of {repeats} interleaved rounds "
        "after 2 warm-up runs, compile apart."
    )
    rows = []
    for done, (kind, size, parameter) in enumerate(scenes, 1):
        rows += run_scene(kind, size, parameter, repeats, threads)
        # Each scene's rows kept as they come (a lent GPU's time may run out).
        if args.out and done < len(scenes):
            partial = f"Partial: {done} of {len(scenes)} scenes."
            write(args.out, "\n".join([header, "", partial, "", table(rows), ""]))
    text = "\n".join([header, "", table(rows), ""])
    print(text)
    if args.out:
        write(args.out, text)


def write(out: str, text: str) -> None:
    path = pathlib.Path(out)
    path.mkdir(parents=True, exist_ok=True)
    (path / "targets.md").write_text(text)


if __name__ == "__main__":
    main()
