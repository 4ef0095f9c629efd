"""Write-back: the kept slaves' results into N rows, and the rows of nothing found.

The bucket detectors compute on the S kept slaves only; this is the one
place where their rows meet all N.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._broad import Blocks
from jaxcontact._types import Array, Contact, Crossing


def empty_contact(x: Array, overflow: Array) -> Contact:
    zeros = jnp.zeros(x.shape[:1], x.dtype)
    false = jnp.zeros(x.shape[:1], bool)
    minus_one = jnp.full(x.shape[:1], -1, jnp.int32)
    return Contact(
        zeros, zeros, minus_one, jnp.zeros_like(x), jnp.zeros_like(x), false, false, overflow
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
