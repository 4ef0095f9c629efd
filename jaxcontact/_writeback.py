"""Write-back: the kept slaves' results into N rows, and the rows of nothing found.

The bucket detectors compute on the S kept slaves only; this is the one
place where their rows meet all N, or, for the compact form
(``ContactList``), where the found ones are packed into K entries.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._broad import Blocks
from jaxcontact._types import Array, Contact, ContactList, Crossing, CrossingList


def empty_contact(x: Array, overflow: Array) -> Contact:
    zeros = jnp.zeros(x.shape[:1], x.dtype)
    false = jnp.zeros(x.shape[:1], bool)
    minus_one = jnp.full(x.shape[:1], -1, jnp.int32)
    return Contact(
        gap=zeros,
        xi=zeros,
        segment=minus_one,
        point=jnp.zeros_like(x),
        normal=jnp.zeros_like(x),
        vertex=minus_one,
        found=false,
        active=false,
        overflow=overflow,
    )


def empty_contact_list(capacity: int, num_rows: int, dtype, overflow: Array) -> ContactList:
    """``capacity`` padding entries of the compact form (slaves ``num_rows``)."""
    zeros = jnp.zeros((capacity,), dtype)
    false = jnp.zeros((capacity,), bool)
    return ContactList(
        node=jnp.full((capacity,), num_rows, jnp.int32),
        gap=zeros,
        xi=zeros,
        segment=jnp.full((capacity,), -1, jnp.int32),
        point=jnp.zeros((capacity, 2), dtype),
        normal=jnp.zeros((capacity, 2), dtype),
        vertex=jnp.full((capacity,), -1, jnp.int32),
        found=false,
        active=false,
        overflow=overflow,
    )


def first_slots(flags: Array, capacity: int) -> tuple[Array, Array, Array]:
    """``(at, valid, count)``: the first ``capacity`` slots where ``flags``
    (bool[S]) is True, in increasing order.

    ``at`` (i32[capacity]) indexes them, clamped into ``[0, S)`` past the
    last one so that it may gather; ``valid`` says which are real;
    ``count`` (i32[]) is how many flags were True, ``capacity`` or more.
    """
    num_slots = flags.shape[0]
    count = jnp.sum(flags, dtype=jnp.int32)
    (slots,) = jnp.nonzero(flags, size=capacity, fill_value=num_slots)
    return jnp.minimum(slots, max(num_slots - 1, 0)), slots < num_slots, count


def pack_found(result: Contact, rows: Array, capacity: int, num_rows: int) -> ContactList:
    """The ``found`` rows of ``result`` (a ``Contact`` of S slots: the kept
    slaves that may be found) packed into ``capacity`` entries, in increasing
    slot order, as a ``ContactList``.

    ``rows`` (i32[S], increasing where real) is each slot's slave row. The
    N rows are never written (on the cutting scene at 10^6 rows the dense
    write-back was 40 % of the call: ``benchmarks/stages.py``).
    """
    at, valid, count = first_slots(result.found, capacity)

    def take(values, fill):
        return _taken(values, at, valid, fill)

    return ContactList(
        node=jnp.where(valid, rows[at], num_rows).astype(jnp.int32),
        gap=take(result.gap, 0),
        xi=take(result.xi, 0),
        segment=take(result.segment, -1),
        point=take(result.point, 0),
        normal=take(result.normal, 0),
        vertex=take(result.vertex, -1),
        found=valid,
        active=take(result.active, False),
        overflow=result.overflow | (count > capacity),
    )


def _taken(values: Array, at: Array, valid: Array, fill) -> Array:
    """``values[at]`` where ``valid``, else ``fill`` (entries past the last)."""
    shape = valid.shape + (1,) * (values.ndim - 1)
    return jnp.where(valid.reshape(shape), values[at], fill)


def empty_crossing_list(capacity: int, num_rows: int, dtype, overflow: Array) -> CrossingList:
    """``capacity`` padding entries of the compact swept form (slaves ``num_rows``)."""
    return CrossingList(
        node=jnp.full((capacity,), num_rows, jnp.int32),
        t=jnp.zeros((capacity,), dtype),
        segment=jnp.full((capacity,), -1, jnp.int32),
        point=jnp.zeros((capacity, 2), dtype),
        crossed=jnp.zeros((capacity,), bool),
        overflow=overflow,
    )


def pack_crossed(result: Crossing, rows: Array, capacity: int, num_rows: int) -> CrossingList:
    """The ``crossed`` rows of ``result`` (a ``Crossing`` of slots whose slave
    rows are ``rows``, increasing where real) packed into ``capacity``
    entries, in increasing slot order, as a ``CrossingList``: as
    ``pack_found`` for contacts."""
    at, valid, count = first_slots(result.crossed, capacity)
    return CrossingList(
        node=jnp.where(valid, rows[at], num_rows).astype(jnp.int32),
        t=_taken(result.t, at, valid, 0),
        segment=_taken(result.segment, at, valid, -1),
        point=_taken(result.point, at, valid, 0),
        crossed=valid,
        overflow=result.overflow | (count > capacity),
    )


def empty_crossing(x: Array, overflow: Array) -> Crossing:
    zeros = jnp.zeros(x.shape[:1], x.dtype)
    return Crossing(
        zeros,
        jnp.full(x.shape[:1], -1, jnp.int32),
        jnp.zeros_like(x),
        jnp.zeros(x.shape[:1], bool),
        overflow,
    )


def write_blocks(result, blocks: Blocks, empty, block_size: int):
    """Writes the kept blocks' results into ``empty``, N rows of nothing found (all alike).

    Every block of the N rows reads its kept slot's rows, or ``empty``'s
    where it was not kept: one gather of whole blocks, fused with the
    choice and the cut to N rows, so each output row is written once.
    Measured 1.5-2x faster on the CPU (0.36 against 0.53-0.58 ms at 81,939
    rows, 4.1-5.1 against 6.3-10 ms at 10^6) than a scatter of the blocks
    into padded rows of zeros (zeros written, copied where XLA shares them
    between fields, scattered into, then cut to N rows: three writes of
    every row). Single rows measured slower than whole blocks: a gather (an
    index per row) took 1.5x the old scatter's time at 81,939 rows, a
    scatter 0.64x there and 1.0x at 10^6, where a gather of blocks took
    0.56x and 0.73x; an earlier scatter of single rows was also fused by XLA
    with the projection and recomputed per field.
    """
    num_rows = empty.segment.shape[0]
    num_blocks = -(-num_rows // block_size)
    capacity = blocks.index.shape[0]
    # Each block's slot in the kept buffer, -1 where it was not kept (empty
    # slots name block ``num_blocks`` and are dropped).
    slot = jnp.full((num_blocks,), -1, jnp.int32)
    slot = slot.at[blocks.index].set(jnp.arange(capacity, dtype=jnp.int32), mode="drop")
    kept = slot >= 0

    def put(full, part):
        if full.ndim == 0:
            return part
        if num_rows == 0:
            return full
        tail = full.shape[1:]
        read = part.reshape((capacity, block_size) + tail)[jnp.maximum(slot, 0)]
        # The rows of ``empty`` are all alike: its first fills the blocks not
        # kept, a constant XLA fuses (a padded copy of ``empty`` was written out).
        fill = full[:1].reshape((1, 1) + tail)
        chosen = jnp.where(kept.reshape((num_blocks,) + (1,) * (len(tail) + 1)), read, fill)
        return chosen.reshape((num_blocks * block_size,) + tail)[:num_rows]

    return jax.tree.map(put, empty, result)
