"""Candidates and the skin rule: the cull and the binning, kept across steps.

A ``Search`` with a skin finds each slave's candidate segments within
``radius + skin`` once (``find``) and reuses them while no pair within the
radius can have been missed (``expired``): Verlet's neighbour lists, as
jax-md keeps them, applied to node-to-segment contact.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.broad import Blocks, broad_phase, kept_rows
from jaxcontact._pipeline.cells import CellLists, list_candidates
from jaxcontact._pipeline.placement import searched_whole
from jaxcontact._pipeline.segments import (
    ends_of,
    resolve_segments,
    rows_ok,
    squared_norm,
    with_pool,
)
from jaxcontact._types import Array, Sizes, Surface


class Candidates(NamedTuple):
    """The kept slaves and their cells' segments within ``radius + skin``,
    found once and reused while the skin rule holds (``expired``)."""

    blocks: Blocks  # the kept blocks of slaves
    listed: CellLists | None  # each kept slave's cell's segments (cell sizes), else None
    reference: Array  # f[N, 2]  slave positions when found
    nodes: Array  # f[P, 2]  master node positions when found
    row_ok: Array  # bool[N]  the rows that were real when found
    segment_ok: Array  # bool[M]  the segments that were real, or in the pool, when found
    indices: Array  # i32[M, 2]  the segments' node indices when found
    overflow: Array  # bool[]  the sizes were too small when they were found
    pool: Array | None = None  # bool[M]  segments listed while masked, that may switch on


# Why candidates were found again (``expired``; ``SearchState.last_rebuild``), bit by bit.
MOVED, NEW_ROWS, NEW_SEGMENTS, REJOINED = 1, 2, 4, 8
REBUILD_REASONS = {
    MOVED: "the slaves and the master moved more than the skin",
    NEW_ROWS: "a slave row became real",
    NEW_SEGMENTS: "a segment outside the pool became real",
    REJOINED: "a real segment was joined to other nodes",
}


@searched_whole(rows="x")
def find(x, surface: Surface, reach, mask, sizes: Sizes, pool=None) -> Candidates:
    """``Candidates`` within ``reach`` (the radius plus the skin); masked
    segments of ``pool`` (bool[M]) are listed as if real."""
    slave_ok = rows_ok(x, mask)
    segments = resolve_segments(with_pool(surface, pool))
    boxes, blocks = broad_phase(
        x, x, slave_ok, segments, reach, sizes.block_size, sizes.block_capacity
    )
    listed, overflow = None, blocks.overflow
    if sizes.use_cells:
        (kept,), ok = kept_rows(blocks, mask, x)
        listed, cells_overflow = list_candidates(kept, ok, segments, boxes, sizes)
        # Cells no kept slave looks up cannot lose a candidate.
        overflow = overflow | (cells_overflow & (blocks.count > 0))
    x, nodes = jax.lax.stop_gradient((x, surface.nodes))
    return Candidates(
        blocks=blocks,
        listed=listed,
        reference=x,
        nodes=nodes,
        row_ok=slave_ok,
        segment_ok=segments.ok,
        indices=segments.indices,
        overflow=overflow,
        pool=pool,
    )


def expired(candidates: Candidates, x, surface: Surface, mask, skin) -> Array:
    """i32[]: why ``candidates`` may miss a pair now within the radius, as bits
    (``REBUILD_REASONS``); 0 while they hold.

    A pair within the radius now was within ``radius + skin`` when they were
    found if the largest slave move plus the largest move of a real
    segment's end is at most the skin (a segment moves no farther than its
    ends). Rows or segments that became real since, and segments joined to
    other nodes, were never looked at: they expire the candidates too,
    except segments of the pool, which were listed in advance. Rows and
    segments that are not real (padding) may change freely, and one that
    became real is reported as new only: what it held as padding is no
    move.
    """

    def not_finite_is_far(squared):
        # A real row's (or segment's) move that is not finite overflowed: stale.
        return jnp.where(jnp.isnan(squared), jnp.inf, squared)

    def largest_and_new(squared, ok, ok_then):
        """The largest real move, and whether a row is real that was not.

        Both read off one value per row (-1 for a new row), whose max and
        min XLA reduces in one pass: the N rows are read once a step.
        Squared lengths per column (``squared_norm``). Measured on
        81,939 rows (``expired`` alone, jitted): 0.36-0.38 ms with
        ``jnp.sum(..., axis=-1)`` and two passes, 0.20 ms per column, 0.19
        in one pass.
        """
        value = jnp.where(ok, jnp.where(ok_then, not_finite_is_far(squared), -1), 0)
        return jnp.sqrt(jnp.max(value, initial=0)), jnp.min(value, initial=0) < 0

    row_ok = rows_ok(x, mask)
    segments = resolve_segments(surface)
    ends_then = ends_of(candidates.nodes, segments.indices)
    ends_now = jnp.stack([segments.start, segments.end], axis=1)
    end_moves = jnp.maximum(*(squared_norm(ends_now[:, k] - ends_then[:, k]) for k in (0, 1)))
    squared = squared_norm(x - candidates.reference)
    rows_moved, new_rows = largest_and_new(squared, row_ok, candidates.row_ok)
    ends_moved, new_segments = largest_and_new(end_moves, segments.ok, candidates.segment_ok)
    moved = rows_moved + ends_moved
    rejoined = jnp.any(segments.ok & jnp.any(segments.indices != candidates.indices, axis=-1))
    reasons = ((moved > skin, MOVED), (new_rows, NEW_ROWS), (new_segments, NEW_SEGMENTS))
    bits = jnp.where(rejoined, REJOINED, 0)
    for flag, bit in reasons:
        bits = bits | jnp.where(flag, bit, 0)
    return bits.astype(jnp.int32)


# One program per shape and sizes.
find_jit = jax.jit(find, static_argnames="sizes")
