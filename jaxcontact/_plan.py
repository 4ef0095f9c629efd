"""Plans: the static sizes of a bucket sort, made on the host from concrete data.

As jax-md separates ``allocate`` (host, sizes from data) from ``update``
(jitted, fixed sizes), ``plan_buckets`` looks at one configuration and returns
a hashable ``BucketPlan``; ``bucket_sort`` and ``bucket_swept`` run under
``jit`` with it as a static argument. Every capacity is the measured need
times ``slack``, so the plan lasts while the scene changes by less than that;
past it, ``overflow`` turns True and ``replan`` makes a larger one. A new plan
means a new compilation.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact import _inputs
from jaxcontact._broad import Box, broad_phase, conservative_margin, enclosing, segment_boxes
from jaxcontact._cells import Grid, bin_segments
from jaxcontact._types import Array, Surface

# With this many segments or fewer, each kept slave meets every segment: a
# running minimum over M broadcast segments beats per-slave candidate gathers
# (benchmarks/bucket.py measures the crossover).
DENSE_LIMIT = 48


@dataclasses.dataclass(frozen=True)
class BucketPlan:
    """Static sizes of a bucket sort. Hashable: pass it to ``jit`` as a static argument.

    Attributes:
      num_slaves: N, the slave count the plan was made for.
      block_size: slaves culled together (consecutive rows).
      block_capacity: most blocks kept near the master.
      for_paths: made for ``bucket_swept`` (path boxes) rather than ``bucket_sort``.
      use_cells: bin the segments in cells; False tests each kept slave
        against every segment.
      grid_shape: cells in x and in y.
      cell_size: smallest cell edge; cells grow when the region outgrows the grid.
      span: most cells a segment's inflated box may cover, in x and in y.
      cell_capacity: most segments one cell may hold.
    """

    num_slaves: int
    block_size: int
    block_capacity: int
    for_paths: bool = False
    use_cells: bool = False
    grid_shape: tuple[int, int] = (1, 1)
    cell_size: float = 0.0
    span: tuple[int, int] = (1, 1)
    cell_capacity: int = 1

    @property
    def slave_capacity(self) -> int:
        """Slaves the narrow phase holds: ``block_capacity * block_size``."""
        return self.block_capacity * self.block_size


def _grow(count: float, slack: float, least: int = 1) -> int:
    return max(least, int(math.ceil(count * slack)))


class _Measured(NamedTuple):
    """What ``plan_buckets`` reads off a configuration (one compiled program)."""

    num_blocks: Array  # i32[]  blocks of slaves that meet the master's box
    rows: Array  # i32[B * block_size]  their rows, N past the end
    slave_ok: Array  # bool[N]
    query: Array  # f[N, 2]  the point whose cell is looked up
    reach: Array  # f[]  the segment boxes' inflation
    boxes: Box  # f[M, 2]  inflated segment boxes
    master: Box  # f[2]  around them
    segment_ok: Array  # bool[M]
    extents: Array  # f[M]  each segment's larger side


@functools.partial(jax.jit, static_argnames=("block_size", "num_blocks"))
def _measure(x_prev, x, surface, radius, mask, block_size: int, num_blocks: int) -> _Measured:
    # Jitted: run op by op, this took 5-7 s at every new shape (measured).
    segments = _inputs.resolve_segments(surface)
    if x_prev is not None:
        x_prev, x, slave_ok = _inputs.sanitize_paths(x_prev, x, mask)
        query_low, query_high, query = jnp.minimum(x_prev, x), jnp.maximum(x_prev, x), x_prev
        travel = jnp.max(jnp.where(slave_ok, jnp.max(jnp.abs(x - x_prev), axis=-1), 0), initial=0)
        cull_reach = jnp.zeros((), x.dtype)
    else:
        x, slave_ok = _inputs.sanitize_points(x, mask)
        query_low = query_high = query = x
        travel = cull_reach = radius
    _, blocks = broad_phase(
        query_low, query_high, slave_ok, segments, cull_reach, block_size, num_blocks
    )
    reach = conservative_margin(travel, segments.start, segments.end)
    boxes = segment_boxes(segments, reach)
    extents = jnp.max(jnp.abs(segments.end - segments.start), axis=-1)
    return _Measured(
        blocks.count, blocks.rows, slave_ok, query, reach, boxes, enclosing(boxes), segments.ok,
        extents,
    )  # fmt: skip


@functools.partial(jax.jit, static_argnames=("shape", "span"))
def _fullest_cell(boxes: Box, ok: Array, grid: Grid, shape, span) -> Array:
    """i32[]: the most segments in one cell."""
    bins = bin_segments(boxes, ok, grid, shape, span, ok.shape[0])
    return jnp.max(bins.count, initial=0)


def plan_buckets(
    x: Array,
    surface: Surface,
    *,
    radius=None,
    x_prev: Array | None = None,
    mask: Array | None = None,
    slack: float = 1.5,
    block_size: int = 64,
    use_cells: bool | None = None,
    cell_factor: float = 1.0,
    cell_size: float | None = None,
) -> BucketPlan:
    """Sizes a bucket sort for this configuration, with room to spare.

    Args:
      x: f[N, 2] concrete slave coordinates.
      surface: the concrete master.
      radius: the search radius (for ``bucket_sort``).
      x_prev: f[N, 2] previous positions; give it (and no radius) to plan
        ``bucket_swept``.
      mask: optional bool[N] slave mask.
      slack: every measured capacity is multiplied by this.
      block_size: slaves culled together; smaller blocks cull tighter but cost
        a longer block pass.
      use_cells: force cell binning on or off; by default on above
        ``DENSE_LIMIT`` segments.
      cell_factor: cell edge as a multiple of (twice the search distance plus
        the median segment extent).
      cell_size: the cell edge itself, instead of one chosen from the data
        (``plan_batch`` sizes every scene of a batch at one edge).

    Returns:
      A ``BucketPlan``.
    """
    if (radius is None) == (x_prev is None):
        raise ValueError(
            "plan_buckets needs radius= (for bucket_sort) or x_prev= (for bucket_swept)"
        )
    if slack < 1:
        raise ValueError(f"slack must be >= 1; got {slack}")
    if not cell_factor > 0:
        raise ValueError(f"cell_factor must be > 0; got {cell_factor}")
    if cell_size is not None and not (math.isfinite(cell_size) and cell_size > 0):
        raise ValueError(f"cell_size must be finite and > 0; got {cell_size}")
    if x_prev is not None:
        x_prev, x, mask = _inputs.check_path_inputs(x_prev, x, mask)
    else:
        x = _inputs.check_points("x", x)
        mask = _inputs.check_mask("mask", mask, x.shape[0])
        radius = _inputs.check_radius(radius, x.dtype)
    surface = _inputs.check_surface(surface, x.dtype)
    num_rows, num_segments = x.shape[0], surface.segments.shape[0]
    for_paths = x_prev is not None
    block_size = max(1, min(block_size, max(num_rows, 1)))
    num_blocks = -(-num_rows // block_size)
    if use_cells is None:
        use_cells = num_segments > DENSE_LIMIT
    # Plans of scenes with nothing to bin still say whether cells are used, so
    # that ``replan`` and ``plan_batch`` keep the choice when they grow them.
    if num_rows == 0 or num_segments == 0:
        return BucketPlan(num_rows, block_size, 1, for_paths, use_cells)
    found = _measure(x_prev, x, surface, radius, mask, block_size, num_blocks)
    block_capacity = min(num_blocks, _grow(int(found.num_blocks), slack))
    if not use_cells:
        return BucketPlan(num_rows, block_size, block_capacity, for_paths)

    # The cells: sized from what the narrow phase will see.
    kept = np.asarray(found.rows)
    kept = kept[kept < num_rows]
    kept = kept[np.asarray(found.slave_ok)[kept]]
    points = np.asarray(found.query)[kept]
    ok = np.asarray(found.segment_ok)
    if points.size == 0 or not ok.any():
        return BucketPlan(num_rows, block_size, block_capacity, for_paths, use_cells)
    low = np.maximum(np.asarray(found.master.low), points.min(axis=0))
    high = np.minimum(np.asarray(found.master.high), points.max(axis=0))
    extent = np.maximum(high - low, 0.0)
    lengths = np.asarray(found.extents)[ok]
    if cell_size is None:
        cell_size = cell_factor * (2 * float(found.reach) + float(np.median(lengths)))
        # Keep the grid O(slaves kept): no more cells than 4 per kept slave.
        most_cells = max(64, 4 * len(points))
        while np.prod(np.ceil(extent * slack / cell_size) + 1) > most_cells:
            cell_size *= 1.25
    grid_shape = tuple(int(v) for v in np.ceil(extent * slack / cell_size).astype(int) + 1)
    widths = (np.asarray(found.boxes.high) - np.asarray(found.boxes.low))[ok]
    span = tuple(int(math.ceil(w * slack / cell_size)) + 1 for w in widths.max(axis=0))
    grid = Grid(jnp.asarray(low, x.dtype), jnp.asarray(cell_size, x.dtype))
    most_per_cell = int(_fullest_cell(found.boxes, found.segment_ok, grid, grid_shape, span))
    return BucketPlan(
        num_slaves=num_rows,
        block_size=block_size,
        block_capacity=block_capacity,
        for_paths=for_paths,
        use_cells=True,
        grid_shape=grid_shape,
        cell_size=float(cell_size),
        span=span,
        cell_capacity=_grow(most_per_cell, slack),
    )


def replan(plan: BucketPlan, x: Array, surface: Surface, **kwargs) -> BucketPlan:
    """A plan for the current data that is nowhere smaller than ``plan``.

    Call it when a result's ``overflow`` is True, then detect again (the new
    plan compiles once). Keyword arguments are those of ``plan_buckets``.
    """
    kwargs = {"block_size": plan.block_size, "use_cells": plan.use_cells, **kwargs}
    fresh = plan_buckets(x, surface, **kwargs)
    fresh = dataclasses.replace(fresh, use_cells=fresh.use_cells or plan.use_cells)
    if fresh.cell_size == 0:  # nothing to bin now: keep the cells measured before
        fresh = dataclasses.replace(fresh, cell_size=plan.cell_size)
    if fresh.for_paths != plan.for_paths or not plan.use_cells:
        return dataclasses.replace(
            fresh, block_capacity=max(fresh.block_capacity, plan.block_capacity)
        )
    return dataclasses.replace(
        fresh,
        block_capacity=max(fresh.block_capacity, plan.block_capacity),
        grid_shape=tuple(map(max, fresh.grid_shape, plan.grid_shape)),
        span=tuple(map(max, fresh.span, plan.span)),
        cell_capacity=max(fresh.cell_capacity, plan.cell_capacity),
    )
