"""The reduction every detector shares: the lowest score, ties to the lowest index."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from jaxcontact._types import Array

# Up to UNROLL steps are unrolled into one fused pass over the rows (fastest:
# the running minimum stays in registers). More steps run in a ``lax.scan``
# over unrolled blocks of BLOCK, which keeps compile time flat (measured: 400
# segments compile in 1.3 s instead of 4-11 s, and run 20% slower).
UNROLL = 32
BLOCK = 8


def lowest_score(
    score,
    num_steps: int,
    num_rows: int,
    dtype,
    *,
    unroll: int = UNROLL,
    block: int = BLOCK,
    steps_needed=None,
) -> tuple[Array, Array]:
    """``(i32[N], f[N])``: per row, the segment with the smallest score, and that score.

    Exact ties go to the segment met first; every caller meets each row's
    segments in increasing index order, so that is the lower index. (Carrying
    a second key for ties through this loop made it 3.5x slower, measured;
    see ``closest.prefer_outside`` for how vertex ties are settled.)

    A running minimum over ``num_steps`` calls of ``score``: O(N) memory and
    one fused pass over the rows per step. Against an (N, M) plane reduced by
    ``argmin`` it is 3.7x faster with the 20-segment cutting tool and slower
    with the paper's 2 segments (measured with the repository's
    5928bf7f76cc:benchmarks/archive/dense.py). Steps run in unrolled
    blocks inside a ``lax.scan``, so compile time stays flat as steps grow.

    Args:
      score: ``score(step) -> (value f[N], segment i32[N])``
        for a traced step index; ``value = inf`` marks no candidate.
      num_steps: how many steps to visit.
      num_rows: N.
      dtype: the values' dtype.
      unroll: at most this many steps run unrolled in one pass; more run in
        a ``lax.scan`` over unrolled blocks of ``block`` steps.
      block: steps per block of the scan.
      steps_needed: optional traced count <= ``num_steps`` past which every
        row's score is ``inf`` (the caller guarantees it). Whole blocks past
        it are then skipped (a ``lax.while_loop`` instead of the scan); steps
        inside the last needed block still run, and with a single block it
        changes nothing.

    Returns:
      The winning segment per row, ``-1`` where every value is ``inf``, and
      its score (``inf`` there).
    """
    choice = jnp.full((num_rows,), -1, jnp.int32)
    best = jnp.full((num_rows,), jnp.inf, dtype)
    if num_steps == 0 or num_rows == 0:
        return choice, best
    block = num_steps if num_steps <= unroll else block
    num_blocks = -(-num_steps // block)

    def visit(offset, carry, first):
        best, choice = carry
        step = first + offset
        value, segment = score(jnp.minimum(step, num_steps - 1))
        value = jnp.where(step < num_steps, value, jnp.inf)
        better = value < best
        return jnp.where(better, value, best), jnp.where(better, segment, choice)

    def visit_block(carry, first):
        # Traced once and unrolled in the jaxpr (``unroll=True``), not by a
        # Python loop that would trace ``score`` ``block`` times.
        visit_first = functools.partial(visit, first=first)
        return jax.lax.fori_loop(0, block, visit_first, carry, unroll=True), None

    carry = _over_blocks(visit_block, (best, choice), num_blocks, block, steps_needed)
    return carry[1], carry[0]


def lowest_in_blocks(
    score_block, num_steps: int, num_rows: int, dtype, *, block: int = BLOCK, steps_needed=None
) -> tuple[Array, Array]:
    """``lowest_score``'s answer, each block's steps scored at once.

    ``score_block(steps)`` takes i32[B] step indices (in range) and returns
    ``(value f[N, B], segment i32[N, B])``. A block is reduced along its
    rows (``argmin``: the first of equal values, the earlier step, as the
    running minimum takes it; NaN and steps past ``num_steps`` are no
    candidate) and merged into the running minimum between blocks. For
    searches whose steps gather their segments: one gather of a block's
    segments instead of one per step, and a row reduction in place of the
    unrolled minimum (measured cheaper to compile with the repository's
    5928bf7f76cc:benchmarks/archive/compile_ops.py).
    ``steps_needed`` as in ``lowest_score``.
    """
    choice = jnp.full((num_rows,), -1, jnp.int32)
    best = jnp.full((num_rows,), jnp.inf, dtype)
    if num_steps == 0 or num_rows == 0:
        return choice, best
    block = min(block, num_steps)
    num_blocks = -(-num_steps // block)

    def visit_block(carry, first):
        best, choice = carry
        steps = first + jnp.arange(block, dtype=jnp.int32)
        values, segments = score_block(jnp.minimum(steps, num_steps - 1))
        real = (steps < num_steps)[None, :] & ~jnp.isnan(values)
        values = jnp.where(real, values, jnp.inf).astype(dtype)
        at = jnp.argmin(values, axis=1)
        value = jnp.take_along_axis(values, at[:, None], axis=1)[:, 0]
        segment = jnp.take_along_axis(segments, at[:, None], axis=1)[:, 0]
        better = value < best
        return (jnp.where(better, value, best), jnp.where(better, segment, choice)), None

    carry = _over_blocks(visit_block, (best, choice), num_blocks, block, steps_needed)
    return carry[1], carry[0]


def _over_blocks(visit_block, carry, num_blocks: int, block: int, steps_needed):
    """``carry`` through ``visit_block(carry, first step)`` for each block: one
    block inline, a ``lax.scan`` over all, or a ``lax.while_loop`` over the
    blocks ``steps_needed`` reaches."""
    firsts = jnp.arange(num_blocks, dtype=jnp.int32) * block
    if num_blocks == 1:
        carry, _ = visit_block(carry, firsts[0])
    elif steps_needed is None:
        carry, _ = jax.lax.scan(visit_block, carry, firsts)
    else:
        blocks_needed = jnp.minimum((steps_needed + block - 1) // block, num_blocks)

        def step(state):
            index, carry = state
            return index + 1, visit_block(carry, index * block)[0]

        _, carry = jax.lax.while_loop(
            lambda state: state[0] < blocks_needed, step, (jnp.zeros((), jnp.int32), carry)
        )
    return carry


def one_scene_at_a_time(fn):
    """``fn`` that, under ``vmap``, runs scene by scene (``lax.map``) instead of batched.

    For the searches only: they return segment indices, take their inputs
    through ``stop_gradient`` (``jax.custom_batching.custom_vmap`` supports
    no reverse-mode differentiation) and hold ``lax.cond`` s, which ``vmap``
    would turn into selects that run both branches and lose the fusion
    boundary ``narrow.in_stages`` relies on. Mapped, each scene keeps
    them; the batched rest (assembling, writing rows) stays vectorised. On
    the CPU that measured as fast per scene as one unbatched call, where
    plain batching was up to 6x slower (measured with the repository's
    5928bf7f76cc:benchmarks/archive/scaling.py). On other
    backends the search is batched as usual.
    Arguments must be arrays (or pytrees of arrays); close over static values.
    """
    mapped = jax.custom_batching.custom_vmap(fn)

    @mapped.def_vmap
    def rule(axis_size, in_batched, *args):
        del axis_size
        if jax.default_backend() != "cpu":
            # Accelerators run the batch as one vectorised program (not
            # measured: commit 5928bf7f76cc:benchmarks/archive/scaling.py measures it).
            axes = jax.tree.map(lambda flag: 0 if flag else None, in_batched)
            result = jax.vmap(fn, in_axes=tuple(axes))(*args)
            return result, jax.tree.map(lambda _: True, result)
        leaves, tree = jax.tree.flatten(args)
        flags = jax.tree.leaves(in_batched)
        batched = [leaf for leaf, flag in zip(leaves, flags, strict=True) if flag]

        def one(slices):
            slices = iter(slices)
            pairs = zip(leaves, flags, strict=True)
            full = [next(slices) if flag else leaf for leaf, flag in pairs]
            return mapped(*jax.tree.unflatten(tree, full))

        result = jax.lax.map(one, batched)
        return result, jax.tree.map(lambda _: True, result)

    return mapped
