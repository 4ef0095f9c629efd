"""Bucket sort: search only what lies near the master.

The paper's bucket-sort strategy in fixed-size arrays. Three stages:

1. Preliminary phase (``_broad``): the master's box, inflated by the search
   distance, against the slaves; the blocks of slaves with a row that meets
   it go into a buffer of measured capacity. If none meets it the rest is skipped
   with ``lax.cond`` s (under ``vmap`` the search still skips, scene by
   scene on the CPU; the other stages run both branches, which stays right).
2. Narrow phase (``_narrow``) on the kept slaves: with few segments, each
   kept slave against every segment; with many, the segments binned into
   cells (``_cells``) and each slave against its own cell's segments.
3. The chosen pair evaluated by the same kernel as ``all_to_all``
   (``_assemble``) and written into rows of zeros (``_writeback``).

Whenever ``overflow`` is false the result equals ``all_to_all``'s (``swept``'s).
The sized forms here take static ``Sizes``; ``Search`` keeps them, and the
candidates found with a skin, across steps.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import threading
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact import _inputs
from jaxcontact._assemble import contact_from_choice, crossing_from_choice
from jaxcontact._broad import Blocks, broad_phase, conservative_margin, kept_rows, segment_boxes
from jaxcontact._cells import CellLists, list_candidates
from jaxcontact._dense import path_lengths, with_normals
from jaxcontact._geometry import first_hit_time, squared_distance
from jaxcontact._inputs import Segments, reach_of
from jaxcontact._lowest import one_scene_at_a_time
from jaxcontact._narrow import Queries, choose, in_stages
from jaxcontact._normals import CORNER_DEGREES, check_normals
from jaxcontact._padded import cut_entries, cut_rows, pad_contact_scene, pad_scene
from jaxcontact._pairs import NO_PAIRING, Pairing, pick, ruled, tag
from jaxcontact._placement import searched_whole
from jaxcontact._sizes import CELLS_ABOVE, Sizes, grow, measure
from jaxcontact._types import Array, Contact, ContactList, Crossing, CrossingList, Surface
from jaxcontact._writeback import (
    empty_contact,
    empty_contact_list,
    empty_crossing,
    empty_crossing_list,
    first_slots,
    pack_crossed,
    pack_found,
    write_blocks,
)


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
    slave_ok = _inputs.rows_ok(x, mask)
    segments = _inputs.resolve_segments(_inputs.with_pool(surface, pool))
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
    became real is reported as new only (since 0.7.4 its move from what it
    held as padding no longer sets the ``MOVED`` bit as well).
    """

    def not_finite_is_far(squared):
        # A real row's (or segment's) move that is not finite overflowed: stale.
        return jnp.where(jnp.isnan(squared), jnp.inf, squared)

    def largest_and_new(squared, ok, ok_then):
        """The largest real move, and whether a row is real that was not.

        Both read off one value per row (-1 for a new row), whose max and
        min XLA reduces in one pass: the N rows are read once a step.
        Squared lengths per column (``_inputs.squared_norm``). Measured on
        81,939 rows (``expired`` alone, jitted): 0.36-0.38 ms with
        ``jnp.sum(..., axis=-1)`` and two passes, 0.20 ms per column, 0.19
        in one pass.
        """
        value = jnp.where(ok, jnp.where(ok_then, not_finite_is_far(squared), -1), 0)
        return jnp.sqrt(jnp.max(value, initial=0)), jnp.min(value, initial=0) < 0

    row_ok = _inputs.rows_ok(x, mask)
    segments = _inputs.resolve_segments(surface)
    ends_then = _inputs.ends_of(candidates.nodes, segments.indices)
    ends_now = jnp.stack([segments.start, segments.end], axis=1)
    end_moves = jnp.maximum(
        *(_inputs.squared_norm(ends_now[:, k] - ends_then[:, k]) for k in (0, 1))
    )
    squared = _inputs.squared_norm(x - candidates.reference)
    rows_moved, new_rows = largest_and_new(squared, row_ok, candidates.row_ok)
    ends_moved, new_segments = largest_and_new(end_moves, segments.ok, candidates.segment_ok)
    moved = rows_moved + ends_moved
    rejoined = jnp.any(segments.ok & jnp.any(segments.indices != candidates.indices, axis=-1))
    reasons = ((moved > skin, MOVED), (new_rows, NEW_ROWS), (new_segments, NEW_SEGMENTS))
    bits = jnp.where(rejoined, REJOINED, 0)
    for flag, bit in reasons:
        bits = bits | jnp.where(flag, bit, 0)
    return bits.astype(jnp.int32)


