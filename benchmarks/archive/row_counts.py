"""Run time against the exact row count: eight consecutive slave counts.

XLA's CPU fusion emitters (its default code generator) ran the dense search
several times slower when the row count was not a multiple of the vector
width. ``jaxcontact._dense`` pads its rows to a multiple of
``ROW_MULTIPLE`` (8) inside the program; this script times each detector,
jitted as a user's program (``jax.jit``), at eight consecutive row counts,
with that padding (the library) and without it (``ROW_MULTIPLE = 1`` while
the program is traced), interleaved call by call, answers compared. (The
bucket sorts do not run the dense search: their two columns are the same
program, a check of the timing's noise.)

The scene is docs/scenes.md's cutting scene (tool tip at x = 18, previous tip
18.2; float32) cut to each row count; the bucket sorts run at sizes measured
on the scene, so that their rows can be compared with the dense ones.

    python benchmarks/row_counts.py            # 81,936 ... 81,943 rows
    python benchmarks/row_counts.py --quick    # 8,000 ... 8,007 rows, fewer repeats
"""

from __future__ import annotations

import argparse
import functools
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness._run import machine
from benchmarks.harness.internals import _dense, measure, sized_bucket_sort, sized_bucket_swept
from jaxcontact import all_to_all, swept
from jaxcontact.scenes import cutting_scene


def compiled(fn, args, row_multiple: int):
    """``jax.jit(fn)`` compiled for ``args`` with ``_dense.ROW_MULTIPLE`` set while tracing."""
    kept = _dense.ROW_MULTIPLE
    _dense.ROW_MULTIPLE = row_multiple
    jax.clear_caches()  # the dense program traced anew, not taken from the cache
    try:
        return jax.jit(fn).lower(*args).compile()
    finally:
        _dense.ROW_MULTIPLE = kept


def medians(executables, args, repeats: int, exact: int | None = None) -> list[float]:
    """Median seconds of each executable, called in turn; the answers of the
    first ``exact`` (all by default) must agree bit for bit."""
    answers = [jax.block_until_ready(executable(*args)) for executable in executables]
    for other in answers[1:exact]:
        for a, b in zip(jax.tree.leaves(answers[0]), jax.tree.leaves(other), strict=True):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    times = [[] for _ in executables]
    for _ in range(repeats):
        for executable, taken in zip(executables, times, strict=True):
            began = time.perf_counter()
            jax.block_until_ready(executable(*args))
            taken.append(time.perf_counter() - began)
    return [float(np.median(taken)) for taken in times]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="8,000 rows, fewer repeats")
    parser.add_argument("--repeats", type=int, default=None, help="timed calls per program")
    args = parser.parse_args(argv)
    first = 8_000 if args.quick else 81_936
    repeats = args.repeats or (5 if args.quick else 20)
    scene = cutting_scene(first + 100, 18.0, x_tip_prev=18.2)
    radius = scene.radius
    detectors = {
        "all_to_all": (lambda sizes: functools.partial(all_to_all, radius=radius), False),
        "swept": (lambda sizes: swept, True),
        "bucket_sort (sized)": (
            lambda sizes: functools.partial(sized_bucket_sort, radius=radius, sizes=sizes),
            False,
        ),
        "bucket_swept (sized)": (
            lambda sizes: functools.partial(sized_bucket_swept, sizes=sizes),
            True,
        ),
    }
    command = "python benchmarks/row_counts.py" + (" --quick" if args.quick else "")
    print(f"`{command}`; {machine()}; float32; median of {repeats} interleaved calls, in ms.")
    print("Cells: rows padded to a multiple of 8 (the library) / not padded.\n")
    counts = range(first, first + 8)
    print("| detector | " + " | ".join(f"{n:,}" for n in counts) + " |")
    print("|---|" + "---:|" * len(counts))
    for name, (make, paths) in detectors.items():
        cells = []
        for n in counts:
            x, x_prev = scene.x[:n], scene.x_prev[:n]
            fn_args = (x_prev, x, scene.surface) if paths else (x, scene.surface)
            if paths:
                fn = make(measure(x, scene.surface, x_prev=x_prev))
            else:
                fn = make(measure(x, scene.surface, radius=radius))
            both = [compiled(fn, fn_args, multiple) for multiple in (_dense.ROW_MULTIPLE, 1)]
            padded, unpadded = medians(both, fn_args, repeats)
            cells.append(f"{padded * 1e3:.2f} / {unpadded * 1e3:.2f}")
        print(f"| `{name}` | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
