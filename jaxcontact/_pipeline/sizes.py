"""Sizes: the static capacities of a bucket sort, measured on the host from concrete data.

As jax-md separates ``allocate`` (host, sizes from data) from ``update``
(jitted, fixed sizes), ``measure`` looks at one configuration and returns
hashable ``Sizes``; ``Search.allocate`` keeps them in the search state as
static fields. Every capacity is the measured need times ``slack``, so the
sizes last while the scene changes by less than that; past it, ``overflow``
turns True and ``largest(old, measure(...))`` makes larger ones. New sizes
mean a new compilation.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact._pipeline import inputs as _inputs
from jaxcontact._pipeline import segments as _segments
from jaxcontact._pipeline.broad import (
    Box,
    broad_phase,
    conservative_margin,
    enclosing,
    segment_boxes,
)
from jaxcontact._pipeline.cells import Grid, bin_segments, cell_lists, cell_of, flat_cell
from jaxcontact._pipeline.placement import searched_whole
from jaxcontact._pipeline.tiles import tile
from jaxcontact._types import CELLS_ABOVE, CHUNK_ROWS, Array, Sizes, Surface


def size_class(count: int, smallest: int = 1) -> int:
    """The least ``m * 2**e >= count`` with ``m`` in [4, 8): at most 1/4 above.

    Four classes per doubling: a sweep over 200 to 20,000 rows meets 27.
    Counts up to 8 are their own class, below ``smallest`` it is ``smallest``,
    and ``0`` stays ``0`` (the empty scene).

    Example:
      >>> [size_class(n) for n in (0, 5, 16, 17, 100, 1000, 81_939)]
      [0, 5, 16, 20, 112, 1024, 98304]
    """
    if count <= 0:
        return 0
    count = max(count, smallest)
    shift = max(0, count.bit_length() - 3)
    return -(-count // (1 << shift)) << shift


def grow(count: float, slack: float, least: int = 1) -> int:
    """``count * slack`` rounded up to its size class (at most 1/4 more).

    Sizes are static, so each distinct value compiles a program of its own:
    rounded to classes, configurations that differ a little share one.
    """
    return size_class(max(least, int(math.ceil(count * slack))))


def _edge_class(edge: float) -> float:
    """``edge`` rounded up to a power of 2**(1/4): as ``grow``, for the cell edge."""
    return 2.0 ** (math.ceil(4 * math.log2(edge)) / 4)


class _Measured(NamedTuple):
    """What ``measure`` reads off a configuration (one compiled program)."""

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
@searched_whole(rows="x")
def _measure(x_prev, x, surface, radius, mask, block_size: int, num_blocks: int) -> _Measured:
    # Jitted: run op by op, this takes 5-7 s at every new shape (measured).
    segments = _segments.resolve_segments(surface)
    if x_prev is not None:
        x_prev, x, slave_ok = _segments.sanitize_paths(x_prev, x, mask)
        query_low, query_high, query = jnp.minimum(x_prev, x), jnp.maximum(x_prev, x), x_prev
        travel = jnp.max(jnp.where(slave_ok, jnp.max(jnp.abs(x - x_prev), axis=-1), 0), initial=0)
        cull_reach = jnp.zeros((), x.dtype)
    else:
        x, slave_ok = _segments.sanitize_points(x, mask)
        query_low = query_high = query = x
        travel = cull_reach = radius
    _, blocks = broad_phase(
        query_low, query_high, slave_ok, segments, cull_reach, block_size, num_blocks
    )
    reach = conservative_margin(travel, segments.start, segments.end)
    boxes = segment_boxes(segments, reach)
    extents = jnp.max(jnp.abs(segments.end - segments.start), axis=-1)
    return _Measured(
        num_blocks=blocks.count,
        rows=blocks.rows,
        slave_ok=slave_ok,
        query=query,
        reach=reach,
        boxes=boxes,
        master=enclosing(boxes),
        segment_ok=segments.ok,
        extents=extents,
    )


def _cells_for(extent, edge: float, num_kept: int, slack: float, chosen: bool):
    """``(edge, grid_shape, buckets)``: the cells of a region of ``extent``
    (f[2]) at cell edge ``edge`` (``chosen``: from the data, so it may be
    widened and is rounded to its class; else the caller's own)."""
    # Keep the lists O(slaves kept): no more than 4 per kept slave.
    most_cells = max(64, 4 * num_kept)
    buckets = 0
    if chosen:
        if np.prod(np.ceil(extent * slack / edge) + 1) > most_cells:
            # Too many cells of this edge: they share that many lists through
            # a hash (``cells.flat_cell``), and are made ``slack`` times
            # wider, so that a segment of the median extent spans at most two
            # per axis. Growing the cells instead until the grid fits gives
            # the curled chip's outline at 10^5 nodes cells 24 times its
            # radius, up to 192 segments in a cell (measured with the
            # repository's benchmarks/costs.py).
            edge *= slack
            buckets = size_class(most_cells)
        edge = _edge_class(edge)
    grid_shape = tuple(size_class(int(v)) for v in np.ceil(extent * slack / edge) + 1)
    if not buckets and np.prod(grid_shape) > most_cells:
        buckets = size_class(most_cells)
    return edge, grid_shape, buckets


@functools.partial(jax.jit, static_argnames=("shape", "span", "buckets"))
def _cell_load(boxes: Box, ok: Array, grid: Grid, points: Array, shape, span, buckets):
    """``(i32[] most segments in one cell's list, i32[] tiles the points need)``: the
    tiles as the tiled cell search groups them (``tiles.tile``)."""
    bins = bin_segments(boxes, ok, grid, shape, span, ok.shape[0], buckets)
    listed = cell_lists(flat_cell(cell_of(points, grid, shape), shape, buckets), bins)
    return jnp.max(bins.count, initial=0), tile(listed, ok.shape[0], 1).needed


def measure(
    x: Array,
    surface: Surface,
    *,
    radius=None,
    x_prev: Array | None = None,
    mask: Array | None = None,
    slack: float = 1.5,
    block_size: int = 64,
    use_cells: bool | None = None,
    cells_above: int = CELLS_ABOVE,
    cell_factor: float = 1.0,
    cell_size: float | None = None,
    chunk_rows: int = CHUNK_ROWS,
    layout: Sizes | None = None,
) -> Sizes:
    """Sizes a bucket sort for this configuration, with room to spare.

    Args:
      x: f[N, 2] concrete slave coordinates.
      surface: the concrete master.
      radius: the search radius (closest points).
      x_prev: f[N, 2] previous positions; give it (and no radius) to size
        the swept search.
      mask: optional bool[N] slave mask.
      slack: every measured capacity is multiplied by this.
      block_size: slaves culled together; smaller blocks cull tighter but cost
        a longer block pass.
      use_cells: force cell binning on or off; by default on above
        ``cells_above`` segments.
      cells_above: the segment count above which cells are used by default.
      cell_factor: cell edge as a multiple of (twice the search distance plus
        the median segment extent).
      cell_size: the cell edge itself, instead of one chosen from the data;
        a grid of more than four cells per kept slave then hashes them into
        lists at that edge (not widened).
      chunk_rows: kept slaves searched together.
      layout: sizes whose cells (edge, grid, buckets) to keep, instead of
        choosing them: the cell capacity and span are then measured for the
        grid the search places with those cells on this configuration (the
        cells grow where its region outgrows the grid). For sizes merged
        from measurements at other cells (``largest``): ``fitted``.

    Returns:
      ``Sizes``.
    """
    if (radius is None) == (x_prev is None):
        raise ValueError("measure needs radius= (closest points) or x_prev= (paths)")
    if slack < 1:
        raise ValueError(f"slack must be >= 1; got {slack}")
    if not cell_factor > 0:
        raise ValueError(f"cell_factor must be > 0; got {cell_factor}")
    if cell_size is not None and not (math.isfinite(cell_size) and cell_size > 0):
        raise ValueError(f"cell_size must be finite and > 0; got {cell_size}")
    x_prev, x, mask = _inputs.check_slaves(x, x_prev, mask)
    if x_prev is None:
        radius = _inputs.check_radius(radius, x.dtype)
    surface = _inputs.check_surface(surface, x.dtype)
    num_rows, num_segments = x.shape[0], surface.segments.shape[0]
    for_paths = x_prev is not None
    block_size = max(1, min(block_size, max(num_rows, 1)))
    num_blocks = -(-num_rows // block_size)
    if use_cells is None:
        use_cells = num_segments > cells_above
    # Sizes of scenes with nothing to bin still say whether cells are used, so
    # that ``largest`` keeps the choice when they grow.
    if num_rows == 0 or num_segments == 0:
        return Sizes(num_rows, block_size, 1, for_paths, use_cells, chunk_rows=chunk_rows)
    measured = _measure(x_prev, x, surface, radius, mask, block_size, num_blocks)
    block_capacity = min(num_blocks, grow(int(measured.num_blocks), slack))
    if not use_cells:
        return Sizes(num_rows, block_size, block_capacity, for_paths, chunk_rows=chunk_rows)

    # The cells: sized from what the narrow phase will see.
    kept = np.asarray(measured.rows)
    kept = kept[kept < num_rows]
    kept = kept[np.asarray(measured.slave_ok)[kept]]
    points = np.asarray(measured.query)[kept]
    ok = np.asarray(measured.segment_ok)
    if points.size == 0 or not ok.any():
        return Sizes(
            num_rows, block_size, block_capacity, for_paths, use_cells, chunk_rows=chunk_rows
        )
    low = np.maximum(np.asarray(measured.master.low), points.min(axis=0))
    high = np.minimum(np.asarray(measured.master.high), points.max(axis=0))
    extent = np.maximum(high - low, 0.0)
    lengths = np.asarray(measured.extents)[ok]
    if layout is not None and layout.use_cells and layout.cell_size > 0:
        edge, grid_shape, buckets = layout.cell_size, layout.grid_shape, layout.buckets
    else:
        chosen = cell_size is None
        if chosen:
            cell_size = cell_factor * (2 * float(measured.reach) + float(np.median(lengths)))
        edge, grid_shape, buckets = _cells_for(extent, cell_size, len(points), slack, chosen)
        layout = None
    # The cells the search places (``cells.list_candidates``): the edge, or
    # wider where the region outgrows the grid (never, for cells chosen here).
    cell = max(edge, float(np.max(extent / np.asarray(grid_shape))))
    widths = (np.asarray(measured.boxes.high) - np.asarray(measured.boxes.low))[ok]
    span = tuple(size_class(int(math.ceil(w * slack / cell)) + 1) for w in widths.max(axis=0))
    if layout is not None:
        span = tuple(map(max, span, layout.span))
    grid = Grid(jnp.asarray(low, x.dtype), jnp.asarray(cell, x.dtype))
    most_per_cell, num_tiles = _cell_load(
        measured.boxes, measured.segment_ok, grid, jnp.asarray(points), grid_shape, span, buckets
    )
    return Sizes(
        num_slaves=num_rows,
        block_size=block_size,
        block_capacity=block_capacity,
        for_paths=for_paths,
        use_cells=True,
        grid_shape=grid_shape,
        cell_size=float(edge),
        span=span,
        cell_capacity=grow(int(most_per_cell), slack),
        chunk_rows=chunk_rows,
        tile_capacity=grow(int(num_tiles), slack),
        buckets=buckets,
    )


def largest(first: Sizes, second: Sizes) -> Sizes:
    """Each capacity the larger of two ``Sizes`` of one detector: sizes that
    hold whatever either holds (the grid also grows at run time when its
    region does)."""
    if (first.num_slaves, first.for_paths) != (second.num_slaves, second.for_paths):
        raise ValueError(f"sizes of different searches cannot be merged: {first}, {second}")
    return dataclasses.replace(
        first,
        block_capacity=max(first.block_capacity, second.block_capacity),
        use_cells=first.use_cells or second.use_cells,
        grid_shape=tuple(map(max, first.grid_shape, second.grid_shape)),
        cell_size=max(first.cell_size, second.cell_size),
        span=tuple(map(max, first.span, second.span)),
        cell_capacity=max(first.cell_capacity, second.cell_capacity),
        contact_capacity=max(first.contact_capacity, second.contact_capacity),
        buckets=max(first.buckets, second.buckets),
        tile_capacity=max(first.tile_capacity, second.tile_capacity),
    )


def measure_batch(x, surface: Surface, *, x_prev=None, mask=None, **kwargs) -> Sizes:
    """One ``Sizes`` for every scene of a batch: ``x`` f[B, N, 2]; ``surface``,
    ``x_prev`` and ``mask`` batched the same way (a surface may be shared).

    Each scene is measured, then measured again at the cells of the largest
    of those sizes (``measure(layout=...)``), so that the largest of each
    capacity holds for all; with ``layout`` given, only the second pass.
    """
    x = np.asarray(x)
    shared = np.ndim(surface.nodes) == 2

    def scene(values, index):
        return None if values is None else np.asarray(values)[index]

    def sized(index, **extra):
        own = surface if shared else jax.tree.map(lambda leaf: leaf[index], surface)
        return measure(
            x[index], own, x_prev=scene(x_prev, index), mask=scene(mask, index), **kwargs, **extra
        )

    if kwargs.get("layout") is None:
        kwargs["layout"] = functools.reduce(largest, [sized(i) for i in range(x.shape[0])])
    # Each scene again at the merged cells: each alone may have chosen other
    # cells (another edge, or lists shared through a hash), and a capacity
    # holds only at the cells it was measured at.
    fits = [sized(index) for index in range(x.shape[0])]
    return functools.reduce(largest, [kwargs["layout"], *fits])


def fitted(sizes: Sizes, x, surface: Surface, **kwargs) -> Sizes:
    """``sizes`` with room for this configuration at their own cells: the
    largest of ``sizes`` and ``measure(..., layout=sizes)`` (``measure_batch``
    for ``x`` f[B, N, 2]). For sizes merged from others (``largest``: a
    ``Search`` allocated ``at_least=`` an old state), whose cell capacity was
    measured at other cells."""
    if not sizes.use_cells:
        return sizes
    batched = np.ndim(x) == 3
    fit = (measure_batch if batched else measure)(x, surface, layout=sizes, **kwargs)
    return largest(sizes, fit)


def check_sizes(sizes, num_slaves: int, for_paths: bool):
    """Sizes made for this many slaves and this query, or a ``ValueError``."""
    if not isinstance(sizes, Sizes):
        raise ValueError(f"sizes must be jaxcontact Sizes; got {type(sizes).__name__}")
    if sizes.num_slaves != num_slaves:
        raise ValueError(f"sizes were made for {sizes.num_slaves} slaves; x has {num_slaves} rows")
    if sizes.for_paths != for_paths:
        wanted = "paths (allocate with x_prev=)" if for_paths else "closest points (a radius)"
        raise ValueError(f"sizes were made for the other query; this one needs sizes for {wanted}")


def room_for_every_slot(sizes: Sizes) -> Sizes:
    """``sizes`` whose list form has an entry for every kept slave: it cannot overflow."""
    return dataclasses.replace(sizes, contact_capacity=max(1, sizes.slave_capacity))


def with_entries(sizes: Sizes, needed, slack: float) -> Sizes:
    """``sizes`` with the list form's capacity: the most entries ``needed``
    (i32[] or i32[B], ``driver.entries_needed``) times ``slack``, at least 1,
    as ``measure`` sizes the rest."""
    most = int(np.max(np.asarray(needed)))
    return dataclasses.replace(sizes, contact_capacity=grow(most, slack))


def merged(sizes: Sizes, old: Sizes | None) -> Sizes:
    """``sizes`` at least as large as ``old``'s (None: as they are), for as many slaves."""
    if old is None:
        return sizes
    if old.num_slaves != sizes.num_slaves:
        raise ValueError(
            f"at_least was allocated for {old.num_slaves} slaves; x has {sizes.num_slaves}"
        )
    return largest(sizes, old)