class _How(NamedTuple):
    """How one detector searches its kept slaves: static, closed over."""

    kernel: Callable  # kernel(*row, row_tags, (Edge, segment tags)) -> f[]: _pairs.ruled
    sizes: Sizes
    assemble: Callable  # assemble(choice, overflow) -> Contact | Crossing of the kept slaves
    empty: Callable  # empty(rows, overflow) -> the not-found result
    num_rows: int  # N


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


def _searched(queries: Queries, blocks: Blocks, segments: Segments, boxes, listed, how: _How):
    """``(go, chosen)``: whether a block was kept, and ``_choose_if``'s result.

    The search is skipped when no block was kept (``_narrow.in_stages``) and
    runs scene by scene under ``vmap`` (``_lowest.one_scene_at_a_time``).
    """
    go = blocks.count > 0
    search = one_scene_at_a_time(functools.partial(_choose_if, how.kernel, how.sizes))
    return go, search(go, *jax.lax.stop_gradient((queries, segments, boxes)), listed)


def _search_kept(queries: Queries, blocks: Blocks, segments: Segments, boxes, listed, how: _How):
    """The narrow phase on the kept slaves and their rows written back.

    Search, ``how.assemble(choice, overflow)`` and the write into
    ``how.num_rows`` rows are each skipped when no block was kept.
    """
    no_overflow = jnp.zeros((), bool)
    go, chosen = _searched(queries, blocks, segments, boxes, listed, how)
    template = jnp.zeros((how.num_rows, 2), queries.query.dtype)

    def assemble(chosen):
        (choice, _), overflow = chosen
        return how.assemble(choice, overflow)

    def write(part):
        empty = how.empty(template, part.overflow)
        return write_blocks(part, blocks, empty, how.sizes.block_size)

    return in_stages(
        go,
        [assemble, write],
        [how.empty(queries.query, no_overflow), how.empty(template, no_overflow)],
        chosen,
    )


def _rounding_reach(segments: Segments, radius):
    """f[]: ``radius`` plus a bound on how far the search's score (its squared
    distance) and the reported gap may differ by rounding.

    They are two evaluations of one distance D that differ in how ``xi`` is
    rounded (a product with the inverse length, a quotient) and in the
    interior's gap being a dot product with the rounded unit normal: each is
    within a few ulps of ``D + 2 |d|`` (``_geometry._offset`` measures from
    the nearer end, ``|x - a| <= D + |d|``). 64 ulps of ``radius + 4 L``,
    L the longest real segment, bounds both with room to spare.
    """
    lengths = jnp.max(jnp.abs(segments.end - segments.start), axis=-1)
    longest = 2 * jnp.max(jnp.where(segments.ok, lengths, 0), initial=0)  # >= |d|
    eps = jnp.finfo(segments.start.dtype).eps
    return radius + 64 * eps * (radius + 4 * longest)


def _assemble_near(
    kept, ok, rows, segments: Segments, chosen, radius, capacity: int, num_rows, ruling
):
    """``(Contact, i32[K] rows, i32[] needed)`` of the kept slaves that can be found.

    Only slaves whose score says they may lie within the radius (within
    ``_rounding_reach``: every row the dense form finds, and a few at the
    radius to within rounding) are assembled, at most ``capacity`` of them
    (``needed`` says how many there were); the ``Contact`` of those is the
    dense form's rows (equal to rounding: XLA fuses this smaller pair
    evaluation differently). ``rows`` are their slave rows, N past the end.
    """
    (choice, best), overflow = chosen
    rule, tags = ruling
    reach = _rounding_reach(segments, radius)
    at, valid, needed = first_slots(ok & (choice >= 0) & (best <= reach * reach), capacity)
    x = jnp.where(valid[:, None], kept[at], 0)
    choice = jnp.where(valid, choice[at], -1)
    radius = radius[at] if radius.ndim else radius
    overflow = overflow | (needed > capacity)
    part = contact_from_choice(x, segments, choice, radius, overflow, valid, rule, pick(tags, at))
    return part, jnp.where(valid, rows[at], num_rows), needed


