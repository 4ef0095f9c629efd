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
    not fuse with its neighbours; the written-out sum fuses (measured 10-40x
    faster on the CPU with commit 5928bf7f76cc:benchmarks/archive/dense.py).
    """
    return u[0] * v[0] + u[1] * v[1]


def cross(u: Array, v: Array) -> Array:
    """The z-component of the 3D cross product of two 2D vectors."""
    return u[0] * v[1] - u[1] * v[0]


def minus(p: Array, q: Array) -> tuple[Array, Array]:
    """``p - q`` of two 2D vectors, as the pair ``(x, y)``: for kernels scored over
    blocks of gathered pairs, which must form no whole vector (``_offset``)."""
    return p[0] - q[0], p[1] - q[1]


def cross_sign(u: Array, v: Array) -> Array:
    """The sign (-1, 0 or 1, in ``u``'s dtype) of ``cross(u, v)``, by comparing its two products.

    Rounding is monotone, so the rounded products compare as the exact ones
    do (or tie): the sign is never wrong, and exactly zero whenever the exact
    products are equal. A subtraction would not be: XLA may contract
    ``p - q`` into a fused multiply-add that returns the rounding error of
    ``q`` (``cross(d, -d)`` came out as -1e-16).
    """
    left, right = u[0] * v[1], u[1] * v[0]
    return (left > right).astype(u.dtype) - (left < right).astype(u.dtype)


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
    normal_distance: Array  # f[]  (x - p) . n, signed


def unit_normal(a: Array, b: Array) -> Array:
    """f[2]: the outward unit normal ``(t_y, -t_x)`` of ``a -> b`` (zero if degenerate)."""
    d = b - a
    return safe_divide(jnp.stack([d[1], -d[0]]), safe_sqrt(dot(d, d)))


def _offset(
    x: Array, a: Array, b: Array, d: Array, inverse_length_squared: Array | None = None
) -> tuple[Array, Array, Array, Array]:
    """``(x - p, p, xi, interior)`` for the closest point ``p`` of ``a -> b`` to ``x``.

    ``d`` is ``b - a``. ``xi``'s ratio is ``((x - a) . d) / (d . d)``, or that
    dot product times ``inverse_length_squared`` where it is given (``Edge``:
    the searches).
    """
    # Per coordinate throughout, no 2-vector formed until the end: the
    # searches score blocks of gathered pairs, and XLA reads a coordinate
    # of a gathered vector straight from its source only when every use of
    # the vector is such a read; one operation on the whole vector has XLA
    # write the block's vectors out first (the cell search on the rough die
    # at 10^5 x 10^4 measured 2x slower so).
    from_a, from_b = minus(x, a), minus(x, b)
    along_a = dot(from_a, d)
    along_b = dot(from_b, d)
    # The clamps are decided by sign, not from the rounded ratio, so a slave
    # exactly at an end point gets xi exactly 0 or 1 (a ratio can round to
    # 0.9999999999999999 there and break an exact tie at a shared vertex).
    before, after = along_a <= 0, along_b >= 0
    if inverse_length_squared is None:
        ratio = safe_divide(along_a, dot(d, d))
    else:
        ratio = along_a * inverse_length_squared
    ratio = jnp.clip(ratio, 0, 1)
    xi = jnp.where(before, 0, jnp.where(after, 1, ratio)).astype(x.dtype)
    # Measure from the nearer end point: exact at both ends (so slaves at a
    # vertex shared by two segments tie exactly) and short differences elsewhere.
    near_a = xi <= 0.5

    def per_axis(axis):
        offset = jnp.where(near_a, from_a[axis] - xi * d[axis], from_b[axis] + (1 - xi) * d[axis])
        point = jnp.where(near_a, a[axis] + xi * d[axis], b[axis] - (1 - xi) * d[axis])
        return offset, point

    (offset_x, point_x), (offset_y, point_y) = per_axis(0), per_axis(1)
    offset, point = jnp.stack([offset_x, offset_y]), jnp.stack([point_x, point_y])
    return offset, point, xi, ~before & ~after


class Edge(NamedTuple):
    """A segment as the searches score it: its ends, and what they alone decide.

    ``edge`` computes it for every segment at once, before ``search_all``'s
    loop over segments. Computed inside the pair kernel instead, each
    segment's share (``d = b - a``, ``1 / (d . d)``) is hoisted by XLA out of
    the loop over rows into kernels of their own, two per segment: with 20
    segments 41 kernels and 1.7 s of compile, against 4 kernels and 0.6 s,
    and the same choices bit for bit (measured on the CPU, jax 0.10.2).
    """

    start: Array  # f[2]  a
    end: Array  # f[2]  b
    direction: Array  # f[2]  d = b - a
    length_squared: Array  # f[]  (b - a) . (b - a)
    inverse_length_squared: Array  # f[]  1 / ((b - a) . (b - a)); 0 where that is 0


def edge(a: Array, b: Array) -> Edge:
    """The ``Edge`` of ``a -> b`` (f[..., 2] each: one segment, or many at once)."""
    d = b - a
    length_squared = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]
    nonzero = length_squared != 0
    inverse = jnp.where(nonzero, 1 / jnp.where(nonzero, length_squared, 1), 0)
    return Edge(a, b, d, length_squared, inverse)


def squared_distance(x: Array, segment: Edge) -> Array:
    """f[]: ``|x - p|^2`` for the closest point ``p`` of ``segment`` to ``x``.

    The searches' score. ``project(x, a, b).distance_squared`` is the same
    number up to the rounding of ``xi`` (a product with the inverse length
    here, a quotient there); the values reported come from ``project``.
    """
    a, b, d = segment.start, segment.end, segment.direction
    offset = _offset(x, a, b, d, segment.inverse_length_squared)[0]
    return dot(offset, offset)


def first_hit_time(x_prev: Array, x: Array, segment: Edge) -> Array:
    """f[]: ``path_hit``'s ``t``, or ``inf`` where the path misses ``segment``."""
    a, b = segment.start, segment.end
    hit = path_hit(x_prev, x, a, b, segment.direction, segment.length_squared)
    return jnp.where(hit.hit, hit.t, jnp.inf)


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
    offset, point, xi, interior = _offset(x, a, b, b - a)
    distance_squared = dot(offset, offset)
    normal = unit_normal(a, b)
    normal_offset = dot(offset, normal)
    # At an end point the sign comes from the cross product of two input
    # differences, exact when its products are (a slave on the extension of
    # the segment's line gets exactly zero: positive), not from the rounded
    # unit normal, whose dot product can round to -1e-9 there.
    corner_sign = jnp.where(cross_sign(offset, b - a) < 0, -1, 1).astype(x.dtype)
    gap = jnp.where(interior, normal_offset, corner_sign * safe_sqrt(distance_squared))
    return Projection(distance_squared, gap, xi, point, normal, normal_offset)


class PathHit(NamedTuple):
    """Where one slave's path meets one segment."""

    hit: Array  # bool[]  the path meets the segment
    t: Array  # f[]  first path parameter in [0, 1] where it does (0 if no hit)


def path_hit(
    x_prev: Array,
    x: Array,
    a: Array,
    b: Array,
    direction: Array | None = None,
    length_squared: Array | None = None,
) -> PathHit:
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
      direction: optional f[2] ``d = b - a``, and
      length_squared: optional f[] ``d . d``, computed once per segment
        (``Edge``): the same numbers as computed here.

    Returns:
      A ``PathHit`` of scalars.
    """
    # Differences per coordinate, as in ``_offset``: the searches score
    # blocks of gathered pairs.
    d = minus(b, a) if direction is None else direction
    u = minus(x, x_prev)
    from_a_prev, from_a_now = minus(x_prev, a), minus(x, a)
    a_from_prev, b_from_prev = minus(a, x_prev), minus(b, x_prev)
    # Which side of the segment's line each end of the path lies on.
    side_prev = cross(d, from_a_prev)
    side_now = cross(d, from_a_now)
    # Which side of the path's line each end of the segment lies on.
    side_a = cross(u, a_from_prev)
    side_b = cross(u, b_from_prev)
    meets_line = ((side_prev <= 0) & (side_now >= 0)) | ((side_prev >= 0) & (side_now <= 0))
    straddles = ((side_a <= 0) & (side_b >= 0)) | ((side_a >= 0) & (side_b <= 0))
    on_line = (side_prev == 0) & (side_now == 0)
    # Each case's t is a ratio; the cases pick numerator and denominator and
    # one division serves them all (the kernel's cost is in its divisions).
    # Crossing the line: t from the path ends' sides. Where the path's line
    # runs exactly through an end point, t from that point alone, which is the
    # same number for both segments sharing it, so an exact tie stays exact.
    numerator = side_prev
    denominator = side_prev - side_now
    length_u = dot(u, u)
    through_b, through_a = side_b == 0, side_a == 0
    numerator = jnp.where(through_b, dot(b_from_prev, u), numerator)
    denominator = jnp.where(through_b, length_u, denominator)
    numerator = jnp.where(through_a, dot(a_from_prev, u), numerator)
    denominator = jnp.where(through_a, length_u, denominator)
    # Along the segment's own line (collinear, or no motion on it): the
    # projections p = (y - a).d of the path's ends; the segment is p in [0, d.d].
    length_d = dot(d, d) if length_squared is None else length_squared
    along_prev = dot(from_a_prev, d)
    along_now = dot(from_a_now, d)
    starts_inside = (along_prev >= 0) & (along_prev <= length_d)
    entry = jnp.where(along_prev < 0, 0, length_d)
    numerator = jnp.where(on_line, jnp.where(starts_inside, 0, entry - along_prev), numerator)
    denominator = jnp.where(
        on_line, jnp.where(starts_inside, 1, along_now - along_prev), denominator
    )
    ratio = safe_divide(numerator, denominator, fallback=2)
    # A path that starts or ends on the segment's line does so exactly at 0 or 1.
    t = jnp.where(side_prev == 0, 0, jnp.where(side_now == 0, 1, ratio))
    t = jnp.where(on_line, ratio, t)
    hit_transversal = (side_prev != side_now) & meets_line & straddles
    hit_collinear = on_line & (length_d > 0) & (ratio >= 0) & (ratio <= 1)
    hit = jnp.where(on_line, hit_collinear, hit_transversal)
    t = jnp.clip(t, 0, 1).astype(x.dtype)
    return PathHit(hit, jnp.where(hit, t, 0))
