"""Bucket sort: search only what lies near the master.

The paper's bucket-sort strategy in fixed-size arrays. Three stages:

1. Preliminary phase (``_broad``): the master's box, inflated by the search
   distance, against boxes of blocks of slaves; the blocks that meet it go
   into a buffer of planned capacity. If none meets it the rest is skipped
   with ``lax.cond`` s (under ``vmap`` the search still skips, scene by
   scene on the CPU; the other stages run both branches, which stays right).
2. Narrow phase on the kept slaves: with few segments, each kept slave
   against every segment; with many, the segments binned into cells
   (``_cells``) and each slave against its own cell's segments.
3. The chosen pair evaluated by the same kernel as ``all_to_all`` and written
   into rows of zeros.

Whenever ``overflow`` is false the result equals ``all_to_all``'s (``swept``'s).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact import _inputs
from jaxcontact._assemble import (
    contact_from_choice,
    crossing_from_choice,
    empty_contact,
    empty_crossing,
    in_stages,
)
from jaxcontact._broad import Blocks, broad_phase, conservative_margin, segment_boxes
from jaxcontact._cells import CellLists
from jaxcontact._geometry import first_hit_time, squared_distance
from jaxcontact._inputs import Segments
from jaxcontact._narrow import (
    choose,
    kept_rows,
    list_candidates,
    scatter_blocks,
)
from jaxcontact._plan import BucketPlan, plan_buckets
from jaxcontact._search import one_scene_at_a_time
from jaxcontact._types import Array, Contact, Crossing, Surface


def _check_plan(plan, num_slaves: int, for_paths: bool):
    if not isinstance(plan, BucketPlan):
        raise ValueError(f"plan must be a jaxcontact.BucketPlan; got {type(plan).__name__}")
    if plan.num_slaves != num_slaves:
        raise ValueError(f"plan was made for {plan.num_slaves} slaves; x has {num_slaves} rows")
    if plan.for_paths != for_paths:
        wanted = (
            "plan_buckets(x, surface, x_prev=...)"
            if for_paths
            else "plan_buckets(x, surface, radius=...)"
        )
        raise ValueError(f"plan was made for the other detector; make one with {wanted}")


class Candidates(NamedTuple):
    """Slaves and segments near each other, found once and reused over steps.

    Found with the search radius widened by a ``skin``; valid while the
    slaves and the master nodes together have moved less than the skin since
    (``candidates_expired`` says when not), as the paper recomputes ``d_max``
    only every n-th step.
    """

    blocks: Blocks  # the kept blocks of slaves
    listed: CellLists | None  # each kept slave's cell's segments (cell plans), else None
    reference: Array  # f[N, 2]  slave positions when found
    nodes: Array  # f[P, 2]  master node positions when found
    skin: Array  # f[]  the extra reach
    overflow: Array  # bool[]  the plan was too small when they were found


def _candidates_impl(x, surface, radius, skin, mask, plan):
    slave_ok = _inputs.rows_ok(x, mask)
    segments = _inputs.resolve_segments(surface)
    boxes, blocks = broad_phase(
        x, x, slave_ok, segments, radius + skin, plan.block_size, plan.block_capacity
    )
    listed, overflow = None, blocks.overflow
    if plan.use_cells:
        kept, ok = kept_rows(x, slave_ok, blocks)
        listed, cells_overflow = list_candidates(kept, ok, segments, boxes, plan)
        overflow = overflow | cells_overflow
    return Candidates(blocks, listed, x, surface.nodes, skin, overflow)


def _search_kept(
    x, query, rows, ok, blocks, segments, boxes, kernel, plan, listed, from_choice, empty
):
    """The narrow phase on the kept slaves and the rows written back: search,
    assemble (``from_choice(choice, overflow)``), scatter, each skipped when
    no block was kept (``_assemble.in_stages``); the search scene by scene
    under ``vmap`` (``_search.one_scene_at_a_time``). Pairs are scored by
    ``kernel(*row, a, b)`` over ``rows``; ``empty(rows, overflow)`` makes a
    not-found result.
    """
    no_overflow = jnp.zeros((), bool)
    go = blocks.count > 0
    search = one_scene_at_a_time(
        functools.partial(_binned_choice, kernel, plan, segments.num_nodes)
    )
    fixed = jax.lax.stop_gradient((rows, query, segments.start, segments.end, boxes))
    found = search(go, *fixed, ok, segments.ok, segments.nodes, listed)

    def write(part):
        return scatter_blocks(part, blocks, empty(x, part.overflow), plan.block_size)

    return in_stages(
        go,
        [lambda found: from_choice(*found), write],
        [empty(query, no_overflow), empty(x, no_overflow)],
        found,
    )


def _binned_choice(
    kernel, plan, num_nodes, go, rows, query, start, end, boxes, ok, segment_ok, nodes, listed
):
    """(i32[S] choice, bool[] cells overflow) of the kept slaves; all -1 unless ``go``."""
    segments = Segments(start, end, segment_ok, nodes, num_nodes)

    def search(_):
        return choose(query, ok, segments, boxes, kernel, rows, plan, listed)

    no_choice = jnp.full(query.shape[:1], -1, jnp.int32), jnp.zeros((), bool)
    return in_stages(go, [search], [no_choice])


def _contact_impl(x, surface, radius, mask, plan, found=None):
    # Bad rows are left in ``x``: the box reductions skip them, and the kept
    # rows are zeroed when gathered, so no pass over all N rows copies x.
    slave_ok = _inputs.rows_ok(x, mask)
    segments = _inputs.resolve_segments(surface)
    num_rows = x.shape[0]
    no_overflow = jnp.zeros((), bool)
    if num_rows == 0 or segments.ok.shape[0] == 0:
        return empty_contact(x, no_overflow)
    if found is None:
        boxes, blocks = broad_phase(
            x, x, slave_ok, segments, radius, plan.block_size, plan.block_capacity
        )
        listed, overflow = None, blocks.overflow
    else:
        boxes, blocks, listed, overflow = None, found.blocks, found.listed, found.overflow

    kept, ok = kept_rows(x, slave_ok, blocks)

    def from_choice(choice, cells_overflow):
        return contact_from_choice(kept, segments, choice, radius, cells_overflow, ok)

    result = _search_kept(
        x, kept, (kept,), ok, blocks, segments, boxes, squared_distance, plan, listed,
        from_choice, empty_contact,
    )  # fmt: skip
    return result._replace(overflow=result.overflow | overflow)


def _crossing_impl(x_prev, x, surface, mask, plan):
    slave_ok = _inputs.rows_ok(x, _inputs.rows_ok(x_prev, mask))
    segments = _inputs.resolve_segments(surface)
    num_rows = x.shape[0]
    no_overflow = jnp.zeros((), bool)
    if num_rows == 0 or segments.ok.shape[0] == 0:
        return empty_crossing(x, no_overflow)
    # A path meets a segment only if their boxes meet.
    path_low, path_high = jnp.minimum(x_prev, x), jnp.maximum(x_prev, x)
    no_reach = jnp.zeros((), x.dtype)
    _, blocks = broad_phase(
        path_low, path_high, slave_ok, segments, no_reach, plan.block_size, plan.block_capacity
    )

    start, ok = kept_rows(x_prev, slave_ok, blocks)
    end, _ = kept_rows(x, slave_ok, blocks)

    # Where a path meets a segment, its start lies within the path's length
    # of that segment: bin the segments inflated by the longest kept path and
    # look up each path's start (the paper's boxes inflated by d_max).
    longest = jnp.max(jnp.where(ok, jnp.max(jnp.abs(end - start), axis=-1), 0), initial=0)
    boxes = segment_boxes(segments, conservative_margin(longest, segments.start, segments.end))

    def from_choice(choice, overflow):
        return crossing_from_choice(start, end, segments, choice, overflow, ok)

    result = _search_kept(
        x, start, (start, end), ok, blocks, segments, boxes, first_hit_time, plan, None,
        from_choice, empty_crossing,
    )  # fmt: skip
    return result._replace(overflow=result.overflow | blocks.overflow)


_contact_jit = jax.jit(_contact_impl, static_argnames="plan")
_candidates_jit = jax.jit(_candidates_impl, static_argnames="plan")
_crossing_jit = jax.jit(_crossing_impl, static_argnames="plan")


def _plan_or_made(plan, values, name: str, how: str, make) -> BucketPlan:
    """``plan``, or one made now from concrete ``values``; under ``jit`` none can be."""
    if plan is not None:
        return plan
    if any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(values)):
        raise ValueError(
            f"{name} under jit needs plan={how} made outside jit (and passed as a static argument)"
        )
    return make()


def bucket_sort(
    x: Array,
    surface: Surface,
    *,
    radius,
    mask: Array | None = None,
    plan: BucketPlan | None = None,
    candidates: Candidates | None = None,
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
      candidates: optional ``Candidates`` from ``find_candidates`` with the
        same plan and mask; the broad phase and the binning are then skipped.
        The caller keeps them fresh with ``candidates_expired``.

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
      (False, 13)
      >>> bool((contact.segment == all_to_all(scene.x, scene.surface, radius=0.1).segment).all())
      True
    """
    x, surface, radius, mask = _inputs.check_contact_inputs(x, surface, radius, mask)
    plan = _plan_or_made(
        plan,
        (x, surface, radius, mask),
        "bucket_sort",
        "plan_buckets(x, surface, radius=...)",
        lambda: plan_buckets(x, surface, radius=radius, mask=mask),
    )
    _check_plan(plan, x.shape[0], for_paths=False)
    if candidates is not None and (candidates.listed is None) == plan.use_cells:
        raise ValueError(
            "candidates were found with a plan of another kind (cells on or off); "
            "find them with the plan passed here"
        )
    return _contact_jit(x, surface, radius, mask, plan=plan, found=candidates)


