"""Bucket sort: search only what lies near the master.

The paper's bucket-sort strategy in fixed-size arrays. Three stages:

1. Preliminary phase (``_broad``): the master's box, inflated by the search
   distance, against boxes of blocks of slaves; the blocks that meet it go
   into a buffer of planned capacity. If none meets it the rest is skipped
   with a ``lax.cond`` (under ``vmap`` a ``cond`` runs both branches; the
   result is still right, only the saving is lost).
2. Narrow phase on the kept slaves: with few segments, each kept slave
   against every segment; with many, the segments binned into cells
   (``_cells``) and each slave against its own cell's segments.
3. The chosen pair evaluated by the same kernel as ``all_to_all`` and written
   into rows of zeros.

Whenever ``overflow`` is false the result equals ``all_to_all``'s (``swept``'s).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact import _inputs
from jaxcontact._assemble import contact_from_choice, crossing_from_choice
from jaxcontact._broad import (
    Box,
    block_boxes,
    conservative_margin,
    cull_blocks,
    enclosing,
    segment_boxes,
)
from jaxcontact._cells import Grid, bin_segments, candidates, cell_of, flat_cell
from jaxcontact._geometry import path_hit, squared_distance
from jaxcontact._inputs import Segments
from jaxcontact._plan import BucketPlan, plan_buckets
from jaxcontact._search import lowest_score
from jaxcontact._types import Array, Contact, Crossing, Surface


def _empty_contact(x: Array, overflow: Array) -> Contact:
    zeros = jnp.zeros(x.shape[:1], x.dtype)
    false = jnp.zeros(x.shape[:1], bool)
    minus_one = jnp.full(x.shape[:1], -1, jnp.int32)
    return Contact(zeros, zeros, minus_one, jnp.zeros_like(x), jnp.zeros_like(x), false, false, overflow)


def _empty_crossing(x: Array, overflow: Array) -> Crossing:
    zeros = jnp.zeros(x.shape[:1], x.dtype)
    return Crossing(
        zeros, jnp.full(x.shape[:1], -1, jnp.int32), jnp.zeros_like(x), jnp.zeros(x.shape[:1], bool), overflow
    )


def _scatter_rows(result, rows: Array, empty):
    """Writes the kept rows' results into the all-zero result ``empty``."""
    return jax.tree.map(
        lambda full, part: full if full.ndim == 0 else full.at[rows].set(part, mode="drop", unique_indices=True),
        empty,
        result,
    )


def _choose(query: Array, ok: Array, segments: Segments, boxes: Box, pair_value, plan: BucketPlan):
    """i32[S] chosen segment of each kept slave, and whether the cells overflowed.

    Args:
      query: f[S, 2] the point whose cell decides the candidates.
      ok: bool[S] kept slave is real.
      segments: resolved segments.
      boxes: f[M, 2] segment boxes inflated by the search distance.
      pair_value: ``pair_value(rows, start, end) -> f[S]`` (inf where no hit),
        ``start``/``end`` either f[2] for all rows or f[S, 2] per row.
      plan: the static sizes.
    """
    num_rows, num_segments = query.shape[0], segments.ok.shape[0]
    if not plan.use_cells:

        def dense_score(k):
            value = pair_value(segments.start[k], segments.end[k])
            return jnp.where(ok & segments.ok[k], value, jnp.inf), jnp.broadcast_to(k, value.shape)

        choice = lowest_score(dense_score, num_segments, num_rows, query.dtype, ordered=True)
        return choice, jnp.zeros((), bool)

    shape = plan.grid_shape
    master = enclosing(boxes)
    low = jnp.maximum(master.low, jnp.min(jnp.where(ok[:, None], query, jnp.inf), axis=0))
    high = jnp.minimum(master.high, jnp.max(jnp.where(ok[:, None], query, -jnp.inf), axis=0))
    extent = jnp.where(jnp.isfinite(high - low) & (high > low), high - low, 0)
    origin = jnp.where(jnp.isfinite(low), low, 0)
    # The grid always covers the region: cells grow when the region does.
    cell_size = jnp.maximum(plan.cell_size, jnp.max(extent / jnp.asarray(shape, query.dtype)))
    grid = Grid(origin, cell_size.astype(query.dtype))
    bins = bin_segments(boxes, segments.ok, grid, shape, plan.span, plan.cell_capacity)
    no_cell = shape[0] * shape[1]
    cells = jnp.where(ok, flat_cell(cell_of(query, grid, shape), shape), no_cell)
    listed = candidates(cells, bins, plan.cell_capacity)

    def cell_score(slot):
        segment = listed[:, slot]
        index = jnp.maximum(segment, 0)
        value = pair_value(segments.start[index], segments.end[index])
        return jnp.where(segment >= 0, value, jnp.inf), segment

    # Each cell lists its segments in increasing order.
    choice = lowest_score(cell_score, plan.cell_capacity, num_rows, query.dtype, ordered=True)
    return choice, bins.overflow