@searched_whole(rows="x")
def _contact(
    x,
    surface,
    radius,
    mask,
    sizes: Sizes,
    candidates: Candidates | None = None,
    with_needed: bool = False,
    pairing: Pairing = NO_PAIRING,
):
    """The sized bucket sort: a ``Contact``, or a ``ContactList`` where the
    sizes have a ``contact_capacity`` (then with ``with_needed``, also the
    entries it needed: ``measure_contacts``). ``radius`` is f[] or f[N]."""
    # Bad rows are left in ``x``: the broad phase's test skips them, and the
    # kept rows are zeroed when gathered, so no pass over all N rows copies x.
    segments = _inputs.resolve_segments(surface)
    rule, tags, segments = tag(pairing, segments, surface.body, radius)
    compact, num_rows = sizes.contact_capacity, x.shape[0]
    no_overflow = jnp.zeros((), bool)
    if compact:
        nothing = empty_contact_list(compact, num_rows, x.dtype, no_overflow)
        nothing = (nothing, jnp.zeros((), jnp.int32))
    if num_rows == 0 or segments.ok.shape[0] == 0:
        if compact:
            return nothing if with_needed else nothing[0]
        return empty_contact(x, no_overflow)
    if candidates is None:
        # Only the mask is given to the cull: a row with a NaN or an infinite
        # coordinate fails every comparison with the master's box, which is
        # finite (real segments are) or empty, and ``kept_rows`` tests the
        # kept rows. A finiteness test per row here was a pass over x of its
        # own, as long as the cull's (measured 0.09 of 0.6 ms at 81,939 rows).
        reach = _inputs.reach_of(radius, mask)
        boxes, blocks = broad_phase(
            x, x, mask, segments, reach, sizes.block_size, sizes.block_capacity
        )
        listed, overflow = None, blocks.overflow
    else:
        boxes, blocks, listed = None, candidates.blocks, candidates.listed
        overflow = candidates.overflow
    (kept,), ok = kept_rows(blocks, mask, x)
    at = jnp.minimum(blocks.rows, num_rows - 1)
    kept_tags = pick(tags, at)
    kept_radius = radius[at] if radius.ndim else radius

    def assemble(choice, cells_overflow):
        return contact_from_choice(
            kept, segments, choice, kept_radius, cells_overflow, ok, rule, kept_tags
        )

    how = _How(ruled(squared_distance, rule), sizes, assemble, empty_contact, num_rows)
    queries = Queries((kept, kept_tags), kept, ok)
    if not compact:
        result = _search_kept(queries, blocks, segments, boxes, listed, how)
        return result._replace(overflow=result.overflow | overflow)
    # The compact form assembles only the kept slaves that can be found, then
    # packs the found ones (``_compact_stages``).
    go, chosen = _searched(queries, blocks, segments, boxes, listed, how)

    def assemble_near(chosen):
        return _assemble_near(
            kept, ok, blocks.rows, segments, chosen, kept_radius, compact, num_rows, ruling
        )

    ruling = (rule, kept_tags)
    stages = (assemble_near, pack_found, empty_contact)
    return _compact_stages(go, chosen, stages, nothing, num_rows, overflow, with_needed)


def _compact_stages(go, chosen, stages, nothing, num_rows: int, overflow, with_needed: bool):
    """The compact forms' result: ``assemble(chosen) -> (part, rows, needed)``
    on at most K kept slots, then ``pack(part, rows, K, N)`` into K entries;
    each stage skipped unless ``go`` (``in_stages``), ``empty`` making the
    skipped part and ``nothing`` the skipped ``(entries, needed)``. Apart, so
    that XLA does not fuse the pair evaluation into each field's gather and
    run it once per field (measured 2x slower at 81,939 rows)."""
    assemble, pack, empty = stages
    capacity, dtype = nothing[0].node.shape[0], nothing[0].point.dtype
    skipped = (empty(jnp.zeros((capacity, 2), dtype), jnp.zeros((), bool)),)
    skipped += (jnp.full((capacity,), num_rows, jnp.int32), jnp.zeros((), jnp.int32))

    def packed(part_rows_needed):
        part, rows, needed = part_rows_needed
        return pack(part, rows, capacity, num_rows), needed

    result, needed = in_stages(go, [assemble, packed], [skipped, nothing], chosen)
    result = result._replace(overflow=result.overflow | overflow)
    return (result, needed) if with_needed else result


