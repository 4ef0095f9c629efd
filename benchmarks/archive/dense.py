"""Benchmark of the dense detectors, ``all_to_all`` and ``swept``, against naive baselines.

Scenes (docs/scenes.md): the paper scene, Test 1 (face length 10, d = 5) at
n = 250 (63,001 nodes) and n = 286 (82,369 nodes), and the cutting scene at
81,939 nodes with the tool tip at x = 18 (``all_to_all`` only: nothing moves).
All in float32, on the CPU.

Each call is timed by ``benchmarks.harness.timing.time_call``: compilation apart, two
warm-up runs, then the median and p10/p90 of ``--repeats`` runs. In the same
process, the same textbook brute force answers the same query twice:

- with NumPy: every slave-segment pair at once in (N, M) arrays, ``argmin``
  over M;
- with JAX, jitted: the same code on ``jax.numpy``, so an (N, M) plane and
  ``jnp.argmin``. It shows what the library's running minimum over segments
  (O(N) memory, one fused pass over the slaves per segment) buys over the
  plane a first version would build.

Each baseline's answer is compared with the library's in the ``result``
column. They differ only where the closest point is a vertex shared by two
segments: the library gives the tie to the face the slave is outside of, the
brute force to whichever its rounding makes closer.

Usage:
  python benchmarks/dense.py                # the sizes above
  python benchmarks/dense.py --quick        # small sizes, a smoke test
  taskset -c 0 python benchmarks/dense.py   # pinned to one core
"""

from __future__ import annotations

import argparse
import functools
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness.timing import pinned_note, time_call
from benchmarks.peer_codes.baselines import brute_crossing
from benchmarks.peer_codes.baselines import dense_closest as brute_closest
from jaxcontact import all_to_all, swept
from jaxcontact.scenes import cutting_scene, paper_scene


def _disagreement(library, baseline) -> str:
    """How many rows differ between two ``(segment, value, flag)`` answers.

    Segments and flags must match exactly; values (a gap or a time) only where
    flagged, since elsewhere they mean nothing, and to float32 rounding, since
    the baselines compute them by another formula.
    """
    segment, value, flag = (np.asarray(part) for part in library)
    other_segment, other_value, other_flag = (np.asarray(part) for part in baseline)
    close = np.isclose(value, other_value, rtol=1e-5, atol=1e-5)
    count = int(np.sum((segment != other_segment) | (flag != other_flag) | (flag & ~close)))
    if count == 0:
        return "same answer"
    return f"{count:,} row differs" if count == 1 else f"{count:,} rows differ"


def _baselines(query, brute, library, args, repeats) -> list[tuple]:
    """Times ``brute`` jitted on JAX and on NumPy; ``(query, method, timing, result)`` rows."""
    plane = jax.jit(functools.partial(brute, jnp))
    timing = time_call(plane, *args, repeats=repeats)
    rows = [(query, "JAX (N, M) plane + argmin", timing, _disagreement(library, plane(*args)))]
    dense = functools.partial(brute, np)
    host_args = [np.asarray(arg) for arg in args]
    # Nothing compiles: the first call's time is no compile time.
    timing = time_call(dense, *host_args, repeats=repeats)._replace(compile_s=None)
    rows.append(
        (query, "NumPy dense brute force", timing, _disagreement(library, dense(*host_args)))
    )
    return rows


def bench_scene(scene, with_swept: bool, repeats: int) -> list[tuple]:
    """Times the library and the baselines on one scene; one row per (query, method)."""
    nodes = np.asarray(scene.surface.nodes)
    pairs = np.asarray(scene.surface.segments)
    start, end = jnp.asarray(nodes[pairs[:, 0]]), jnp.asarray(nodes[pairs[:, 1]])

    detect = jax.jit(functools.partial(all_to_all, radius=scene.radius))
    timing = time_call(detect, scene.x, scene.surface, repeats=repeats)
    contact = detect(scene.x, scene.surface)
    summary = f"found {int(contact.found.sum()):,}, active {int(contact.active.sum()):,}"
    rows = [("all_to_all", "jaxcontact (running min)", timing, summary)]
    closest = functools.partial(brute_closest, radius=np.float32(scene.radius))
    library = (contact.segment, contact.gap, contact.found)
    rows += _baselines("all_to_all", closest, library, (scene.x, start, end), repeats)

    if with_swept:
        sweep = jax.jit(swept)
        timing = time_call(sweep, scene.x_prev, scene.x, scene.surface, repeats=repeats)
        crossing = sweep(scene.x_prev, scene.x, scene.surface)
        summary = f"crossed {int(crossing.crossed.sum()):,}"
        rows.append(("swept", "jaxcontact (running min)", timing, summary))
        library = (crossing.segment, crossing.t, crossing.crossed)
        args = (scene.x_prev, scene.x, start, end)
        rows += _baselines("swept", brute_crossing, library, args, repeats)
    return rows


def _table(results: list[tuple]) -> str:
    """The markdown table; ``× library`` is a method's median over the library's."""
    lines = [
        "| scene | nodes N | segments M | query | method | compile (s) | median (ms) "
        "| p10–p90 (ms) | × library | result |",
        "|---|---:|---:|---|---|---:|---:|---:|---:|---|",
    ]
    library_median = {}
    for scene, n, m, query, method, timing, result in results:
        library_median.setdefault((scene, query), timing.median_s)
        compile_s = "—" if timing.compile_s is None else f"{timing.compile_s:.2f}"
        lines.append(
            f"| {scene} | {n:,} | {m} | {query} | {method} | {compile_s} "
            f"| {timing.median_s * 1e3:.2f} | {timing.p10_s * 1e3:.2f}–{timing.p90_s * 1e3:.2f} "
            f"| {timing.median_s / library_median[scene, query]:.1f} | {result} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, a smoke test")
    parser.add_argument("--repeats", type=int, default=20, help="timed runs per call (>= 10)")
    args = parser.parse_args()

    paper_sizes, cutting_nodes = ((30, 99), 5_000) if args.quick else ((250, 286), 81_939)
    scenes = [(f"paper, n={n}", paper_scene(n), True) for n in paper_sizes]
    scenes.append(("cutting, x_tip=18", cutting_scene(cutting_nodes, 18.0), False))
    results = []
    for name, scene, with_swept in scenes:
        size = (name, scene.x.shape[0], scene.surface.segments.shape[0])
        results += [(*size, *row) for row in bench_scene(scene, with_swept, args.repeats)]

    print(
        f"jax {jax.__version__}, numpy {np.__version__}, {jax.devices()[0].device_kind}, "
        f"float32; {pinned_note()}"
    )
    print(f"median of {args.repeats} runs after 2 warm-up runs\n")
    print(_table(results))


if __name__ == "__main__":
    main()