def _vmapped(kernel, *rows):
    """``pair_value(start, end)`` mapping ``kernel(*row, start, end)`` over rows."""

    def pair_value(start, end):
        axis = None if start.ndim == 1 else 0
        return jax.vmap(kernel, in_axes=(0,) * len(rows) + (axis, axis))(*rows, start, end)

    return pair_value


def _check_plan(plan, num_slaves: int, for_paths: bool):
    if not isinstance(plan, BucketPlan):
        raise ValueError(f"plan must be a jaxcontact.BucketPlan; got {type(plan).__name__}")
    if plan.num_slaves != num_slaves:
        raise ValueError(f"plan was made for {plan.num_slaves} slaves; x has {num_slaves} rows")
    if plan.for_paths != for_paths:
        wanted = "plan_buckets(x, surface, x_prev=...)" if for_paths else "plan_buckets(x, surface, radius=...)"
        raise ValueError(f"plan was made for the other detector; make one with {wanted}")


def _contact_impl(x, surface, radius, mask, plan):
    x, slave_ok = _inputs.sanitize_points(x, mask)
    segments = _inputs.resolve_segments(surface)
    num_rows = x.shape[0]
    no_overflow = jnp.zeros((), bool)
    if num_rows == 0 or segments.ok.shape[0] == 0:
        return _empty_contact(x, no_overflow)
    reach = conservative_margin(radius, segments.start, segments.end)
    boxes = segment_boxes(segments, reach)
    blocks = cull_blocks(
        block_boxes(x, x, slave_ok, plan.block_size), enclosing(boxes), num_rows, plan.block_size,
        plan.block_capacity,
    )

    def narrow(_):
        rows = jnp.minimum(blocks.rows, num_rows - 1)
        kept, ok = x[rows], slave_ok[rows] & (blocks.rows < num_rows)
        choice, overflow = _choose(kept, ok, segments, boxes, _vmapped(squared_distance, kept), plan)
        part = contact_from_choice(kept, segments, jax.lax.stop_gradient(choice), radius, overflow)
        return _scatter_rows(part, blocks.rows, _empty_contact(x, overflow))

    result = jax.lax.cond(blocks.count > 0, narrow, lambda _: _empty_contact(x, no_overflow), None)
    return result._replace(overflow=result.overflow | blocks.overflow)


def _crossing_impl(x_prev, x, surface, mask, plan):
    x_prev, x, slave_ok = _inputs.check_paths(x_prev, x, mask)
    segments = _inputs.resolve_segments(surface)
    num_rows = x.shape[0]
    no_overflow = jnp.zeros((), bool)
    if num_rows == 0 or segments.ok.shape[0] == 0:
        return _empty_crossing(x, no_overflow)
    # A path meets a segment only if their boxes meet.
    touching = segment_boxes(segments, conservative_margin(jnp.zeros((), x.dtype), segments.start, segments.end))
    path_low, path_high = jnp.minimum(x_prev, x), jnp.maximum(x_prev, x)
    blocks = cull_blocks(
        block_boxes(path_low, path_high, slave_ok, plan.block_size), enclosing(touching), num_rows,
        plan.block_size, plan.block_capacity,
    )

    def narrow(_):
        rows = jnp.minimum(blocks.rows, num_rows - 1)
        start, end = x_prev[rows], x[rows]
        ok = slave_ok[rows] & (blocks.rows < num_rows)
        # Where a path meets a segment, its start lies within the path's length
        # of that segment: bin the segments inflated by the longest kept path
        # and look up each path's start (the paper's boxes inflated by d_max).
        longest = jnp.max(jnp.where(ok, jnp.max(jnp.abs(end - start), axis=-1), 0), initial=0)
        boxes = segment_boxes(segments, conservative_margin(longest, segments.start, segments.end))

        def hit_time(x_prev, x, a, b):
            hit = path_hit(x_prev, x, a, b)
            return jnp.where(hit.hit, hit.t, jnp.inf)

        choice, overflow = _choose(start, ok, segments, boxes, _vmapped(hit_time, start, end), plan)
        part = crossing_from_choice(start, end, segments, jax.lax.stop_gradient(choice), overflow)
        return _scatter_rows(part, blocks.rows, _empty_crossing(x, overflow))

    result = jax.lax.cond(blocks.count > 0, narrow, lambda _: _empty_crossing(x, no_overflow), None)
    return result._replace(overflow=result.overflow | blocks.overflow)


