"""The broad phase: boxes, their overlap, and culling whole blocks of slaves.

This is the paper's preliminary phase (section 2.1): the master's bounding
box, inflated by the search distance, against the slaves' boxes. Slaves are
culled a block at a time (``block_size`` consecutive rows): a block is kept
when one of its rows meets the master's box, which costs one streaming pass
of comparisons over the slaves, while compacting single slaves
(``jnp.nonzero`` over N rows) costs more than the whole narrow phase near a
small tool. Culling pays when rows that are close in the input are close in
space, as mesh numberings are; a random order is still correct, only slower.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.segments import Segments, finite_rows
from jaxcontact._pipeline.sort import first_true
from jaxcontact._types import Array


def conservative_margin(distance: Array, *coordinates: Array) -> Array:
    """``distance`` widened so that box tests never miss what the kernel finds.

    A box test and the per-pair kernel round differently. Widening by a
    relative 2^-8 of the distance and 16 ulps of the largest coordinate makes
    the test strictly more inclusive than the kernel; the cost is a few extra
    candidates.
    """
    dtype = distance.dtype
    planes = [
        jnp.where(jnp.isfinite(plane), jnp.abs(plane), 0).astype(dtype)
        for values in coordinates
        for plane in (values[..., 0], values[..., 1])
    ]
    scale = jnp.max(jnp.stack(bounds(planes, [jnp.maximum] * len(planes))), initial=0)
    return distance * (1 + 2.0**-8) + 16 * jnp.finfo(dtype).eps * scale


def bounds(planes, combine) -> list:
    """Each of ``planes`` (arrays of one shape) reduced over all its elements by its own
    of ``combine`` (``jnp.minimum`` or ``jnp.maximum``), in one variadic reduce.

    XLA's CPU compiler splits a single-operand reduction over more than 32
    elements into 2-4 kernels (its tree-reduction rewriter) and leaves a
    variadic one whole: the master's box, its margin and the grid's region
    are each one kernel so. Minimum and maximum are exact, so the values are
    those of ``jnp.min`` and ``jnp.max``.
    """
    inits = [
        jnp.array(jnp.inf if op is jnp.minimum else -jnp.inf, plane.dtype)
        for plane, op in zip(planes, combine, strict=True)
    ]

    def reducer(first, second):
        return tuple(op(a, b) for op, a, b in zip(combine, first, second, strict=True))

    axes = tuple(range(planes[0].ndim))
    return list(jax.lax.reduce(tuple(planes), tuple(inits), reducer, axes))


class Box(NamedTuple):
    """An axis-aligned box; empty when any ``low > high``."""

    low: Array  # f[..., 2]
    high: Array  # f[..., 2]


def segment_boxes(segments: Segments, inflate: Array) -> Box:
    """f[M, 2] boxes of the segments inflated by ``inflate``; masked ones empty."""
    low = jnp.minimum(segments.start, segments.end) - inflate
    high = jnp.maximum(segments.start, segments.end) + inflate
    ok = segments.ok[:, None]
    return Box(jnp.where(ok, low, jnp.inf), jnp.where(ok, high, -jnp.inf))


def enclosing(boxes: Box) -> Box:
    """The box around ``boxes`` (f[M, 2] each; empty boxes contribute nothing), one
    variadic reduce (``bounds``)."""
    low_x, low_y, high_x, high_y = bounds(
        [boxes.low[:, 0], boxes.low[:, 1], boxes.high[:, 0], boxes.high[:, 1]],
        [jnp.minimum, jnp.minimum, jnp.maximum, jnp.maximum],
    )
    return Box(jnp.stack([low_x, low_y]), jnp.stack([high_x, high_y]))


def overlaps(first: Box, second: Box) -> Array:
    """bool[...]: the boxes share a point (touching counts).

    Per coordinate, not ``jnp.all(..., axis=-1)``: XLA's CPU code runs a
    length-2 reduction as a loop per row (``segments.squared_norm``); the
    cull of 81,939 rows measured 2x faster so (0.15 against 0.08 ms).
    """

    def meet(axis):
        low, high = first.low[..., axis], first.high[..., axis]
        return (low <= second.high[..., axis]) & (high >= second.low[..., axis])

    return meet(0) & meet(1)


class Blocks(NamedTuple):
    """The slave rows that survive culling, in a buffer of fixed size."""

    index: Array  # i32[C]  kept block, B (the block count) for an empty slot
    rows: Array  # i32[S]  slave row, N for an empty slot (S = C * block_size)
    count: Array  # i32[]  blocks with a row that meets the master's box
    overflow: Array  # bool[]  more blocks overlap than the buffer holds


def _any_per_block(flags: Array, block_size: int) -> Array:
    """bool[B]: any of ``flags`` (bool[N]) in each block of consecutive rows.

    Full blocks are reduced as a (blocks, block_size) view, the last partial
    block apart: no padded copy of the N rows.
    """
    num_rows = flags.shape[0]
    full = num_rows // block_size
    parts = []
    if full:
        parts.append(jnp.any(flags[: full * block_size].reshape(full, block_size), axis=1))
    if num_rows % block_size:
        parts.append(jnp.any(flags[full * block_size :], keepdims=True))
    return jnp.concatenate(parts) if len(parts) > 1 else parts[0]


def cull_blocks(
    low: Array, high: Array, ok: Array, target: Box, block_size: int, capacity: int
) -> Blocks:
    """Keeps the blocks with an ``ok`` row whose box ``[low, high]`` meets
    ``target``, at most ``capacity`` of them (``ok=None``: every row may be).

    A row's own box, not its block's: one pass of comparisons over the rows,
    where a box per block costs XLA a copy of each coordinate column and
    min/max reductions over it (the broad phase with the kept rows measured
    3.7x faster on the CPU at 10^6 rows, 4.8 against 1.3 ms, and 1.5x at
    81,939, with commit 5928bf7f76cc:benchmarks/archive/stages.py). It keeps no block
    a box per block would drop. A row that can be found lies in the target box
    (``conservative_margin``), so the rows found are the same.
    """
    num_rows = low.shape[0]
    num_blocks = -(-num_rows // block_size)
    rows_meet = overlaps(Box(low, high), Box(target.low[None], target.high[None]))
    if ok is not None:
        rows_meet = rows_meet & ok
    meets = _any_per_block(rows_meet, block_size)
    count = jnp.sum(meets, dtype=jnp.int32)
    kept = first_true(meets, capacity)
    rows = kept[:, None] * block_size + jnp.arange(block_size, dtype=kept.dtype)[None, :]
    rows = jnp.where((kept[:, None] < num_blocks) & (rows < num_rows), rows, num_rows)
    return Blocks(
        kept.astype(jnp.int32), rows.reshape(-1).astype(jnp.int32), count, count > capacity
    )


def broad_phase(low, high, slave_ok, segments: Segments, reach, block_size: int, capacity: int):
    """The segment boxes inflated by ``reach``, and the blocks of slave boxes that meet them.

    ``low``/``high`` are f[N, 2] per-slave boxes: the slave itself, or its path.
    """
    boxes = segment_boxes(segments, conservative_margin(reach, segments.start, segments.end))
    blocks = cull_blocks(low, high, slave_ok, enclosing(boxes), block_size, capacity)
    return boxes, blocks


def kept_rows(blocks: Blocks, mask: Array | None, *points: Array):
    """The kept slaves of each of ``points`` (f[N, 2] each: a point, a path's
    two ends) as f[S, 2], bad rows zeroed, and bool[S] which are real.

    A row is real when it is kept, not masked and finite in every one of
    ``points`` (``segments.rows_ok``, ``segments.paths_ok``), decided here on
    the kept rows only: the broad phase's own test then fuses into its one
    pass over the N rows, where a flag per row shared by both would be
    written out first (measured 1.3 against 1.5 ms at 10^6 rows; no change at
    81,939, whose partial last block has XLA write the flags out anyway).
    """
    num_rows = points[0].shape[0]
    rows = jnp.minimum(blocks.rows, num_rows - 1)
    ok = blocks.rows < num_rows
    if mask is not None:
        ok = ok & mask[rows]
    gathered = [values[rows] for values in points]
    for values in gathered:
        ok = ok & finite_rows(values)
    return tuple(jnp.where(ok[:, None], values, 0) for values in gathered), ok