@searched_whole(rows="x")
def _crossing(
    x_prev, x, surface, mask, sizes: Sizes, pairing: Pairing = NO_PAIRING, with_needed=False
):
    """The sized swept bucket sort: a ``Crossing``, or a ``CrossingList``
    where the sizes have a ``contact_capacity`` (then with ``with_needed``,
    also the entries it needed: ``measure_crossings``)."""
    slave_ok = _inputs.paths_ok(x_prev, x, mask)
    segments = _inputs.resolve_segments(surface)
    lengths = jnp.where(slave_ok, path_lengths(x_prev, x), 0)
    rule, tags, segments = tag(pairing, segments, surface.body, lengths)
    compact, num_rows = sizes.contact_capacity, x.shape[0]
    no_overflow = jnp.zeros((), bool)
    if compact:
        nothing = empty_crossing_list(compact, num_rows, x.dtype, no_overflow)
        nothing = (nothing, jnp.zeros((), jnp.int32))
    if x.shape[0] == 0 or segments.ok.shape[0] == 0:
        if compact:
            return nothing if with_needed else nothing[0]
        return empty_crossing(x, no_overflow)
    # A path meets a segment only if their boxes meet.
    path_low, path_high = jnp.minimum(x_prev, x), jnp.maximum(x_prev, x)
    no_reach = jnp.zeros((), x.dtype)
    _, blocks = broad_phase(
        path_low, path_high, slave_ok, segments, no_reach, sizes.block_size, sizes.block_capacity
    )
    (start, end), ok = kept_rows(blocks, mask, x_prev, x)
    kept_tags = pick(tags, jnp.minimum(blocks.rows, x.shape[0] - 1))
    # Where a path meets a segment, its start lies within the path's length
    # of that segment: bin the segments inflated by the longest kept path and
    # look up each path's start (the paper's boxes inflated by d_max).
    longest = jnp.max(jnp.where(ok, jnp.max(jnp.abs(end - start), axis=-1), 0), initial=0)
    boxes = segment_boxes(segments, conservative_margin(longest, segments.start, segments.end))

    def assemble(choice, overflow):
        return crossing_from_choice(start, end, segments, choice, overflow, ok)

    how = _How(ruled(first_hit_time, rule), sizes, assemble, empty_crossing, x.shape[0])
    queries = Queries((start, end, kept_tags), start, ok)
    if not compact:
        result = _search_kept(queries, blocks, segments, boxes, None, how)
        return result._replace(overflow=result.overflow | blocks.overflow)
    # The compact form assembles only the kept paths the search chose a
    # segment for, then packs the crossed ones (``_compact_stages``).
    go, chosen = _searched(queries, blocks, segments, boxes, None, how)

    def assemble_chosen(chosen):
        (choice, _), overflow = chosen
        at, valid, needed = first_slots(ok & (choice >= 0), compact)
        part = crossing_from_choice(
            jnp.where(valid[:, None], start[at], 0),
            jnp.where(valid[:, None], end[at], 0),
            segments,
            jnp.where(valid, choice[at], -1),
            overflow | (needed > compact),
            valid,
        )
        return part, jnp.where(valid, blocks.rows[at], num_rows), needed

    stages = (assemble_chosen, pack_crossed, empty_crossing)
    return _compact_stages(go, chosen, stages, nothing, num_rows, blocks.overflow, with_needed)


# One program per shape and sizes, called plainly or inlined under jit.
find_jit = jax.jit(find, static_argnames="sizes")
contact_jit = jax.jit(_contact, static_argnames=("sizes", "with_needed"))
crossing_jit = jax.jit(_crossing, static_argnames=("sizes", "with_needed"))


def sized_bucket_sort(
    x, surface, *, radius, mask=None, sizes: Sizes, candidates=None, **pair_keywords
) -> Contact:
    """``bucket_sort`` at given ``Sizes`` (and reused ``candidates``), inputs
    checked as the public detectors check them; runs under ``jit`` and
    ``vmap`` (``sizes`` is static). ``Search``, the benchmarks and the tests
    call it. ``pair_keywords``: ``slave_node``, ``slave_body``, ``self_contact``."""
    x, surface, radius, mask = _inputs.check_contact_inputs(x, surface, radius, mask)
    pairing = _check_pairing(pair_keywords, x, surface, mask)
    check_sizes(sizes, x.shape[0], for_paths=False)
    return contact_jit(
        x, surface, radius, mask, sizes=sizes, candidates=candidates, pairing=pairing
    )