_contact_jit = jax.jit(_contact_impl, static_argnames="plan")
_crossing_jit = jax.jit(_crossing_impl, static_argnames="plan")


def _is_traced(*values) -> bool:
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(values))


def bucket_sort(
    x: Array, surface: Surface, *, radius, mask: Array | None = None, plan: BucketPlan | None = None
) -> Contact:
    """Closest master segment of every slave near the master, by bucket sort.

    Args:
      x: f[N, 2] slave coordinates. Rows close in the input should be close in
        space (a mesh numbering is): slaves are culled in blocks of rows.
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: scalar search radius, >= 0.
      mask: optional bool[N], False for padding slaves.
      plan: static sizes from ``plan_buckets``. Required under ``jit`` (pass it
        as a static argument); a plain call without one plans for itself. A
        new plan compiles anew.

    Returns:
      A ``Contact`` equal to ``all_to_all``'s whenever ``overflow`` is False.
      When it is True, some slave may have been missed: make a bigger plan with
      ``replan(plan, ...)`` and call again.

    Example:
      >>> import jax
      >>> from jaxcontact import all_to_all, bucket_sort, plan_buckets
      >>> from jaxcontact.scenes import cutting_scene
      >>> scene = cutting_scene(2_000, 18.0)
      >>> plan = plan_buckets(scene.x, scene.surface, radius=scene.radius)
      >>> detect = jax.jit(bucket_sort, static_argnames="plan")
      >>> contact = detect(scene.x, scene.surface, radius=scene.radius, plan=plan)
      >>> bool(contact.overflow), int(contact.found.sum())
      (False, 12)
      >>> bool((contact.segment == all_to_all(scene.x, scene.surface, radius=0.1).segment).all())
      True
    """
    x = _inputs.check_points("x", x)
    mask = _inputs.check_mask("mask", mask, x.shape[0])
    surface = _inputs.check_surface(surface, x.dtype)
    radius = _inputs.check_radius(radius, x.dtype)
    if plan is None:
        if _is_traced(x, surface, radius, mask):
            raise ValueError(
                "bucket_sort under jit needs plan=plan_buckets(...) made outside jit "
                "(and passed as a static argument)"
            )
        plan = plan_buckets(x, surface, radius=radius, mask=mask)
    _check_plan(plan, x.shape[0], for_paths=False)
    return _contact_jit(x, surface, radius, mask, plan=plan)


def bucket_swept(
    x_prev: Array, x: Array, surface: Surface, *, mask: Array | None = None, plan: BucketPlan | None = None
) -> Crossing:
    """First crossing of every slave's path with the master, by bucket sort.

    The broad phase works on the boxes of the paths ``x_prev -> x``; the cells
    hold the segments inflated by the longest path (the paper's ``d_max``).

    Args:
      x_prev: f[N, 2] previous slave positions.
      x: f[N, 2] current slave positions.
      surface: the master ``Surface``.
      mask: optional bool[N], False for padding slaves.
      plan: static sizes from ``plan_buckets(x, surface, x_prev=x_prev)``;
        required under ``jit``.

    Returns:
      A ``Crossing`` equal to ``swept``'s whenever ``overflow`` is False.
    """
    x_prev, _, _ = _inputs.check_paths(x_prev, x, mask)
    surface = _inputs.check_surface(surface, x_prev.dtype)
    if plan is None:
        if _is_traced(x_prev, x, surface, mask):
            raise ValueError(
                "bucket_swept under jit needs plan=plan_buckets(x, surface, x_prev=x_prev) "
                "made outside jit (and passed as a static argument)"
            )
        plan = plan_buckets(x, surface, x_prev=x_prev, mask=mask)
    _check_plan(plan, x_prev.shape[0], for_paths=True)
    return _crossing_jit(x_prev, x, surface, mask, plan=plan)
