"""Master segments resolved to their end points, and slave rows sanitised.

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
    data_fields=["start", "end", "ok", "indices", "tags"],
    meta_fields=["num_nodes"],
)
@dataclasses.dataclass(frozen=True)
class Segments:
    """Master segments resolved to end points, with bad ones neutralised.

    A pytree whose node count is static, so it passes whole through ``cond``,
    ``custom_vmap`` and ``jit``.
    """

    start: Array  # f[M, 2]  a; zeros where not ok
    end: Array  # f[M, 2]  b; zeros where not ok
    ok: Array  # bool[M]  real, finite and of non-zero length
    indices: Array | None  # i32[M, 2]  the node indices of each segment's ends
    num_nodes: int  # P, static: ok segments' node indices lie in [0, P)
    tags: object = None  # pairs.SegmentTags: what the pair rule reads, or None


def ends_of(nodes: Array, indices: Array) -> Array:
    """f[M, 2, 2]: the nodes at ``indices`` (i32[M, 2]), read clamped into range.

    An index out of range reads some node (zeros when there are no nodes,
    where a gather cannot run at all): the caller masks those segments.
    """
    if nodes.shape[0] == 0:
        return jnp.zeros(indices.shape + (2,), nodes.dtype)
    return nodes[jnp.clip(indices, 0, nodes.shape[0] - 1)]


def resolve_segments(surface: Surface) -> Segments:
    """End points of every segment; masked, non-finite or zero-length ones flagged."""
    ends = ends_of(surface.nodes, surface.segments)
    start, end = ends[:, 0], ends[:, 1]
    num_nodes = surface.nodes.shape[0]
    # Masked segments' indices may be anything (a sentinel such as -1), and
    # under jit even a real segment's cannot be checked: a segment with an
    # index out of range reads a node it does not name, and is not real.
    in_range = jnp.all((surface.segments >= 0) & (surface.segments < num_nodes), axis=-1)
    finite = jnp.all(jnp.isfinite(start) & jnp.isfinite(end), axis=-1) & in_range
    ok = finite if surface.mask is None else finite & surface.mask
    start = jnp.where(ok[:, None], start, 0)
    end = jnp.where(ok[:, None], end, 0)
    length_squared = jnp.sum((end - start) ** 2, axis=-1)
    ok = ok & (length_squared > 0) & jnp.isfinite(length_squared)
    start, end = jnp.where(ok[:, None], start, 0), jnp.where(ok[:, None], end, 0)
    return Segments(start, end, ok, surface.segments, num_nodes)


def with_pool(surface: Surface, pool) -> Surface:
    """``surface`` with the masked segments of ``pool`` (bool[M] or None)
    counted as real: what a search sizes for and lists in advance."""
    if pool is None or surface.mask is None:
        return surface
    return surface._replace(mask=surface.mask | pool)


def finite_rows(points: Array) -> Array:
    """bool[...]: both coordinates of each point (f[..., 2]) are finite.

    The two columns taken apart, not ``jnp.all(..., axis=-1)``: XLA's CPU
    code reduces an axis of length 2 as a loop per row, and a pass over N
    rows measured about twice as long that way (``squared_norm``).
    """
    return jnp.isfinite(points[..., 0]) & jnp.isfinite(points[..., 1])


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
