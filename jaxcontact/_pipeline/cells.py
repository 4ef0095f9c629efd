"""Fixed-size cell binning of the master segments.

A uniform grid of ``shape`` cells, each ``cell_size`` wide, starts at
``origin``. Each segment is registered in every cell that its inflated box
touches; a query point then looks only at the segments of its own cell. A
segment within the inflation distance of a point has an inflated box that
contains the point, and cell indices are a monotone function of the
coordinate (the same ``floor((p - origin) / cell_size)`` for both), so the
point's cell is among the box's cells: nothing is lost at cell edges, at
negative coordinates, or for points exactly on a boundary.

All sizes are static: a segment may span at most ``span`` cells per axis and
a cell hold at most ``capacity`` segments; beyond either, ``overflow`` is set.

Where a grid of cells of the natural edge would hold many more cells than
there are slaves (an outline that winds through a wide, mostly empty box:
self-contact, several bodies), the cells keep their edge and share a fixed
number of lists through a spatial hash (``buckets``), instead of growing until
the grid is small: lists then hold the segments near a cell, not those of a
cell many times wider.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.broad import Box, enclosing
from jaxcontact._pipeline.segments import Segments
from jaxcontact._pipeline.sort import sorted_pair_keys, stable_order
from jaxcontact._types import Array, Sizes


class Grid(NamedTuple):
    """Where the cells are. ``origin`` and ``cell_size`` are traced."""

    origin: Array  # f[2]  lower-left corner of cell (0, 0)
    cell_size: Array  # f[]  edge length of every cell


class Bins(NamedTuple):
    """Segments sorted by cell: cell ``c`` holds ``order[start[c] : start[c] + count[c]]``."""

    order: Array  # i32[E]  segment of each sorted entry (E = M * span_x * span_y)
    start: Array  # i32[G + 1]  first entry of each cell (G = cells; the last is "no cell")
    count: Array  # i32[G + 1]  entries of each cell
    overflow: Array  # bool[]  a segment spans too many cells, or a cell holds too many


def cell_of(points: Array, grid: Grid, shape: tuple[int, int]) -> Array:
    """i32[..., 2]: the cell of each point, clamped into the grid."""
    leading = (1,) * (points.ndim - 1)
    index = jnp.floor((points - grid.origin.reshape(leading + (2,))) / grid.cell_size)
    upper = jnp.asarray(shape, index.dtype).reshape(leading + (2,)) - 1
    return jnp.clip(index, 0, upper).astype(jnp.int32)


def flat_cell(cell: Array, shape: tuple[int, int], buckets: int = 0) -> Array:
    """i32[...]: the list of a cell given as (ix, iy): its row-major number,
    or with ``buckets`` its spatial hash into that many lists.

    The hash is Teschner et al.'s (2003, "Optimized Spatial Hashing for
    Collision Detection of Deformable Objects", VMV): ``(ix * 73856093) xor
    (iy * 19349663) mod buckets``, in uint32 arithmetic. Cells that share a
    list only lengthen it: a point still meets every segment registered in
    its own cell, and the pair's score rejects the others.
    """
    if not buckets:
        return cell[..., 1] * shape[0] + cell[..., 0]
    ix = cell[..., 0].astype(jnp.uint32) * jnp.uint32(73856093)
    iy = cell[..., 1].astype(jnp.uint32) * jnp.uint32(19349663)
    return ((ix ^ iy) % jnp.uint32(buckets)).astype(jnp.int32)


def num_lists(shape: tuple[int, int], buckets: int = 0) -> int:
    """Cell lists of a grid: one per cell, or ``buckets`` where cells are hashed."""
    return buckets or shape[0] * shape[1]


def cell_entries(
    boxes: Box, ok: Array, grid: Grid, shape: tuple[int, int], span: tuple[int, int], buckets=0
) -> tuple[Array, Array, Array]:
    """``(list i32[E], segment i32[E], too_wide bool[])``: an entry for each
    ``ok`` segment in each cell its box touches, running segment by segment
    (E = M * span_x * span_y); the entries past a box name the list
    ``num_lists(shape, buckets)`` ("no cell"). ``too_wide``: a box covers more
    than ``span`` cells on an axis. Arguments as ``bin_segments``'."""
    num_cells = num_lists(shape, buckets)
    num_segments = ok.shape[0]
    safe = ok[:, None]
    low = cell_of(jnp.where(safe, boxes.low, grid.origin), grid, shape)
    high = cell_of(jnp.where(safe, boxes.high, grid.origin), grid, shape)
    too_wide = jnp.any(ok & jnp.any(high - low >= jnp.asarray(span)[None], axis=-1))
    step_x = jnp.arange(span[0], dtype=jnp.int32)[None, :, None]
    step_y = jnp.arange(span[1], dtype=jnp.int32)[None, None, :]
    cell_x = low[:, 0, None, None] + step_x
    cell_y = low[:, 1, None, None] + step_y
    inside = (
        ok[:, None, None] & (cell_x <= high[:, 0, None, None]) & (cell_y <= high[:, 1, None, None])
    )
    listed = flat_cell(jnp.stack(jnp.broadcast_arrays(cell_x, cell_y), axis=-1), shape, buckets)
    cell = jnp.where(inside, listed, num_cells).reshape(-1)
    segment = jnp.broadcast_to(
        jnp.arange(num_segments, dtype=jnp.int32)[:, None, None], inside.shape
    ).reshape(-1)
    return cell, segment, too_wide