def _check_pairing(pair_keywords: dict, x, surface: Surface, mask) -> Pairing:
    """The ``Pairing`` of a detector's pair keywords (checked)."""
    unknown = set(pair_keywords) - {"slave_node", "slave_body", "self_contact"}
    if unknown:
        raise TypeError(f"unexpected keyword arguments {sorted(unknown)}")
    return _inputs.check_pairing(
        pair_keywords.get("slave_node"),
        pair_keywords.get("slave_body"),
        pair_keywords.get("self_contact", False),
        x,
        surface,
        mask,
    )


def room_for_every_slot(sizes: Sizes) -> Sizes:
    """``sizes`` whose compact form has an entry for every kept slave: it cannot overflow."""
    return dataclasses.replace(sizes, contact_capacity=max(1, sizes.slave_capacity))


def entries_needed(x, surface, radius, mask, sizes: Sizes, pairing=NO_PAIRING) -> Array:
    """i32[]: the entries the compact form needs for this data (the slaves it
    assembles: those found, and any at the radius to within rounding).

    Runs the compact search with an entry for every kept slave (a program of
    its own); ``vmap`` it for a batch.
    """
    wide = room_for_every_slot(sizes)
    return contact_jit(x, surface, radius, mask, sizes=wide, with_needed=True, pairing=pairing)[1]


def measure_contacts(
    x, surface, radius, mask, sizes: Sizes, slack: float, axes=None, pairing=NO_PAIRING
) -> Sizes:
    """``sizes`` with the compact form's capacity: the entries needed now times
    ``slack`` (at least 1), as ``measure`` sizes the rest (concrete inputs).
    With ``axes`` (``vmap``'s ``in_axes`` of ``x, surface, mask, pairing``),
    the largest need of a batch."""
    radius = jnp.asarray(radius, x.dtype)

    def count(x, surface, mask, pairing):
        return entries_needed(x, surface, radius, mask, sizes, pairing)

    if axes is not None:
        count = jax.vmap(count, axes)
    needed = int(np.max(np.asarray(count(x, surface, mask, pairing))))
    return dataclasses.replace(sizes, contact_capacity=grow(needed, slack))


def crossings_needed(x_prev, x, surface, mask, sizes: Sizes, pairing=NO_PAIRING) -> Array:
    """i32[]: the entries the compact swept form needs for this data (the
    paths the search chose a segment for), as ``entries_needed``."""
    wide = room_for_every_slot(sizes)
    return crossing_jit(x_prev, x, surface, mask, sizes=wide, with_needed=True, pairing=pairing)[1]


def measure_crossings(
    x_prev, x, surface, mask, sizes: Sizes, slack: float, pairing, axes=None
) -> Sizes:
    """``sizes`` (for paths) with the compact swept form's capacity: the
    entries needed now times ``slack`` (at least 1), as ``measure_contacts``
    (``axes``: ``vmap``'s ``in_axes`` of ``x, surface, mask, pairing``; the
    paths ``x_prev`` are batched as ``x``)."""

    def count(x_prev, x, surface, mask, pairing):
        return crossings_needed(x_prev, x, surface, mask, sizes, pairing)

    if axes is not None:
        count = jax.vmap(count, (axes[0], *axes))
    needed = int(np.max(np.asarray(count(x_prev, x, surface, mask, pairing))))
    return dataclasses.replace(sizes, contact_capacity=grow(needed, slack))


def sized_bucket_swept(
    x_prev, x, surface, *, mask=None, sizes: Sizes, **pair_keywords
) -> Crossing | CrossingList:
    """``bucket_swept`` at given ``Sizes``, inputs checked; as ``sized_bucket_sort``
    (a ``CrossingList`` where the sizes have a ``contact_capacity``)."""
    x_prev, x, mask = _inputs.check_path_inputs(x_prev, x, mask)
    surface = _inputs.check_surface(surface, x.dtype)
    pairing = _check_pairing(pair_keywords, x, surface, mask)
    check_sizes(sizes, x.shape[0], for_paths=True)
    return crossing_jit(x_prev, x, surface, mask, sizes=sizes, pairing=pairing)


