"""The integer sorts of the cells and the tie rule, where their keys outgrow int32 (issue 25).

``_sort.stable_order`` sorts ``key * E + position`` (E keys) as one int32
array with no payload. Where that product does not fit in int32 it took
``jnp.argsort(stable=True)``, whose sort carries the positions as a second
operand; since 0.7.5 it sorts a digit at a time (a radix sort of one-operand
passes), and the cell binning sorts packed ``(cell, segment)`` pairs
(``_sort.sorted_pairs``), which fit where ``cell * E + position`` does not.

Keys come from the reference scenes themselves (float32, ``docs/scenes.md``),
computed as the searches compute them, with the sizes ``measure`` picks:

- cell entries: each segment's entry in each of the ``span`` cells around its
  radius-inflated box ("no cell" past its box), sorted by the cell's list
  (its number, or its hash where the sizes hash the cells; ``_cells.bin_segments``);
- node keys: each segment's end node (``_outline.vertex_neighbours`` sorts
  those of the real segments, as ``node + 1``, against ``num_nodes + 1`` values).

Each form is checked to give the stable argsort's order, then timed over 30
interleaved calls (``benchmarks.harness.timing.time_interleaved``); medians, ms.

    python benchmarks/sorts.py            # both cores
    taskset -c 0 python benchmarks/sorts.py
    python benchmarks/sorts.py --quick    # small scenes, 5 calls
"""

from __future__ import annotations

import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import _run
from benchmarks.harness.internals import (
    Grid,
    _inputs,
    cell_entries,
    measure,
    num_lists,
    packs,
    segment_boxes,
    sorted_pairs,
    stable_order,
)
from benchmarks.harness.timing import time_interleaved
from jaxcontact.scenes import curling_chip, rough_die_scene

SCENES = {
    "rough die, 10^5 x 10^4": lambda: rough_die_scene(10**5, 10**4),
    "rough die, 10^6 x 10^5": lambda: rough_die_scene(10**6, 10**5),
    "chip outline, 10^4": lambda: curling_chip(10**4),
    "chip outline, 10^5": lambda: curling_chip(10**5),
}
QUICK = {
    "rough die, 10^4 x 10^3": lambda: rough_die_scene(10**4, 10**3),
    "chip outline, 10^4": lambda: curling_chip(10**4),
}


def binned_entries(scene):
    """``(list i32[E], segment i32[E], lists)``: the binning's keys at ``measure``'s
    sizes (``_cells.cell_entries``: the cell's list is its number, or its hash
    where ``sizes.buckets``), the grid placed at the segments' boxes."""
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    segments = _inputs.resolve_segments(scene.surface)
    boxes = segment_boxes(segments, jnp.asarray(scene.radius, scene.x.dtype))
    origin = jnp.min(jnp.where(segments.ok[:, None], boxes.low, jnp.inf), axis=0)
    grid = Grid(origin, jnp.asarray(sizes.cell_size, scene.x.dtype))
    layout = (sizes.grid_shape, sizes.span, sizes.buckets)
    cell, segment, _ = cell_entries(boxes, segments.ok, grid, *layout)
    return np.asarray(cell), np.asarray(segment), num_lists(sizes.grid_shape, sizes.buckets) + 1


def node_keys(scene):
    """``(keys i32[M], values)``: each segment's end node plus one, as the tie rule sorts them."""
    ends = np.asarray(scene.surface.segments)[:, 1] + 1
    return ends.astype(np.int32), scene.surface.nodes.shape[0] + 1


def rows(name: str, scene, repeats: int) -> list[str]:
    out = []
    cell, segment, num_cells = binned_entries(scene)
    num_segments = int(segment.max()) + 1
    forms = {
        "argsort (stable)": lambda c, s: s[jnp.argsort(c, stable=True)],
        "stable_order": lambda c, s: s[stable_order(c, num_cells)],
    }
    if packs(num_cells, num_segments):
        forms["packed pairs"] = lambda c, s: sorted_pairs(c, s, num_segments, num_cells)
    out += _time(
        f"{name}: cell entries",
        (cell, segment),
        forms,
        f"{len(cell):,} entries, {num_cells:,} lists",
        repeats,
    )
    keys, values = node_keys(scene)
    forms = {
        "argsort (stable)": lambda k: jnp.argsort(k, stable=True).astype(jnp.int32),
        "stable_order": lambda k: stable_order(k, values),
    }
    out += _time(
        f"{name}: node keys", (keys,), forms, f"{len(keys):,} keys, {values:,} values", repeats
    )
    return out


def _time(what, arrays, forms, sizes, repeats):
    args = tuple(jnp.asarray(a) for a in arrays)
    jitted = {label: jax.jit(form) for label, form in forms.items()}
    want = np.asarray(jitted["argsort (stable)"](*args))
    for label, form in jitted.items():
        np.testing.assert_array_equal(np.asarray(form(*args)), want, err_msg=f"{what}: {label}")
    timings = time_interleaved(
        {label: (form, args) for label, form in jitted.items()}, repeats=repeats
    )
    base = timings["argsort (stable)"].median_s
    return [
        f"| {what} | {sizes} | {label} | {1e3 * t.median_s:.2f} | {t.median_s / base:.2f} |"
        for label, t in timings.items()
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small scenes, 5 calls")
    args = parser.parse_args()
    _run.reuse_pages()
    repeats = 5 if args.quick else 30
    print(f"{_run.machine()}; medians of {repeats} interleaved calls, ms")
    print()
    print("| keys | size | form | median ms | of argsort |")
    print("|---|---|---|---:|---:|")
    for name, build in (QUICK if args.quick else SCENES).items():
        for line in rows(name, build(), repeats):
            print(line, flush=True)


if __name__ == "__main__":
    main()
