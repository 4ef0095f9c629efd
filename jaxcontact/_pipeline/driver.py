"""The driver: one query (``_query``) down the pipeline's stages, written once.

Two drivers, for every query alike:

- ``exhaustive``: every slave against every segment (``all_to_all``,
  ``swept``): sanitise, tag the pairs, the lowest score per row, assemble.
- ``sized``: the paper's bucket sort at static ``Sizes`` (``bucket_sort``,
  ``bucket_swept``, ``Search``):

  1. the cull (``broad``): the master's box, inflated by the query's reach,
     against blocks of slaves; the blocks that meet it go into a buffer of
     measured capacity;
  2. the narrow phase (``narrow``) on the kept slaves: with few segments
     each kept slave against every segment; with many, the segments binned
     into cells (``cells``) and each slave against its own cell's;
  3. the chosen pair assembled by the query (``_query``), and written into
     N rows or packed into K entries (``writeback``).

  When no block was kept, stages 2 and 3 are skipped (``in_stages``).
  Whenever ``overflow`` is False the result equals the exhaustive one.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline import writeback
from jaxcontact._pipeline.broad import Blocks, broad_phase, kept_rows
from jaxcontact._pipeline.lowest import one_scene_at_a_time
from jaxcontact._pipeline.narrow import Queries, choose, in_stages, search_all, vmapped
from jaxcontact._pipeline.pairs import EVERY_PAIR, Pairs, pick, ruled, tag
from jaxcontact._pipeline.placement import searched_whole
from jaxcontact._pipeline.segments import Segments, resolve_segments
from jaxcontact._pipeline.sizes import room_for_every_slot
from jaxcontact._types import Array, Sizes, Surface

# -- every slave against every segment ---------------------------------------


def _lowest(kernel, rows, segments: Segments, slave_ok):
    """i32[N]: per row, the segment of lowest ``kernel``; -1 if no row is real."""

    def search(_):
        pair_value = vmapped(kernel, *rows)
        return search_all(pair_value, segments, slave_ok.shape[0], segments.start.dtype)[0]

    return in_stages(jnp.any(slave_ok), [search], [jnp.full(slave_ok.shape, -1, jnp.int32)])


def _whole_vectors(points: tuple, mask, per_row, multiple: int):
    """``points``, ``mask`` and ``per_row`` (a pytree of per-row arrays)
    padded with masked rows of zeros to a multiple of ``multiple`` rows."""
    extra = -points[0].shape[0] % multiple
    if extra == 0:
        return points, mask, per_row
    ok = jnp.ones(points[0].shape[0], bool) if mask is None else mask

    def pad(values):
        return jnp.pad(values, ((0, extra),) + ((0, 0),) * (values.ndim - 1))

    padded = tuple(map(pad, points)), pad(ok), jax.tree.map(pad, per_row)
    # Written out once: a pad fused into the search's loops would keep the odd count.
    return jax.lax.optimization_barrier(padded)


@functools.partial(jax.jit, static_argnums=0)
@searched_whole(rows="points")
def exhaustive(query, points: tuple, surface: Surface, radius, mask, pairs: Pairs = EVERY_PAIR):
    """``query``'s N-row result, every slave against every segment.

    The search runs in a ``lax.cond`` (``in_stages``), scene by scene under
    ``vmap`` (``one_scene_at_a_time``). Masked rows are dropped when
    assembling, not inside the search's loop (a row mask fused into it
    makes it 3-4x slower, measured). Compiled as one program even when
    called outside ``jit``: op by op, the unrolled search takes seconds to
    dispatch.
    """
    num_rows = points[0].shape[0]
    per_row = (radius if radius is not None and jnp.ndim(radius) else None, pairs)
    points, mask, (per_row_radius, pairs) = _whole_vectors(
        points, mask, per_row, query.row_multiple
    )
    radius = radius if per_row_radius is None else per_row_radius
    points, slave_ok = query.sanitize(points, mask)
    segments = resolve_segments(surface)
    reach = query.pair_reach(points, slave_ok, radius)
    rule, tags, segments = tag(pairs, segments, surface.body, reach, points[0].shape[0])
    fixed = jax.lax.stop_gradient(((*points, tags), segments))
    search = one_scene_at_a_time(functools.partial(_lowest, ruled(query.kernel, rule)))
    choice = search(*fixed, slave_ok)
    no_overflow = jnp.zeros((), bool)
    result = query.assemble(points, segments, choice, radius, no_overflow, slave_ok, (rule, tags))
    if result.segment.shape[0] == num_rows:
        return result
    # The search writes whole vectors too: cut back after it, not fused into it.
    result = jax.lax.optimization_barrier(result)
    return jax.tree.map(lambda field: field[:num_rows] if field.ndim else field, result)


# -- the bucket sort at static sizes --------------------------------------------


class _Kept(NamedTuple):
    """The kept slaves of one sized search, and what their search needs."""

    points: tuple  # f[S, 2] each: the query's points of each kept slave, bad rows zeroed
    ok: Array  # bool[S]  kept and real
    rows: Array  # i32[S]  each kept slot's slave row, N past the end
    tags: object  # the kept rows' pair tags (``pairs.RowTags``) or None
    radius: object  # f[] or f[S]: the kept rows' radius (None for a query without one)


def _choose_if(kernel, sizes: Sizes, go, queries: Queries, segments: Segments, boxes, listed):
    """``((i32[S] choice, f[S] score), bool[] cells overflow)`` of the kept
    slaves; choices all -1 (scores inf) unless ``go``."""

    def search(_):
        return choose(queries, segments, boxes, kernel, sizes, listed)

    dtype = queries.query.dtype
    no_choice = (
        jnp.full(queries.ok.shape, -1, jnp.int32),
        jnp.full(queries.ok.shape, jnp.inf, dtype),
    )
    return in_stages(go, [search], [(no_choice, jnp.zeros((), bool))])


def _as_rows(query, kept: _Kept, chosen, segments, ruling, blocks: Blocks, sizes, go, num_rows):
    """The N-row result: the kept slaves assembled, then written into their ``num_rows`` rows.

    Assembly and write are each skipped when no block was kept.
    """
    dtype = kept.points[0].dtype
    no_overflow = jnp.zeros((), bool)

    def assemble(chosen):
        (choice, _), overflow = chosen
        return query.assemble(kept.points, segments, choice, kept.radius, overflow, kept.ok, ruling)

    def write(part):
        nothing = writeback.empty(query.result, num_rows, dtype, part.overflow)
        return writeback.write_blocks(part, blocks, nothing, sizes.block_size)

    skipped = (
        writeback.empty(query.result, kept.ok.shape[0], dtype, no_overflow),
        writeback.empty(query.result, num_rows, dtype, no_overflow),
    )
    return in_stages(go, [assemble, write], list(skipped), chosen)


def _as_entries(query, kept: _Kept, chosen, segments, ruling, sizes: Sizes, go, num_rows):
    """``(the K-entry result, i32[] entries needed)``: only the kept slaves
    that may hold an answer (``query.reportable``) are assembled, at most K
    of them, when a block was kept; then the answered ones packed.
    """
    capacity = sizes.contact_capacity
    dtype = kept.points[0].dtype
    no_overflow = jnp.zeros((), bool)

    def assemble(chosen):
        (choice, score), overflow = chosen
        may = query.reportable(choice, score, kept.ok, segments, kept.radius)
        at, valid, needed = writeback.first_slots(may, capacity)
        points = tuple(jnp.where(valid[:, None], values[at], 0) for values in kept.points)
        radius = kept.radius[at] if kept.radius is not None and kept.radius.ndim else kept.radius
        rule, tags = ruling
        part = query.assemble(
            points,
            segments,
            jnp.where(valid, choice[at], -1),
            radius,
            overflow | (needed > capacity),
            valid,
            (rule, pick(tags, at)),
        )
        return part, jnp.where(valid, kept.rows[at], num_rows), needed

    skipped = (
        writeback.empty(query.result, capacity, dtype, no_overflow),
        jnp.full((capacity,), num_rows, jnp.int32),
        jnp.zeros((), jnp.int32),
    )
    # The cond's boundary also keeps XLA from fusing the pair evaluation into
    # each field's gather in ``pack`` and running it once per field (2x
    # slower at 81,939 rows); the packing itself runs either way.
    part, rows, needed = in_stages(go, [assemble], [skipped], chosen)
    return writeback.pack(part, query.listing, query.flag, rows, capacity, num_rows), needed


@searched_whole(rows="points")
def sized(
    query,
    points: tuple,
    surface: Surface,
    radius,
    mask,
    sizes: Sizes,
    candidates=None,
    with_needed: bool = False,
    pairs: Pairs = EVERY_PAIR,
):
    """``query``'s bucket sort at ``sizes``: N rows, or K entries where the
    sizes have a ``contact_capacity`` (then with ``with_needed``, also the
    entries it needed). ``candidates`` (``candidates.Candidates``) replace
    the cull and the binning where a ``Search`` kept them."""
    # Bad rows are left in the points: the cull's test skips them, and the
    # kept rows are zeroed when gathered, so no pass over all N rows copies them.
    num_rows = points[0].shape[0]
    segments = resolve_segments(surface)
    low, high, cull_ok = query.row_boxes(points, mask)
    reach = query.pair_reach(points, cull_ok, radius)
    rule, tags, segments = tag(pairs, segments, surface.body, reach, num_rows)
    capacity = sizes.contact_capacity
    dtype = points[0].dtype
    no_overflow = jnp.zeros((), bool)
    if num_rows == 0 or segments.ok.shape[0] == 0:
        if capacity:
            nothing = writeback.empty(query.listing, capacity, dtype, no_overflow, num_rows)
            return (nothing, jnp.zeros((), jnp.int32)) if with_needed else nothing
        return writeback.empty(query.result, num_rows, dtype, no_overflow)
    if candidates is None:
        margin = query.inflate(points, radius, mask)
        culled, blocks = broad_phase(
            low, high, cull_ok, segments, margin, sizes.block_size, sizes.block_capacity
        )
        listed, overflow = None, blocks.overflow
    else:
        culled, blocks, listed = None, candidates.blocks, candidates.listed
        overflow = candidates.overflow
    gathered, ok = kept_rows(blocks, mask, *points)
    at = jnp.minimum(blocks.rows, num_rows - 1)
    kept_radius = radius[at] if radius is not None and radius.ndim else radius
    kept = _Kept(gathered, ok, blocks.rows, pick(tags, at), kept_radius)
    boxes = None if listed is not None else query.cell_boxes(segments, gathered, ok, culled)
    queries = Queries((*gathered, kept.tags), gathered[0], ok)
    go = blocks.count > 0
    search = one_scene_at_a_time(functools.partial(_choose_if, ruled(query.kernel, rule), sizes))
    fixed = jax.lax.stop_gradient((queries, segments, boxes))
    chosen = search(go, *fixed, listed)
    ruling = (rule, kept.tags)
    if not capacity:
        result = _as_rows(query, kept, chosen, segments, ruling, blocks, sizes, go, num_rows)
        return result._replace(overflow=result.overflow | overflow)
    result, needed = _as_entries(query, kept, chosen, segments, ruling, sizes, go, num_rows)
    result = result._replace(overflow=result.overflow | overflow)
    return (result, needed) if with_needed else result


# One program per query, shape and sizes, called plainly or inlined under jit.
sized_jit = jax.jit(sized, static_argnums=0, static_argnames=("sizes", "with_needed"))


def entries_needed(query, points, surface, radius, mask, sizes: Sizes, pairs, axes=None):
    """i32[] (i32[B] with ``axes``): the entries ``query``'s list form needs
    for this data (the kept slaves it assembles: ``query.reportable``).

    Runs the list form with an entry for every kept slave (a program of its
    own). ``axes``: ``vmap``'s ``in_axes`` of ``points, surface, mask,
    pairs`` for a batch (the points a tuple mapped alike).
    """
    wide = room_for_every_slot(sizes)

    def count(points, surface, mask, pairs):
        found = sized_jit(
            query, points, surface, radius, mask, sizes=wide, with_needed=True, pairs=pairs
        )
        return found[1]

    if axes is not None:
        count = jax.vmap(count, axes)
    return count(points, surface, mask, pairs)