def bin_segments(
    boxes: Box,
    ok: Array,
    grid: Grid,
    shape: tuple[int, int],
    span: tuple[int, int],
    capacity: int,
    buckets: int = 0,
) -> Bins:
    """Registers every ``ok`` segment in each cell its box touches.

    Args:
      boxes: f[M, 2] inflated segment boxes.
      ok: bool[M] real segments.
      grid: the grid's placement.
      shape: static (cells in x, cells in y).
      span: static most cells a segment may cover per axis.
      capacity: static most segments a cell's list may hold.
      buckets: static; 0 gives each cell its own list, more hashes the
        cells into that many lists (``flat_cell``).
    """
    num_cells, num_segments = num_lists(shape, buckets), ok.shape[0]
    cell, segment, too_wide = cell_entries(boxes, ok, grid, shape, span, buckets)
    count = jax.ops.segment_sum(jnp.ones_like(cell), cell, num_segments=num_cells + 1)
    # Each cell's segments in increasing order: a segment is in a cell once
    # (in a list shared by hashed cells it may be twice: two equal entries,
    # harmless), so one sort of packed (cell, segment) pairs where they fit
    # in int32; else a stable sort of the cells (the entries run segment by
    # segment).
    keys = sorted_pair_keys(cell, segment, num_segments, num_cells + 1)
    if keys is None:
        by_cell = stable_order(cell, num_cells + 1)
        order, sorted_cell = segment[by_cell], cell[by_cell]
    else:
        order, sorted_cell = keys % num_segments, keys // num_segments
    # Each cell's first entry: the least position of its entries in the sorted
    # order (a scatter-min; a cumsum of the counts is 6-10 kernels on XLA's
    # CPU). An empty cell's start is never read.
    num_entries = order.shape[0]
    position = jnp.arange(num_entries, dtype=jnp.int32)
    start = jnp.full((num_cells + 1,), num_entries, jnp.int32).at[sorted_cell].min(position)
    too_full = jnp.max(count[:num_cells], initial=0) > capacity
    # The last "cell" gathers the unused entries; a point there must see none.
    count = count.at[num_cells].set(0)
    return Bins(order, start.astype(jnp.int32), count.astype(jnp.int32), too_wide | too_full)


class CellLists(NamedTuple):
    """Each query point's candidate segments, as a slice of the sorted entries.

    O(S + E) memory: the (S, capacity) table of candidates is never built;
    ``segments_in_slots`` reads a block of its columns at a time.
    """

    first: Array  # i32[S]  first entry of the point's cell
    count: Array  # i32[S]  entries in it (0 for a point that should see none)
    order: Array  # i32[E]  segment of each sorted entry


def cell_lists(cells: Array, bins: Bins) -> CellLists:
    """The candidate lists of points in cells ``cells`` (i32[S], "no cell" sees none)."""
    return CellLists(bins.start[cells], bins.count[cells], bins.order)


def segments_in_slots(lists: CellLists, slots: Array) -> Array:
    """i32[S, B]: each point's candidate segments in ``slots`` (i32[B]), -1 past its list."""
    if lists.order.shape[0] == 0:
        return jnp.full(lists.first.shape + slots.shape, -1, jnp.int32)
    entry = jnp.minimum(lists.first[:, None] + slots[None, :], lists.order.shape[0] - 1)
    return jnp.where(slots[None, :] < lists.count[:, None], lists.order[entry], -1)


def list_candidates(query: Array, ok: Array, segments: Segments, boxes: Box, sizes: Sizes):
    """The segments in each kept slave's cell (``CellLists``), and the cells' overflow.

    Args:
      query: f[S, 2] the point whose cell decides the candidates.
      ok: bool[S] kept slave is real.
      segments: resolved segments.
      boxes: f[M, 2] segment boxes inflated by the search distance.
      sizes: the static sizes.
    """
    shape = sizes.grid_shape
    master = enclosing(boxes)
    kept = Box(jnp.where(ok[:, None], query, jnp.inf), jnp.where(ok[:, None], query, -jnp.inf))
    region = enclosing(kept)
    low, high = jnp.maximum(master.low, region.low), jnp.minimum(master.high, region.high)
    extent = jnp.where(jnp.isfinite(high - low) & (high > low), high - low, 0)
    origin = jnp.where(jnp.isfinite(low), low, 0)
    # The grid always covers the region: cells grow when the region does.
    cell_size = jnp.maximum(sizes.cell_size, jnp.max(extent / jnp.asarray(shape, query.dtype)))
    grid = Grid(origin, cell_size.astype(query.dtype))
    buckets = sizes.buckets
    bins = bin_segments(boxes, segments.ok, grid, shape, sizes.span, sizes.cell_capacity, buckets)
    no_cell = num_lists(shape, buckets)
    cells = jnp.where(ok, flat_cell(cell_of(query, grid, shape), shape, buckets), no_cell)
    return cell_lists(cells, bins), bins.overflow
