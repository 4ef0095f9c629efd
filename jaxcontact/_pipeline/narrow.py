"""The narrow phase: each row against its candidate segments, lowest score wins.

Shared by every detector: ``search_all`` (each row against every segment:
``all_to_all``, ``swept``, and the bucket sort's kept slaves when there are
few segments) and ``search_listed`` or ``search_tiles`` (each kept slave
against its cell's segments: in chunks on the CPU, in tiles elsewhere;
``tiled``). All return segment indices only; the query's ``assemble``
(``_query``) turns them into results.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.broad import Box
from jaxcontact._pipeline.cells import CellLists, list_candidates, segments_in_slots
from jaxcontact._pipeline.geometry import Edge, edge
from jaxcontact._pipeline.lowest import UNROLL, lowest_in_blocks, lowest_score
from jaxcontact._pipeline.pairs import pick
from jaxcontact._pipeline.segments import Segments
from jaxcontact._pipeline.sort import stable_order
from jaxcontact._pipeline.tiles import tile
from jaxcontact._pipeline.triangles import face
from jaxcontact._types import Array, Sizes

# Up to this many pairs, ``search_all`` scores the whole plane at once (``_lowest_in_plane``).
PLANE_PAIRS = 1 << 15


class Queries(NamedTuple):
    """The rows a search scores, as the pair kernel takes them."""

    # The kernel's per-row arguments: f[S, 2] each (a point; a path's two
    # ends), then the rows' pair tags (``pairs.RowTags``) or None.
    rows: tuple
    query: Array  # f[S, 2]  the point whose cell is looked up
    ok: Array  # bool[S]  the row is real


def search_all(pair_value, segments: Segments, num_rows: int, dtype) -> tuple[Array, Array]:
    """``(i32[S], f[S])``: each row's lowest-scoring segment against every
    segment, and its score (``all_to_all``, ``swept``, and the bucket sort's
    kept slaves when there are few segments)."""

    # Each segment's own share of the kernel, for all at once (``Edge``;
    # ``Face`` in 3D), with what the pair rule reads of it (``pairs``).
    edges = (_shares(segments), segments.tags)

    def score(k):
        value = pair_value(jax.tree.map(lambda field: field[k], edges))
        value = jnp.where(segments.ok[k], value, jnp.inf)
        return value, jnp.broadcast_to(k, value.shape)

    num_segments = segments.ok.shape[0]
    if num_segments > UNROLL and num_rows * num_segments <= PLANE_PAIRS:
        return _lowest_in_plane(pair_value, edges, segments.ok, dtype)
    # Rows are not masked here but where the result is assembled: any per-row
    # mask fused into this loop made it 3-4x slower (measured).
    return lowest_score(score, num_segments, num_rows, dtype)


def _shares(segments: Segments):
    """Each segment's ``Edge``, or each triangle's ``Face`` (3D)."""
    if segments.apex is None:
        return edge(segments.start, segments.end)
    return face(segments.start, segments.end, segments.apex)


def _lowest_in_plane(pair_value, edges, segment_ok: Array, dtype):
    """``lowest_score``'s answer from the whole (M, S) plane of scores at once.

    For small scenes with more segments than ``lowest_score`` unrolls (the
    workpiece's own outline in ``sim.cutting``): one fused pass and one
    reduction, where the running minimum runs a loop of ``M / 8`` steps, a
    few kernels each, which is the whole of a small scene's time. ``argmin``
    takes the first of equal scores, the lower index, as the running minimum
    does; NaN scores are no candidate there (``value < best`` is False), so
    they are ``inf`` here.
    """
    values = jax.vmap(pair_value)(edges)
    values = jnp.where(segment_ok[:, None] & ~jnp.isnan(values), values, jnp.inf).astype(dtype)
    choice = jnp.argmin(values, axis=0).astype(jnp.int32)
    best = jnp.min(values, axis=0)
    return jnp.where(best < jnp.inf, choice, -1), best


def _search_rows(pair_value, segments: Segments, listed: CellLists, capacity: int, dtype):
    """``(i32[S], f[S])``: each row against the segments of its list, up to the
    fullest list's length; the choice and its score."""

    def score_block(slots):
        # A block of slots at once: one gather of their segments and ends,
        # f[S, B] values. Computed per row from the gathered ends: the same
        # numbers as ``search_all``'s, so both score a pair alike.
        segment = segments_in_slots(listed, slots)
        index = jnp.maximum(segment, 0)
        value = jax.vmap(pair_value, in_axes=1, out_axes=1)(
            (edge(segments.start[index], segments.end[index]), pick(segments.tags, index))
        )
        # Reused lists may name a segment masked or degenerate since.
        listed_ok = (segment >= 0) & segments.ok[index]
        return jnp.where(listed_ok, value, jnp.inf), segment

    # Each cell lists its segments in increasing order, so a block's first
    # lowest slot is the lower segment, as the running minimum takes it.
    # Blocks of 8 slots, each gathered at once and reduced along its rows:
    # one slot at a time (an unrolled running minimum, a gather per slot)
    # makes 47 more kernels of the binned closest step, which compiles 1.5x
    # slower (measured 5.9 against 3.9 s pinned, commit
    # 5928bf7f76cc:benchmarks/archive/compile_probe.py) for the same
    # answers bit for bit and no run time gained beyond noise (measured with the repository's
    # benchmarks/targets.py, both cores).
    # Every row runs as many slots as the fullest list among them needs, not
    # the capacity in the sizes (measured 1.3x faster on the rough die).
    fullest = jnp.max(listed.count, initial=0)
    return lowest_in_blocks(
        score_block, capacity, listed.first.shape[0], dtype, steps_needed=fullest
    )


def search_listed(kernel, rows, segments: Segments, listed: CellLists, sizes: Sizes):
    """``(i32[S], f[S])``: each kept slave against the segments of its cell, at
    most ``sizes.cell_capacity`` slots; the choice and its score.

    ``kernel(*row, row_tags, segment)`` scores a pair (``pairs.ruled``);
    ``rows`` are the kept slaves' f[S, ...]
    arrays. A row costs as many slots as the fullest list it is searched
    with. Kept blocks hold many slaves whose cells are empty (a block is kept
    when one of its rows meets the master's box), so above
    ``sizes.chunk_rows`` rows they are ordered by list length, longest
    first, and searched a chunk at a time, each chunk only as far as its
    own longest list; the loop stops at the first chunk of empty lists.
    Each row's answer does not depend on the order: it meets its own list
    in the same order either way.
    """
    num_rows, chunk_rows = listed.first.shape[0], sizes.chunk_rows
    capacity, dtype = sizes.cell_capacity, segments.start.dtype
    if num_rows <= chunk_rows:
        return _search_rows(vmapped(kernel, *rows), segments, listed, capacity, dtype)
    num_chunks = -(-num_rows // chunk_rows)
    pad = num_chunks * chunk_rows - num_rows
    # Longest first: a stable sort of (capacity - length), one int32 key.
    length = jnp.clip(listed.count, 0, capacity)
    order = stable_order(capacity - length, capacity + 1)

    # Rows in search order, padded to whole chunks with rows past the end
    # (empty lists). Each chunk gathers its own rows: the chunks after the
    # first of empty lists are never read, so gathering every kept row in
    # this order up front would be work for rows no chunk searches.
    order = jnp.pad(order, (0, pad), constant_values=num_rows)
    heads = order[::chunk_rows]
    # Each chunk's longest list comes first.
    longest = jnp.where(heads < num_rows, length[jnp.minimum(heads, num_rows - 1)], 0)

    def search_chunk(state):
        chunk, found = state
        at = chunk * chunk_rows
        index = jax.lax.dynamic_slice_in_dim(order, at, chunk_rows)
        real, index = index < num_rows, jnp.minimum(index, num_rows - 1)
        count = jnp.where(real, listed.count[index], 0)
        lists = CellLists(listed.first[index], count, listed.order)
        pair_value = vmapped(kernel, *jax.tree.map(lambda values: values[index], rows))
        chosen = _search_rows(pair_value, segments, lists, capacity, dtype)
        found = tuple(
            jax.lax.dynamic_update_slice_in_dim(whole, new, at, 0)
            for whole, new in zip(found, chosen, strict=True)
        )
        return chunk + 1, found

    def more(state):
        chunk = jnp.minimum(state[0], num_chunks - 1)
        return (state[0] < num_chunks) & (longest[chunk] > 0)

    padded = num_chunks * chunk_rows
    found = (jnp.full((padded,), -1, jnp.int32), jnp.full((padded,), jnp.inf, dtype))
    _, (choice, best) = jax.lax.while_loop(more, search_chunk, (jnp.zeros((), jnp.int32), found))
    order = order[:num_rows]
    choice = jnp.full((num_rows,), -1, jnp.int32).at[order].set(choice[:num_rows])
    return choice, jnp.full((num_rows,), jnp.inf, dtype).at[order].set(best[:num_rows])


def search_tiles(kernel, rows, segments: Segments, listed: CellLists, sizes: Sizes):
    """``((i32[S], f[S]), bool[])``: each kept slave against the segments of
    its cell, at most ``sizes.cell_capacity``; the choice, its score, and
    whether the tiles overflowed (``tiles``).

    One pass over ``(tiles, cell_capacity, TILE)`` pairs, with no loop: each
    tile's segments are gathered once for its ``TILE`` slaves, and the
    scores are reduced along the segments in the same fused pass. Each list
    holds its segments in increasing order, so the first lowest slot
    (``argmin``) is the lower segment, as every search breaks ties.
    ``kernel(*row, row_tags, segment)`` scores a pair (``pairs.ruled``);
    ``rows`` are the kept slaves' f[S, ...] arrays.
    """
    num_rows, capacity = listed.first.shape[0], sizes.cell_capacity
    dtype = segments.start.dtype
    num_tiles = sizes.tile_capacity or num_rows
    tiled = tile(listed, capacity, num_tiles)
    # i32[K, C]: each tile's segments, -1 past its list.
    lists = CellLists(tiled.first, tiled.count, listed.order)
    segment = segments_in_slots(lists, jnp.arange(capacity, dtype=jnp.int32))
    index = jnp.maximum(segment, 0)
    # Reused lists may name a segment masked or degenerate since.
    listed_ok = (segment >= 0) & segments.ok[index]
    edges = (edge(segments.start[index], segments.end[index]), pick(segments.tags, index))
    at = jnp.minimum(tiled.rows, num_rows - 1)
    tile_rows = jax.tree.map(lambda values: values[at], rows)

    def per_tile(tile_rows, edges):
        # f[C, TILE]: the tile's slaves against its segments.
        def per_segment(one):
            return jax.vmap(kernel, in_axes=(0,) * len(tile_rows) + (None,))(*tile_rows, one)

        return jax.vmap(per_segment)(edges)

    values = jax.vmap(per_tile)(tile_rows, edges)
    values = jnp.where(listed_ok[:, :, None] & ~jnp.isnan(values), values, jnp.inf).astype(dtype)
    best_slot = jnp.argmin(values, axis=1)
    best = jnp.min(values, axis=1)
    chosen = jnp.take_along_axis(segment, best_slot, axis=1)
    chosen = jnp.where(best < jnp.inf, chosen, -1)
    choice = jnp.full((num_rows,), -1, jnp.int32).at[tiled.rows].set(chosen, mode="drop")
    score = jnp.full((num_rows,), jnp.inf, dtype).at[tiled.rows].set(best, mode="drop")
    return (choice, score), tiled.needed > num_tiles


def choose(queries: Queries, segments: Segments, boxes: Box, kernel, sizes: Sizes, listed=None):
    """``((i32[S], f[S]), bool[])``: the chosen segment of each kept slave and
    its score, and whether the cells overflowed.

    Pairs are scored by ``kernel(*row, row_tags, segment)`` over ``queries.rows``. Rows
    that are not ``ok`` may hold any choice; the caller masks them.
    ``listed`` reuses candidate lists found before (``Search``).
    """
    num_rows, dtype = queries.query.shape[0], queries.query.dtype
    if not sizes.use_cells:
        pair_value = vmapped(kernel, *queries.rows)
        return search_all(pair_value, segments, num_rows, dtype), jnp.zeros((), bool)
    overflow = jnp.zeros((), bool)
    if listed is None:
        listed, overflow = list_candidates(queries.query, queries.ok, segments, boxes, sizes)
    if not tiled():
        return search_listed(kernel, queries.rows, segments, listed, sizes), overflow
    chosen, too_many = search_tiles(kernel, queries.rows, segments, listed, sizes)
    return chosen, overflow | too_many


# Which cell search runs: None lets the backend decide (``tiled``); tests and
# benchmarks set True or False to run either on any backend.
TILED = None


def tiled() -> bool:
    """Whether the cell search runs in tiles (``search_tiles``) or by list length in chunks
    (``search_listed``).

    Both give the same answers. On the CPU the chunks are faster: XLA's CPU
    code scores a pair in some 5-15 ns however the pairs are laid out, so the
    pairs a search scores decide its time, and the chunks run each list only
    as far as it is long, where a tile runs the cell capacity for all its
    slots (4-10 times the pairs on the dense reference scenes; measured with
    the repository's benchmarks/targets.py, its stage table). On a GPU the
    chunks' loop of dependent steps, each a few kernels, is what costs, and
    the tiles' one wide pass measured 1.1-34 times faster on an H100 (the
    larger the scene, the more).
    """
    return jax.default_backend() != "cpu" if TILED is None else TILED


def vmapped(kernel, *rows):
    """``pair_value(segment)`` mapping ``kernel(*rows, segment)`` over rows.

    ``segment`` is ``(Edge, segment tags)``: of one segment for all rows
    (f[2] ends) or one per row (f[S, 2] ends). Kernels come from
    ``pairs.ruled``; the last of ``rows`` are the rows' tags (or None).
    """

    def pair_value(segment: tuple[Edge, object]):
        axis = None if segment[0].start.ndim == 1 else 0
        return jax.vmap(kernel, in_axes=(0,) * len(rows) + (axis,))(*rows, segment)

    return pair_value


def in_stages(go: Array, stages, skipped, value=None):
    """Runs ``stages`` in turn, each on the last one's result, when ``go``.

    Each stage is its own ``lax.cond`` on ``go``, returning ``skipped[i]``
    when not. Besides skipping the work (no real row; no kept block), the
    cond boundaries keep XLA from fusing a search loop into the gathers that
    read its result: on the CPU it then re-runs the search per gathered value
    (measured 5x slower on the cutting scene), and ``optimization_barrier``
    does not stop that fusion there. Under ``vmap`` the conds become selects:
    both branches run and the boundaries are lost, which is why the searches
    run through ``lowest.one_scene_at_a_time``. ``value`` goes to the first
    stage.
    """
    for stage, empty in zip(stages, skipped, strict=True):
        value = jax.lax.cond(go, stage, lambda _, empty=empty: empty, value)
    return value
