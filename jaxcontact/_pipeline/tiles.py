"""Tiles: the kept slaves grouped by cell, a few slaves to a tile, for one wide pass.

A tile is up to ``TILE`` kept slaves of one cell list. Every slave of a tile
meets the same segments, so the narrow phase scores a tile as one dense
block, ``cell_capacity`` segments by ``TILE`` slaves: each segment is
gathered once per tile, not once per pair, and the whole search is one pass
over ``(tiles, cell_capacity, TILE)`` with no loop.

Slaves whose list is empty (kept blocks hold many) get no tile. So the work
is the tiles the scene needs, at most ``Sizes.tile_capacity`` of them
(measured on the host, like every capacity); beyond it ``overflow`` is set.

Grouping is one sort of the kept slaves by their list, then ranks within a
list from a running maximum: no scatter-add and no loop.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.cells import CellLists
from jaxcontact._pipeline.sort import stable_order
from jaxcontact._types import Array

# Slaves per tile: each gathered segment serves eight slaves, while a list
# with fewer slaves (the chip's outline has one or two per cell) leaves at
# most seven slots of its tile empty.
TILE = 8


class Tiles(NamedTuple):
    """The kept slaves with a non-empty list, ``TILE`` of one list to a tile."""

    rows: Array  # i32[K, TILE]  kept slot of each tile's slave, S past the end (K = tiles)
    first: Array  # i32[K]  first entry of the tile's list
    count: Array  # i32[K]  entries of the tile's list (0 for an unused tile)
    needed: Array  # i32[]  tiles the slaves need; more than K overflows


def tile(listed: CellLists, capacity: int, num_tiles: int) -> Tiles:
    """The kept slaves of ``listed`` in ``num_tiles`` tiles; lists longer
    than ``capacity`` are cut to it (their cells overflowed already)."""
    num_rows = listed.first.shape[0]
    count = jnp.clip(listed.count, 0, capacity)
    # A list is named by its first entry; empty lists sort last, under one key.
    none = listed.order.shape[0] + 1
    key = jnp.where(count > 0, jnp.minimum(listed.first, none - 1), none)
    order = stable_order(key, none + 1)
    key = key[order]
    position = jnp.arange(num_rows, dtype=jnp.int32)
    starts = jnp.concatenate([jnp.ones((1,), bool), key[1:] != key[:-1]])
    rank = position - jax.lax.cummax(jnp.where(starts, position, 0))
    opens = starts | (rank % TILE == 0)
    index = jnp.cumsum(opens.astype(jnp.int32)) - 1
    real = key < none
    needed = jnp.sum(opens & real, dtype=jnp.int32)
    # Padding rows go past the last tile, where the scatters drop them.
    index = jnp.where(real, index, num_tiles)
    rows = jnp.full((num_tiles, TILE), num_rows, jnp.int32)
    rows = rows.at[index, rank % TILE].set(order, mode="drop")
    head = jnp.where(opens & real, index, num_tiles)
    first = jnp.zeros((num_tiles,), jnp.int32).at[head].set(key, mode="drop")
    length = jnp.zeros((num_tiles,), jnp.int32).at[head].set(count[order], mode="drop")
    return Tiles(rows, first, length, needed)
