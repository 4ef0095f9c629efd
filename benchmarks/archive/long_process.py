"""Memory maps in a long process: what each compiled program costs, and how many are compiled.

XLA's CPU backend maps about three memory regions (code, read-only data,
data) into the process for every kernel of every program it compiles, and
keeps them until ``jax.clear_caches()``. Linux refuses a process more than
``vm.max_map_count`` maps (65,530 by default); XLA's compiler then crashes.
This script counts the lines of ``/proc/self/maps`` in one process:

1. **Maps per program**: each detector compiled at several exact shapes
   (``jax.jit`` of the detector: the caller's own program, at the caller's
   shape), the new maps per compile.
2. **A sweep of plain calls**: ``--shapes`` calls of each detector on
   scenes of as many distinct slave counts (between ``--smallest`` and
   ``--largest``, log-spaced), one process; programs compiled (the
   detector's jit caches) and maps added, in total and per call. Plain calls
   pad to size classes (``jaxcontact._pipeline.padding``), so most shapes reuse a
   program. Each sweep starts after ``jax.clear_caches()``, which frees the
   maps of the sweep before (so the script itself stays under the limit).

The scenes are the cutting scene (docs/scenes.md) at the requested node
count, tool tip at ``x = 18``, float32 (20 segments: no cells) and, for the
binned path, the rough die with 60 segments.

    python benchmarks/long_process.py                  # 300 shapes per detector
    python benchmarks/long_process.py --quick          # 40 shapes
    python benchmarks/long_process.py --out DIR        # also writes DIR/long_process.md
"""

from __future__ import annotations

import argparse
import os
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness._run import machine
from benchmarks.harness.internals import exhaustive, sized_jit
from jaxcontact import all_to_all, bucket_sort, bucket_swept, swept
from jaxcontact.scenes import cutting_scene, rough_die_scene


def maps() -> int:
    with open("/proc/self/maps") as lines:
        return sum(1 for _ in lines)


def limit() -> str:
    try:
        with open("/proc/sys/vm/max_map_count") as value:
            return value.read().strip()
    except OSError:
        return "unknown"


def detectors():
    """(name, call(scene), the jitted programs a plain call compiles)."""

    def closest(detect):
        return lambda scene: detect(scene.x, scene.surface, radius=scene.radius)

    def crossing(detect):
        # Every slave moves 0.05 down: paths of the same length in every scene.
        return lambda scene: detect(scene.x + np.float32([0.0, 0.05]), scene.x, scene.surface)

    return [
        # Both queries share one program per driver: each count is of both.
        ("all_to_all", closest(all_to_all), (exhaustive,)),
        ("bucket_sort", closest(bucket_sort), (sized_jit,)),
        ("swept", crossing(swept), (exhaustive,)),
        ("bucket_swept", crossing(bucket_swept), (sized_jit,)),
    ]


def scene_at(num_nodes: int, binned: bool):
    if binned:
        return rough_die_scene(num_nodes, 60)
    return cutting_scene(num_nodes, 18.0)


def per_program(num_shapes: int) -> list[str]:
    """Rows: maps each exact-shape compile adds, per detector (median, range)."""
    rows = []
    for name, call, _ in detectors():
        for binned in (False, True):
            jax.clear_caches()
            added = []
            for num_nodes in np.linspace(2_000, 3_000, num_shapes).astype(int):
                scene = scene_at(int(num_nodes), binned)
                before = maps()
                if name.startswith("bucket"):
                    # The one-call form measures on the host: compile the sized
                    # program at this exact shape, as a Search would.
                    jax.block_until_ready(call(scene))
                else:
                    jax.block_until_ready(jax.jit(call)(scene))
                added.append(maps() - before)
            kind = "rough die, 60 segments (cells)" if binned else "cutting, 20 segments"
            rows.append(
                f"| {name} | {kind} | {int(np.median(added))} | {min(added)}-{max(added)} |"
            )
    return rows


def sweep(num_shapes: int, smallest: int, largest: int) -> list[str]:
    """Rows: one detector's plain calls at ``num_shapes`` distinct slave counts."""
    counts = np.unique(np.geomspace(smallest, largest, num_shapes).astype(int))
    rows = []
    for name, call, programs in detectors():
        for binned in (False, True):
            # Each sweep starts from empty caches, as a fresh process would.
            jax.clear_caches()
            before_programs = sum(program._cache_size() for program in programs)
            before = maps()
            for num_nodes in counts:
                jax.block_until_ready(call(scene_at(int(num_nodes), binned)))
            compiled = sum(program._cache_size() for program in programs) - before_programs
            added = maps() - before
            kind = "rough die (cells)" if binned else "cutting"
            rows.append(
                f"| {name} | {kind} | {len(counts)} | {compiled} | {added:,} | "
                f"{added / len(counts):.0f} |"
            )
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="40 shapes, a smoke test")
    parser.add_argument("--shapes", type=int, default=None, help="slave counts per sweep")
    parser.add_argument("--smallest", type=int, default=200)
    parser.add_argument("--largest", type=int, default=20_000)
    parser.add_argument("--out", default=None, help="folder: write long_process.md there")
    args = parser.parse_args(argv)
    if not os.path.exists("/proc/self/maps"):
        print("no /proc/self/maps on this system: nothing to count", file=sys.stderr)
        return 0
    num_shapes = args.shapes or (40 if args.quick else 300)
    command = "python benchmarks/long_process.py" + " --quick" * args.quick
    lines = [
        f"`{command}`; {machine()}; jax {jax.__version__}; float32; "
        f"vm.max_map_count = {limit()}; maps at start: {maps():,}.",
        "",
        "Maps one compiled program adds (the detector under `jax.jit` at 5 exact shapes "
        "between 2,000 and 3,000 nodes; the bucket sorts' one-call form compiles its "
        "sized program at each):",
        "",
        "| detector | scene | maps per program (median) | range |",
        "|---|---|---:|---:|",
        *per_program(5),
        "",
        f"Plain calls at distinct slave counts, log-spaced from {args.smallest:,} to "
        f"{args.largest:,}, one process (each call pads to its size class):",
        "",
        "| detector | scene | distinct shapes | programs compiled | maps added | per call |",
        "|---|---|---:|---:|---:|---:|",
        *sweep(num_shapes, args.smallest, args.largest),
        "",
        f"Maps at the end: {maps():,}.",
    ]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "long_process.md"), "w") as file:
            file.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
