"""Master segments (or triangles) resolved to their corners, and slave rows sanitised.

Under ``jit`` a bad value cannot raise, so it is neutralised here: a slave
with a NaN or inf coordinate is treated as masked, a segment touching such a
node or with an index out of range as masked, and both are replaced by zeros
before any arithmetic, so that nothing NaN reaches a value or a gradient.
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp

from jaxcontact._types import Array, Surface


@functools.partial(
    jax.tree_util.register_dataclass,
    data_fields=["start", "end", "ok", "indices", "tags", "apex"],
    meta_fields=["num_nodes"],
)
@dataclasses.dataclass(frozen=True)
class Segments:
    """Master segments resolved to end points, with bad ones neutralised.

    In 3D the same for triangles: ``start``, ``end`` and ``apex`` are the
    corners a, b, c (f[M, 3] each) and ``indices`` i32[M, 3]; in 2D
    ``apex`` is None. A pytree whose node count is static, so it passes
    whole through ``cond``, ``custom_vmap`` and ``jit``.
    """

    start: Array  # f[M, d]  a; zeros where not ok
    end: Array  # f[M, d]  b; zeros where not ok
    ok: Array  # bool[M]  real, finite and of non-zero length (3D: area)
    indices: Array | None  # i32[M, 2] (3D: i32[M, 3])  the node indices of the corners
    num_nodes: int  # P, static: ok segments' node indices lie in [0, P)
    tags: object = None  # pairs.SegmentTags: what the pair rule reads, or None
    apex: Array | None = None  # f[M, 3]  a triangle's third corner c (3D); None in 2D


def ends_of(nodes: Array, indices: Array) -> Array:
    """f[M, k, d]: the nodes (f[P, d]) at ``indices`` (i32[M, k]), read clamped into range.

    An index out of range reads some node (zeros when there are no nodes,
    where a gather cannot run at all): the caller masks those segments.
    """
    if nodes.shape[0] == 0:
        return jnp.zeros(indices.shape + nodes.shape[-1:], nodes.dtype)
    return nodes[jnp.clip(indices, 0, nodes.shape[0] - 1)]


def resolve_segments(surface: Surface) -> Segments:
    """End points of every segment; masked, non-finite or zero-length ones flagged.

    Triangles (i32[M, 3] in ``surface.segments``) go to ``resolve_triangles``."""
    if surface.segments.shape[-1] == 3:
        return resolve_triangles(surface)
    ends = ends_of(surface.nodes, surface.segments)
    start, end = ends[:, 0], ends[:, 1]
    ok = _real(surface, (start, end))
    start = jnp.where(ok[:, None], start, 0)
    end = jnp.where(ok[:, None], end, 0)
    length_squared = jnp.sum((end - start) ** 2, axis=-1)
    ok = ok & (length_squared > 0) & jnp.isfinite(length_squared)
    start, end = jnp.where(ok[:, None], start, 0), jnp.where(ok[:, None], end, 0)
    return Segments(start, end, ok, surface.segments, surface.nodes.shape[0])


def _real(surface: Surface, corners: tuple) -> Array:
    """bool[M]: not masked, every index in range and every corner finite."""
    num_nodes = surface.nodes.shape[0]
    # Masked segments' indices may be anything (a sentinel such as -1), and
    # under jit even a real segment's cannot be checked: a segment with an
    # index out of range reads a node it does not name, and is not real.
    in_range = jnp.all((surface.segments >= 0) & (surface.segments < num_nodes), axis=-1)
    finite = jnp.isfinite(corners[0]) & jnp.isfinite(corners[1])
    for corner in corners[2:]:
        finite = finite & jnp.isfinite(corner)
    finite = jnp.all(finite, axis=-1) & in_range
    return finite if surface.mask is None else finite & surface.mask


def resolve_triangles(surface: Surface) -> Segments:
    """The corners of every triangle (3D); masked, non-finite or zero-area ones
    flagged, as zero-length segments are in 2D."""
    corners = ends_of(surface.nodes, surface.segments)
    ok = _real(surface, (corners[:, 0], corners[:, 1], corners[:, 2]))
    corners = jnp.where(ok[:, None, None], corners, 0)
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    twice_area = jnp.cross(b - a, c - a)
    area_squared = jnp.sum(twice_area * twice_area, axis=-1)
    ok = ok & (area_squared > 0) & jnp.isfinite(area_squared)
    a, b, c = (jnp.where(ok[:, None], corner, 0) for corner in (a, b, c))
    return Segments(a, b, ok, surface.segments, surface.nodes.shape[0], apex=c)


def with_pool(surface: Surface, pool) -> Surface:
    """``surface`` with the masked segments of ``pool`` (bool[M] or None)
    counted as real: what a search sizes for and lists in advance."""
    if pool is None or surface.mask is None:
        return surface
    return surface._replace(mask=surface.mask | pool)


def finite_rows(points: Array) -> Array:
    """bool[...]: every coordinate of each point (f[..., 2] or f[..., 3]) is finite.

    The two columns taken apart, not ``jnp.all(..., axis=-1)``: XLA's CPU
    code reduces an axis of length 2 as a loop per row, and a pass over N
    rows measured about twice as long that way (``squared_norm``).
    """
    finite = jnp.isfinite(points[..., 0]) & jnp.isfinite(points[..., 1])
    for axis in range(2, points.shape[-1]):
        finite = finite & jnp.isfinite(points[..., axis])
    return finite


def squared_norm(vectors: Array) -> Array:
    """f[...]: ``x^2 + y^2`` of each vector (f[..., 2]): what
    ``jnp.sum(vectors**2, axis=-1)`` computes, to rounding (XLA may fuse the
    multiply and the add). Used only where a last bit does not matter (the
    skin check's threshold, the self-contact window of a path).

    Written per column: XLA's CPU code runs ``jnp.sum(..., axis=-1)`` over a
    length-2 axis as a loop per row; the skin check (``candidates.expired``,
    jitted alone) on 81,939 rows measured 0.36-0.38 ms that way and 0.2 ms
    per column (commit 5928bf7f76cc:benchmarks/archive/search_step.py times the whole step).
    """
    return vectors[..., 0] * vectors[..., 0] + vectors[..., 1] * vectors[..., 1]


def rows_ok(points: Array, mask: Array | None) -> Array:
    """bool[N]: the row is finite and not masked out."""
    ok = finite_rows(points)
    return ok if mask is None else ok & mask


def sanitize_points(points: Array, mask: Array | None) -> tuple[Array, Array]:
    """Returns ``(points with bad rows zeroed, bool[N] row ok)``."""
    ok = rows_ok(points, mask)
    return jnp.where(ok[:, None], points, 0), ok


def paths_ok(x_prev: Array, x: Array, mask: Array | None) -> Array:
    """bool[N]: both ends of the path are finite and the row is not masked out."""
    return rows_ok(x, rows_ok(x_prev, mask))


def sanitize_paths(x_prev: Array, x: Array, mask: Array | None) -> tuple[Array, Array, Array]:
    """Returns both positions with bad rows zeroed and bool[N] row ok (``paths_ok``)."""
    ok = paths_ok(x_prev, x, mask)
    return jnp.where(ok[:, None], x_prev, 0), jnp.where(ok[:, None], x, 0), ok
