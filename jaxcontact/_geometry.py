"""Geometry kernels, each for ONE slave and ONE segment.

Every kernel takes plain coordinates (shape ``(2,)``) and returns scalars or
``(2,)`` vectors; the detectors batch them with ``vmap``. They are written so
that no input (a zero-length segment, coincident points, a point exactly on a
vertex) produces NaN or inf in values or in gradients: every square root and
division sees a safe argument through the double-``where`` pattern (as in
jax-md's ``util.safe_mask``), and the branch that is not taken is fed harmless
numbers so its gradient is zero, not NaN.

Differences are always formed against the nearest end of the segment, so a
float32 scene far from the origin keeps the accuracy of its local geometry:
``x - a`` of two nearby float32 numbers is exact (Sterbenz), everything after
it works on small numbers.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp

from jaxcontact._types import Array


def dot(u: Array, v: Array) -> Array:
    """The dot product of two 2D vectors, written out.

    ``jnp.dot`` under ``vmap`` becomes a batched ``dot_general`` that XLA does
    not fuse with its neighbours; the written-out sum fuses (10-40x faster on
    the CPU, measured in benchmarks/dense.py's history).
    """
    return u[0] * v[0] + u[1] * v[1]


def cross(u: Array, v: Array) -> Array:
    """The z-component of the 3D cross product of two 2D vectors."""
    return u[0] * v[1] - u[1] * v[0]


def safe_sqrt(value: Array) -> Array:
    """``sqrt(value)`` with a zero (not infinite) gradient at ``value == 0``."""
    positive = value > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, value, 1)), 0)


def safe_divide(numerator: Array, denominator: Array, fallback: Array | float = 0) -> Array:
    """``numerator / denominator``, or ``fallback`` where the denominator is 0."""
    nonzero = denominator != 0
    return jnp.where(nonzero, numerator / jnp.where(nonzero, denominator, 1), fallback)


class Projection(NamedTuple):
    """The closest point of one segment to one slave."""

    distance_squared: Array  # f[]  |x - p|^2
    gap: Array  # f[]  signed gap
    xi: Array  # f[]  clamped projection coordinate
    point: Array  # f[2]  closest point p
    normal: Array  # f[2]  outward unit normal (t_y, -t_x)


def _offset(x: Array, a: Array, b: Array) -> tuple[Array, Array, Array, Array]:
    """``(x - p, p, xi, interior)`` for the closest point ``p`` of ``a -> b`` to ``x``."""
    d = b - a
    from_a = x - a
    from_b = x - b
    along_a = dot(from_a, d)
    along_b = dot(from_b, d)
    # The clamps are decided by sign, not from the rounded ratio, so a slave
    # exactly at an end point gets xi exactly 0 or 1 (a ratio can round to
    # 0.9999999999999999 there and break an exact tie at a shared vertex).
    before, after = along_a <= 0, along_b >= 0
    ratio = jnp.clip(safe_divide(along_a, dot(d, d)), 0, 1)
    xi = jnp.where(before, 0, jnp.where(after, 1, ratio)).astype(x.dtype)
    # Measure from the nearer end point: exact at both ends (so slaves at a
    # vertex shared by two segments tie exactly) and short differences elsewhere.
    near_a = xi <= 0.5
    offset = jnp.where(near_a, from_a - xi * d, from_b + (1 - xi) * d)
    point = jnp.where(near_a, a + xi * d, b - (1 - xi) * d)
    return offset, point, xi, ~before & ~after


def squared_distance(x: Array, a: Array, b: Array) -> Array:
    """f[]: ``|x - p|^2`` for the closest point ``p`` of segment ``a -> b`` to ``x``.

    The same number as ``project(x, a, b).distance_squared``, at lower cost.
    """
    offset = _offset(x, a, b)[0]
    return dot(offset, offset)


def project(x: Array, a: Array, b: Array) -> Projection:
    """Closest point of segment ``a -> b`` to slave ``x``, with the signed gap.

    The signed gap is ``(x - p) . n`` where the projection falls inside the
    segment and ``+-|x - p|`` (sign of ``(x - p) . n``, zero counted positive)
    where it is clamped to an end point; the two agree where they meet, so the
    gap is continuous along the segment. A zero-length segment gives finite
    numbers; callers treat it as masked.

    Args:
      x: f[2] slave.
      a: f[2] segment start.
      b: f[2] segment end.

    Returns:
      A ``Projection`` of scalars and ``(2,)`` vectors.
    """
    offset, point, xi, interior = _offset(x, a, b)
    d = b - a
    distance_squared = dot(offset, offset)
    normal = safe_divide(jnp.stack([d[1], -d[0]]), safe_sqrt(dot(d, d)))
    normal_offset = dot(offset, normal)
    corner_sign = jnp.where(normal_offset < 0, -1, 1).astype(x.dtype)
    gap = jnp.where(interior, normal_offset, corner_sign * safe_sqrt(distance_squared))
    return Projection(distance_squared, gap, xi, point, normal)


class PathHit(NamedTuple):
    """Where one slave's path meets one segment."""

    hit: Array  # bool[]  the path meets the segment
    t: Array  # f[]  first path parameter in [0, 1] where it does (0 if no hit)


def path_hit(x_prev: Array, x: Array, a: Array, b: Array) -> PathHit:
    """First time ``t`` in ``[0, 1]`` at which the path ``x_prev -> x`` meets ``a -> b``.

    Orientation tests decide whether the two meet (touching an end point
    counts, so does arriving exactly on the segment at ``t = 1``). Each
    orientation is computed from differences of the inputs directly, not from
    differences of rounded products, so a point exactly on the segment's line
    gives exactly zero whenever the inputs make that representable.

    A path along the segment's own line meets it at the first ``t`` inside
    it; a path parallel to the segment and off its line never does; a path of
    zero length meets it (at ``t = 0``) only if it lies on it.

    Args:
      x_prev: f[2] path start.
      x: f[2] path end.
      a: f[2] segment start.
      b: f[2] segment end.

    Returns:
      A ``PathHit`` of scalars.
    """
    d = b - a
    u = x - x_prev
    # Which side of the segment's line each end of the path lies on.
    side_prev = cross(d, x_prev - a)
    side_now = cross(d, x - a)
    # Which side of the path's line each end of the segment lies on.
    side_a = cross(u, a - x_prev)
    side_b = cross(u, b - x_prev)
    meets_line = ((side_prev <= 0) & (side_now >= 0)) | ((side_prev >= 0) & (side_now <= 0))
    straddles = ((side_a <= 0) & (side_b >= 0)) | ((side_a >= 0) & (side_b <= 0))
    transversal = side_prev != side_now
    t_lines = safe_divide(side_prev, side_prev - side_now)
    # Where the path's line runs exactly through an end point, the meeting
    # point is that end point: t from it alone is the same number for both
    # segments sharing it, so an exact tie at a shared vertex stays exact.
    length_u = dot(u, u)
    t_at_a = safe_divide(dot(a - x_prev, u), length_u)
    t_at_b = safe_divide(dot(b - x_prev, u), length_u)
    t_vertex = jnp.where(side_a == 0, t_at_a, jnp.where(side_b == 0, t_at_b, t_lines))
    t_inner = jnp.where(side_prev == 0, 0, jnp.where(side_now == 0, 1, t_vertex))
    t_transversal = jnp.clip(t_inner, 0, 1).astype(x.dtype)
    hit_transversal = transversal & meets_line & straddles

    # Both path ends on the segment's line (collinear or zero motion): track the
    # segment coordinate s along the path and find the first t with s in [0, 1].
    length_squared = dot(d, d)
    s_prev = safe_divide(dot(x_prev - a, d), length_squared)
    s_now = safe_divide(dot(x - a, d), length_squared)
    starts_inside = (s_prev >= 0) & (s_prev <= 1)
    entry = jnp.where(s_prev < 0, 0, 1).astype(x.dtype)
    t_entry = safe_divide(entry - s_prev, s_now - s_prev, fallback=2)
    t_collinear = jnp.where(starts_inside, 0, t_entry)
    on_line = (side_prev == 0) & (side_now == 0) & (length_squared > 0)
    hit_collinear = on_line & (t_collinear >= 0) & (t_collinear <= 1)

    hit = jnp.where(on_line, hit_collinear, hit_transversal)
    t = jnp.where(on_line, t_collinear, t_transversal)
    return PathHit(hit, jnp.where(hit, t, 0))
