"""Write-back: the kept slaves' results into N rows, or the answered ones into K entries.

The sized search computes on the S kept slaves only; this is the one place
where their rows meet all N, or, for the list form (``ContactList``,
``CrossingList``), where the answered ones are packed into K entries. It
reads only the result types' fields, so every query shares it.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.broad import Blocks
from jaxcontact._pipeline.sort import first_true
from jaxcontact._types import Array

# What a row (or entry) of nothing found holds, by field: -1 for an index,
# else zero or False; vectors are f[..., 2].
INDEX_FIELDS = ("segment", "vertex")
FLAG_FIELDS = ("found", "active", "crossed")
VECTOR_FIELDS = ("point", "normal")


def fill_of(name: str):
    """The value a field holds where nothing was found."""
    if name in FLAG_FIELDS:
        return False
    return -1 if name in INDEX_FIELDS else 0


def empty(kind: type, num_rows: int, dtype, overflow: Array, num_slaves: int = 0):
    """``num_rows`` rows (or entries) of ``kind`` (a result or list type) of
    nothing found; a list's entries name slave ``num_slaves``, past the end."""

    def field(name):
        if name == "node":
            return jnp.full((num_rows,), num_slaves, jnp.int32)
        if name in INDEX_FIELDS:
            return jnp.full((num_rows,), -1, jnp.int32)
        if name in FLAG_FIELDS:
            return jnp.zeros((num_rows,), bool)
        shape = (num_rows, 2) if name in VECTOR_FIELDS else (num_rows,)
        return jnp.zeros(shape, dtype)

    return kind(
        **{name: field(name) for name in kind._fields if name != "overflow"}, overflow=overflow
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
    slots = first_true(flags, capacity)
    return jnp.minimum(slots, max(num_slots - 1, 0)), slots < num_slots, count


def pack(result, listing: type, flag: str, rows: Array, capacity: int, num_rows: int):
    """The answered rows of ``result`` (rows of S slots whose ``flag`` is set)
    packed into ``capacity`` entries of ``listing``, in increasing slot order.

    ``rows`` (i32[S], increasing where real) is each slot's slave row. The N
    rows are never written: where few slaves touch, writing them would be
    most of the call (measured 40 % on the cutting scene at 10^6 rows).
    """
    at, valid, count = first_slots(getattr(result, flag), capacity)

    def take(name):
        values = getattr(result, name)
        shape = valid.shape + (1,) * (values.ndim - 1)
        return jnp.where(valid.reshape(shape), values[at], fill_of(name))

    node = jnp.where(valid, rows[at], num_rows).astype(jnp.int32)
    skip = ("node", "overflow", flag)
    fields = {name: take(name) for name in listing._fields if name not in skip}
    return listing(
        node=node,
        **fields,
        **{flag: valid},
        overflow=result.overflow | (count > capacity),
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
    every row). Single rows measured slower than whole blocks: against that
    scatter of blocks, a gather (an index per row) took 1.5x its time at
    81,939 rows and a scatter of single rows 0.64x there and 1.0x at 10^6,
    where the gather of blocks took 0.56x and 0.73x.
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
        # kept, a constant XLA fuses (rather than a padded copy of ``empty`` written out).
        fill = full[:1].reshape((1, 1) + tail)
        chosen = jnp.where(kept.reshape((num_blocks,) + (1,) * (len(tail) + 1)), read, fill)
        return chosen.reshape((num_blocks * block_size,) + tail)[:num_rows]

    return jax.tree.map(put, empty, result)