def find_candidates(
    x: Array, surface: Surface, *, radius, skin, plan: BucketPlan, mask: Array | None = None
) -> Candidates:
    """Finds the slaves and segments within ``radius + skin`` of each other, for reuse.

    Make the plan for the widened reach, ``plan_buckets(x, surface, radius=radius + skin)``.
    Pass the result to ``bucket_sort(..., candidates=...)`` on later steps while
    ``candidates_expired`` is False; a result of such a call equals the
    plain call's.

    Example:
      >>> import jax
      >>> from jaxcontact import bucket_sort, candidates_expired, find_candidates, plan_buckets
      >>> from jaxcontact.scenes import cutting_scene
      >>> scene = cutting_scene(2_000, 18.0)
      >>> plan = plan_buckets(scene.x, scene.surface, radius=0.1 + 0.05)
      >>> near = find_candidates(scene.x, scene.surface, radius=0.1, skin=0.05, plan=plan)
      >>> moved = scene.x.at[:, 0].add(0.01)
      >>> bool(candidates_expired(near, moved, scene.surface))
      False
      >>> int(bucket_sort(moved, scene.surface, radius=0.1, plan=plan, candidates=near).found.sum())
      13
    """
    x, surface, radius, mask = _inputs.check_contact_inputs(x, surface, radius, mask)
    skin = _inputs.check_radius(skin, x.dtype)
    _check_plan(plan, x.shape[0], for_paths=False)
    return _candidates_jit(x, surface, radius, skin, mask, plan=plan)


