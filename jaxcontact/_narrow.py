"""The bucket sort's stages after culling: search the kept slaves, write the rows back.

Shared by ``bucket_sort``, ``bucket_swept`` and reusable candidates. Every
function works on the S kept slaves (S = block capacity x block size), never
on all N, except ``scatter_blocks``, which writes them into N rows.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._broad import (
    Blocks,
    Box,
    enclosing,
)
from jaxcontact._cells import (
    CellLists,
    Grid,
    bin_segments,
    cell_lists,
    cell_of,
    flat_cell,
    segment_in_slot,
    stable_order,
)
from jaxcontact._inputs import Segments
from jaxcontact._plan import BucketPlan
from jaxcontact._search import lowest_score
from jaxcontact._types import Array


def scatter_blocks(result, blocks: Blocks, empty, block_size: int):
    """Writes the kept blocks' results into the all-zero result ``empty``.

    Whole blocks are written (a scatter of C slices of ``block_size`` rows):
    measured 8x cheaper than a scatter of single rows, which XLA also fused
    with the projection and recomputed per field.
    """
    num_rows = empty.segment.shape[0]
    num_blocks = -(-num_rows // block_size)
    pad = num_blocks * block_size - num_rows

    def put(full, part):
        if full.ndim == 0:
            return part
        tail = full.shape[1:]
        padded = jnp.pad(full, ((0, pad),) + ((0, 0),) * len(tail))
        by_block = padded.reshape((num_blocks, block_size) + tail)
        by_block = by_block.at[blocks.index].set(part.reshape((-1, block_size) + tail), mode="drop")
        return by_block.reshape((num_blocks * block_size,) + tail)[:num_rows]

    return jax.tree.map(put, empty, result)


def search_all(pair_value, segments: Segments, num_rows: int, dtype) -> Array:
    """i32[S]: each row against every segment (``all_to_all``, ``swept``, and
    the bucket sort's kept slaves when there are few segments)."""

    def score(k):
        value = pair_value(segments.start[k], segments.end[k])
        value = jnp.where(segments.ok[k], value, jnp.inf)
        return value, jnp.broadcast_to(k, value.shape)

    # Rows are not masked here but where the result is assembled: any per-row
    # mask fused into this loop made it 3-4x slower (measured).
    return lowest_score(score, segments.ok.shape[0], num_rows, dtype)


def list_candidates(query: Array, ok: Array, segments: Segments, boxes: Box, plan: BucketPlan):
    """The segments in each kept slave's cell (``CellLists``), and the cells' overflow.

    Args:
      query: f[S, 2] the point whose cell decides the candidates.
      ok: bool[S] kept slave is real.
      segments: resolved segments.
      boxes: f[M, 2] segment boxes inflated by the search distance.
      plan: the static sizes.
    """
    shape = plan.grid_shape
    master = enclosing(boxes)
    low = jnp.maximum(master.low, jnp.min(jnp.where(ok[:, None], query, jnp.inf), axis=0))
    high = jnp.minimum(master.high, jnp.max(jnp.where(ok[:, None], query, -jnp.inf), axis=0))
    extent = jnp.where(jnp.isfinite(high - low) & (high > low), high - low, 0)
    origin = jnp.where(jnp.isfinite(low), low, 0)
    # The grid always covers the region: cells grow when the region does.
    cell_size = jnp.maximum(plan.cell_size, jnp.max(extent / jnp.asarray(shape, query.dtype)))
    grid = Grid(origin, cell_size.astype(query.dtype))
    bins = bin_segments(boxes, segments.ok, grid, shape, plan.span, plan.cell_capacity)
    no_cell = shape[0] * shape[1]
    cells = jnp.where(ok, flat_cell(cell_of(query, grid, shape), shape), no_cell)
    return cell_lists(cells, bins), bins.overflow


# Kept slaves are searched in chunks of this many rows, fullest lists first.
_CHUNK = 2048


def _search_rows(pair_value, segments: Segments, listed: CellLists, capacity: int, dtype):
    """i32[S]: each row against the segments of its list, up to the fullest list's length."""

    def score(slot):
        segment = segment_in_slot(listed, slot)
        index = jnp.maximum(segment, 0)
        value = pair_value(segments.start[index], segments.end[index])
        # Reused lists may name a segment masked or degenerate since.
        listed_ok = (segment >= 0) & segments.ok[index]
        return jnp.where(listed_ok, value, jnp.inf), segment

    # Each cell lists its segments in increasing order. Per-slot gathers make
    # the unrolled loop slow to compile and to run: scan blocks of 8 (measured
    # 3x faster to compile and 1.3-1.7x faster to run on the cutting scene).
    # Every row runs as many slots as the fullest list among them needs, not
    # the planned capacity (measured 1.3x faster on the rough die).
    fullest = jnp.max(listed.count, initial=0)
    return lowest_score(
        score, capacity, listed.first.shape[0], dtype, unroll=8, steps_needed=fullest
    )


def search_listed(kernel, rows, segments: Segments, listed: CellLists, capacity: int, dtype):
    """i32[S]: each kept slave against the segments of its cell, ``capacity`` slots.

    ``kernel(*row, a, b)`` scores a pair; ``rows`` are the kept slaves' f[S, ...]
    arrays. A row costs as many slots as the fullest list it is searched
    with. Kept blocks hold many slaves whose cells are empty (a block is kept
    when its box meets the master's), so above ``_CHUNK`` rows they are
    ordered by list length, longest first, and searched a chunk at a time,
    each chunk only as far as its own longest list; the loop stops at the
    first chunk of empty lists. Each row's answer does not depend on the
    order: it meets its own list in the same order either way.
    """
    num_rows = listed.first.shape[0]
    if num_rows <= _CHUNK:
        return _search_rows(vmapped(kernel, *rows), segments, listed, capacity, dtype)
    num_chunks = -(-num_rows // _CHUNK)
    pad = num_chunks * _CHUNK - num_rows
    # Longest first: a stable sort of (capacity - length), one int32 key.
    length = jnp.clip(listed.count, 0, capacity)
    order = stable_order(capacity - length, capacity + 1)

    def arrange(values):
        """Rows in search order, padded with zeros (empty lists) to whole chunks."""
        return jnp.pad(values[order], ((0, pad),) + ((0, 0),) * (values.ndim - 1))

    first, count = arrange(listed.first), arrange(listed.count)
    rows = tuple(map(arrange, rows))
    longest = count[::_CHUNK]  # each chunk's longest list comes first

    def search_chunk(state):
        chunk, choice = state
        at = chunk * _CHUNK

        def part(values):
            return jax.lax.dynamic_slice_in_dim(values, at, _CHUNK)

        lists = CellLists(part(first), part(count), listed.order)
        pair_value = vmapped(kernel, *map(part, rows))
        found = _search_rows(pair_value, segments, lists, capacity, dtype)
        return chunk + 1, jax.lax.dynamic_update_slice_in_dim(choice, found, at, 0)

    def more(state):
        chunk = jnp.minimum(state[0], num_chunks - 1)
        return (state[0] < num_chunks) & (longest[chunk] > 0)

    choice = jnp.full((num_chunks * _CHUNK,), -1, jnp.int32)
    _, choice = jax.lax.while_loop(more, search_chunk, (jnp.zeros((), jnp.int32), choice))
    return jnp.full((num_rows,), -1, jnp.int32).at[order].set(choice[:num_rows])


def choose(
    query: Array, ok: Array, segments: Segments, boxes: Box, kernel, rows, plan, listed=None
):
    """i32[S] chosen segment of each kept slave, and whether the cells overflowed.

    Pairs are scored by ``kernel(*row, a, b)`` over ``rows``. Rows that are
    not ``ok`` may hold any choice; the caller masks them. ``listed`` reuses
    candidate lists found before (see ``find_candidates``).
    """
    if not plan.use_cells:
        pair_value = vmapped(kernel, *rows)
        return search_all(pair_value, segments, query.shape[0], query.dtype), jnp.zeros((), bool)
    overflow = jnp.zeros((), bool)
    if listed is None:
        listed, overflow = list_candidates(query, ok, segments, boxes, plan)
    choice = search_listed(kernel, rows, segments, listed, plan.cell_capacity, query.dtype)
    return choice, overflow


def vmapped(kernel, *rows):
    """``pair_value(start, end)`` mapping ``kernel(*row, start, end)`` over rows.

    ``start``/``end`` are f[2] for all rows or f[S, 2] per row.
    """

    def pair_value(start, end):
        axis = None if start.ndim == 1 else 0
        return jax.vmap(kernel, in_axes=(0,) * len(rows) + (axis, axis))(*rows, start, end)

    return pair_value


def kept_rows(x: Array, slave_ok: Array, blocks: Blocks):
    """The kept slaves (f[S, 2], bad rows zeroed) and bool[S] which are real."""
    rows = jnp.minimum(blocks.rows, x.shape[0] - 1)
    ok = slave_ok[rows] & (blocks.rows < x.shape[0])
    return jnp.where(ok[:, None], x[rows], 0), ok