def check_sizes(sizes, num_slaves: int, for_paths: bool):
    """Sizes made for this many slaves and this detector, or a ``ValueError``."""
    if not isinstance(sizes, Sizes):
        raise ValueError(f"sizes must be jaxcontact Sizes; got {type(sizes).__name__}")
    if sizes.num_slaves != num_slaves:
        raise ValueError(f"sizes were made for {sizes.num_slaves} slaves; x has {num_slaves} rows")
    if sizes.for_paths != for_paths:
        wanted = "paths (allocate with x_prev=)" if for_paths else "closest points (a radius)"
        raise ValueError(f"sizes were made for the other query; this one needs sizes for {wanted}")


def require_concrete(name: str, values, hint: str | None = None):
    """A ``ValueError`` when ``values`` are traced: sizes are measured on the host."""
    if any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(values)):
        hint = hint or (
            "use jaxcontact.Search (allocate once outside, then search.closest / "
            "search.swept inside)"
        )
        raise ValueError(
            f"{name} measures its sizes from concrete data, so it cannot run under jit, "
            f"vmap or grad of its inputs: {hint}"
        )


# The one-call forms keep their sizes, as a ``Search`` keeps them for its
# caller: per query, result form and padded input shapes and dtypes, the
# sizes last measured. A call runs with them and measures again only when
# they overflow (then the search runs again at the new sizes), so that a
# plain call on a scene that changes little costs one search, not a measure
# and a search (issue 25, target 2: ``python benchmarks/one_call.py``). Never
# a different answer: without overflow a result is all_to_all's (swept's)
# whatever the sizes. The KEPT_SIZES signatures used last are kept.
KEPT_SIZES = 64
_kept_sizes: collections.OrderedDict = collections.OrderedDict()
_kept_lock = threading.Lock()  # plain calls from several threads share the table


def _signature(*values) -> tuple:
    """Hashable: the tree structure, shapes and dtypes of ``values`` (and a
    ``Pairing``'s static ``self_contact``)."""
    leaves, structure = jax.tree.flatten(values)
    dtypes = (leaf.dtype if hasattr(leaf, "dtype") else np.asarray(leaf).dtype for leaf in leaves)
    return structure, tuple(zip(map(np.shape, leaves), dtypes, strict=True))


def with_kept_sizes(key, sizes_now: Callable[[], Sizes], search: Callable[[Sizes], object]):
    """``search(sizes)`` at the sizes kept under ``key`` when they do not
    overflow; else at ``sizes_now()``, which are kept instead."""
    with _kept_lock:
        kept = _kept_sizes.get(key)
    if kept is not None:
        found = search(kept)
        if not bool(found.overflow):
            _keep(key, kept)
            return found
    sizes = sizes_now()
    _keep(key, sizes)
    return search(sizes)


def _keep(key, sizes: Sizes) -> None:
    """``sizes`` kept under ``key``, as the last used; the oldest dropped past KEPT_SIZES."""
    with _kept_lock:
        _kept_sizes[key] = sizes
        _kept_sizes.move_to_end(key)
        while len(_kept_sizes) > KEPT_SIZES:
            _kept_sizes.popitem(last=False)


def forget_sizes() -> None:
    """Drops the one-call forms' kept sizes: the next calls measure again."""
    with _kept_lock:
        _kept_sizes.clear()