@jax.jit
def candidates_expired(candidates: Candidates, x: Array, surface: Surface) -> Array:
    """bool[]: the slaves and the master have moved too far for ``candidates`` to hold.

    A pair within the radius now was within ``radius + skin`` when the
    candidates were found if the largest slave move plus the largest master
    node move is at most the skin (a segment moves no farther than its ends).
    """

    def largest_move(now, then):
        step = jnp.sum((now - then) ** 2, axis=-1)
        return jnp.sqrt(jnp.max(jnp.where(jnp.isfinite(step), step, 0), initial=0))

    moved = largest_move(x, candidates.reference) + largest_move(surface.nodes, candidates.nodes)
    return moved > candidates.skin


def bucket_swept(
    x_prev: Array,
    x: Array,
    surface: Surface,
    *,
    mask: Array | None = None,
    plan: BucketPlan | None = None,
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
    x_prev, x, mask = _inputs.check_path_inputs(x_prev, x, mask)
    surface = _inputs.check_surface(surface, x_prev.dtype)
    plan = _plan_or_made(
        plan,
        (x_prev, x, surface, mask),
        "bucket_swept",
        "plan_buckets(x, surface, x_prev=x_prev)",
        lambda: plan_buckets(x, surface, x_prev=x_prev, mask=mask),
    )
    _check_plan(plan, x_prev.shape[0], for_paths=True)
    return _crossing_jit(x_prev, x, surface, mask, plan=plan)
