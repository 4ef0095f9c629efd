"""The exhaustive detectors: every slave against every master segment.

The per-pair kernel is ``vmap``-ed over the slaves for one segment at a time,
and a running minimum is kept over the segments: O(N) memory whatever M is,
and one fused pass over the slaves per segment. (An (N, M) plane reduced along
M, or an ``argmin`` over it, measured 2-10x slower on the CPU; see
benchmarks/dense.py.) Segments are visited in unrolled blocks inside a
``lax.scan``, so compile time stays flat for large M. The kernel is then
evaluated once more for each slave's chosen pair.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact import _inputs
from jaxcontact._assemble import contact_from_choice, crossing_from_choice
from jaxcontact._geometry import path_hit, squared_distance
from jaxcontact._types import Array, Contact, Crossing, Surface

# Segments visited per unrolled block; larger blocks compile longer.
_BLOCK = 32


def first_minimum(score, num_segments: int, num_slaves: int, dtype) -> Array:
    """i32[N]: for each slave, the lowest segment index with the smallest score.

    Args:
      score: ``score(k) -> f[N]`` for a (traced) segment index ``k``; ``inf``
        marks an ineligible pair.
      num_segments: M.
      num_slaves: N.
      dtype: the score's dtype.

    Returns:
      The chosen segment per slave; ``-1`` where every score is ``inf``.
    """
    best = jnp.full((num_slaves,), jnp.inf, dtype)
    choice = jnp.full((num_slaves,), -1, jnp.int32)
    if num_segments == 0:
        return choice
    block = min(num_segments, _BLOCK)
    num_blocks = -(-num_segments // block)

    def visit_block(carry, first):
        best, choice = carry
        for offset in range(block):
            k = first + offset
            value = jnp.where(k < num_segments, score(jnp.minimum(k, num_segments - 1)), jnp.inf)
            # Strictly smaller: of equal scores the earlier (lower) index stays.
            better = value < best
            best = jnp.where(better, value, best)
            choice = jnp.where(better, k, choice)
        return (best, choice), None

    firsts = jnp.arange(num_blocks, dtype=jnp.int32) * block
    if num_blocks == 1:
        (_, choice), _ = visit_block((best, choice), firsts[0])
    else:
        (_, choice), _ = jax.lax.scan(visit_block, (best, choice), firsts)
    return choice


def all_to_all(x: Array, surface: Surface, *, radius, mask: Array | None = None) -> Contact:
    """Closest master segment of every slave, by dense N x M projection.

    Args:
      x: f[N, 2] slave coordinates (float32 or float64).
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: scalar search radius, >= 0; a slave is ``found`` when its
        closest real segment lies within it.
      mask: optional bool[N], False for padding slaves.

    Returns:
      A ``Contact`` with one row per slave, in ``x``'s dtype. ``overflow`` is
      always False. Costs O(N M) time and O(N + M) memory.

    Raises:
      ValueError: on a wrong shape or dtype, and (outside ``jit``) on segment
        indices out of range or a negative or non-finite radius.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, all_to_all
      >>> floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]]), jnp.array([[0, 1]]))
      >>> contact = all_to_all(jnp.array([[0.5, 0.25], [0.5, -0.125]]), floor, radius=0.5)
      >>> contact.gap.tolist(), contact.active.tolist(), contact.normal.tolist()
      ([0.25, -0.125], [False, True], [[0.0, 1.0], [0.0, 1.0]])
    """
    x = _inputs.check_points("x", x)
    mask = _inputs.check_mask("mask", mask, x.shape[0])
    surface = _inputs.check_surface(surface, x.dtype)
    radius = _inputs.check_radius(radius, x.dtype)
    x, slave_ok = _inputs.sanitize_points(x, mask)
    segments = _inputs.resolve_segments(surface)
    to_segment = jax.vmap(squared_distance, in_axes=(0, None, None))

    def score(k):
        eligible = slave_ok & segments.ok[k]
        return jnp.where(eligible, to_segment(x, segments.start[k], segments.end[k]), jnp.inf)

    choice = first_minimum(score, segments.ok.shape[0], x.shape[0], x.dtype)
    return contact_from_choice(x, segments, choice, radius, jnp.zeros((), bool))


def swept(x_prev: Array, x: Array, surface: Surface, *, mask: Array | None = None) -> Crossing:
    """First crossing of every slave's path ``x_prev -> x`` with the master, densely.

    The earliest crossing along the path wins; exact ties go to the lower
    segment index.

    Args:
      x_prev: f[N, 2] previous slave positions.
      x: f[N, 2] current slave positions, same shape and dtype.
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      mask: optional bool[N], False for padding slaves.

    Returns:
      A ``Crossing`` with one row per slave, in ``x``'s dtype; ``overflow`` is
      always False. Costs O(N M) time and O(N + M) memory.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, swept
      >>> wall = Surface(jnp.array([[1.0, 0.0], [1.0, 2.0]]), jnp.array([[0, 1]]))
      >>> crossing = swept(jnp.array([[0.0, 1.0]]), jnp.array([[4.0, 1.0]]), wall)
      >>> crossing.crossed.tolist(), crossing.t.tolist(), crossing.point.tolist()
      ([True], [0.25], [[1.0, 1.0]])
    """
    x_prev, x, slave_ok = _inputs.check_paths(x_prev, x, mask)
    surface = _inputs.check_surface(surface, x.dtype)
    segments = _inputs.resolve_segments(surface)
    hit_of = jax.vmap(path_hit, in_axes=(0, 0, None, None))

    def score(k):
        hit = hit_of(x_prev, x, segments.start[k], segments.end[k])
        eligible = slave_ok & segments.ok[k] & hit.hit
        return jnp.where(eligible, hit.t, jnp.inf)

    choice = first_minimum(score, segments.ok.shape[0], x.shape[0], x.dtype)
    return crossing_from_choice(x_prev, x, segments, choice, jnp.zeros((), bool))