def bucket_sort(
    x: Array,
    surface: Surface,
    *,
    radius,
    mask: Array | None = None,
    compact: bool = False,
    slave_node: Array | None = None,
    slave_body: Array | None = None,
    self_contact: bool = False,
    normals: str = "flat",
    corner: float = CORNER_DEGREES,
) -> Contact | ContactList:
    """Closest master segment of every slave near the master, by bucket sort.

    The one-call form: it measures the sizes of the bucket sort from the data
    (on the host) and runs it, so it needs concrete inputs. Inside ``jit``,
    ``lax.scan``, ``vmap`` or ``grad``, and to reuse sizes and candidates
    over the steps of a simulation, use ``Search``.

    Args:
      x: f[N, 2] slave coordinates. Rows close in the input should be close in
        space (a mesh numbering is): slaves are culled in blocks of rows.
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: search radius, >= 0: a scalar, or f[N] one per slave.
      mask: optional bool[N], False for padding slaves.
      compact: return the found contacts only, as a ``ContactList`` with an
        entry for every slave the broad phase kept (``Search(compact=True)``
        measures a tighter capacity once and reuses it).
      slave_node, slave_body, self_contact: the pair rule, as for
        ``all_to_all``.
      normals, corner: flat or smooth normals, as for ``all_to_all``.

    Returns:
      A ``Contact`` equal to ``all_to_all``'s, ``overflow`` False, or its
      ``ContactList``. The sizes last measured at the same padded shapes are
      reused while they hold (as a ``Search`` holds them), and measured again
      for this data when a search at them overflows.

    Example:
      >>> from jaxcontact import all_to_all, bucket_sort
      >>> from jaxcontact.scenes import cutting_scene
      >>> scene = cutting_scene(2_000, 18.0)
      >>> contact = bucket_sort(scene.x, scene.surface, radius=scene.radius)
      >>> bool(contact.overflow), int(contact.found.sum())
      (False, 13)
      >>> bool((contact.segment == all_to_all(scene.x, scene.surface, radius=0.1).segment).all())
      True
    """
    x, surface, radius, mask = _inputs.check_contact_inputs(x, surface, radius, mask)
    pairing = _inputs.check_pairing(slave_node, slave_body, self_contact, x, surface, mask)
    corner = check_normals(normals, corner)
    require_concrete("bucket_sort", (x, surface, radius, mask, pairing))
    use_cells = surface.segments.shape[0] > CELLS_ABOVE
    x, mask, surface, radius, pairing, num_rows = pad_contact_scene(
        x, mask, surface, radius, pairing
    )

    def sizes_now():
        return measure(x, surface, radius=reach_of(radius, mask), mask=mask, use_cells=use_cells)

    def search(sizes):
        sizes = room_for_every_slot(sizes) if compact else sizes
        return contact_jit(x, surface, radius, mask, sizes=sizes, pairing=pairing)

    key = ("closest", compact, use_cells, _signature(x, mask, surface, radius, pairing))
    found = with_kept_sizes(key, sizes_now, search)
    found = with_normals(found, x, surface, normals, corner)
    return cut_entries(found, num_rows) if compact else cut_rows(found, num_rows)


def bucket_swept(
    x_prev: Array,
    x: Array,
    surface: Surface,
    *,
    mask: Array | None = None,
    compact: bool = False,
    slave_node: Array | None = None,
    slave_body: Array | None = None,
    self_contact: bool = False,
) -> Crossing | CrossingList:
    """First crossing of every slave's path with the master, by bucket sort.

    The broad phase works on the boxes of the paths ``x_prev -> x``; the cells
    hold the segments inflated by the longest path (the paper's ``d_max``).
    The one-call form, for concrete inputs: under ``jit`` use ``Search``.

    Args:
      x_prev: f[N, 2] previous slave positions.
      x: f[N, 2] current slave positions.
      surface: the master ``Surface``.
      mask: optional bool[N], False for padding slaves.
      compact: return the crossed paths only, as a ``CrossingList`` with an
        entry for every path the broad phase kept (``Search(compact=True)``
        measures a tighter capacity once and reuses it).
      slave_node, slave_body, self_contact: the pair rule, as for ``swept``.

    Returns:
      A ``Crossing`` equal to ``swept``'s, ``overflow`` False, or its
      ``CrossingList``; sizes kept and measured again as ``bucket_sort``'s.
    """
    x_prev, x, mask = _inputs.check_path_inputs(x_prev, x, mask)
    surface = _inputs.check_surface(surface, x_prev.dtype)
    pairing = _inputs.check_pairing(slave_node, slave_body, self_contact, x, surface, mask)
    require_concrete("bucket_swept", (x_prev, x, surface, mask, pairing))
    use_cells = surface.segments.shape[0] > CELLS_ABOVE
    (x_prev, x), mask, surface, pairing, num_rows = pad_scene((x_prev, x), mask, surface, pairing)

    def sizes_now():
        return measure(x, surface, x_prev=x_prev, mask=mask, use_cells=use_cells)

    def search(sizes):
        sizes = room_for_every_slot(sizes) if compact else sizes
        return crossing_jit(x_prev, x, surface, mask, sizes=sizes, pairing=pairing)

    key = ("swept", compact, use_cells, _signature(x_prev, x, mask, surface, pairing))
    crossing = with_kept_sizes(key, sizes_now, search)
    return cut_entries(crossing, num_rows) if compact else cut_rows(crossing, num_rows)
