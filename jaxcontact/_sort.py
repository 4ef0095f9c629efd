"""Integer sorts shared by the cells, the search and the tie rule."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._types import Array


def stable_order(keys: Array, num_values: int) -> Array:
    """i32[E]: the stable ``argsort`` of ``keys``, integers in ``[0, num_values)``.

    Where ``key * E + position`` fits in int32 it is one sort of those
    unique numbers, with no payload: measured 5.6x faster on the CPU than
    ``argsort(stable=True)`` (2.9 against 16 ms for 90,000 entries), whose
    sort carries the positions as a second operand.
    """
    size = keys.shape[0]
    if num_values * size >= 2**31:
        return jnp.argsort(keys, stable=True).astype(jnp.int32)
    position = jnp.arange(size, dtype=jnp.int32)
    return jax.lax.sort(keys.astype(jnp.int32) * size + position) % size
