"""The 3D pair kernel: ONE slave against ONE triangle, and the surface's pseudo-normals.

The closest point of a triangle follows Ericson, *Real-Time Collision
Detection* (2005), section 5.1.5: six dot products of the slave's offsets
from the corners with two edge vectors place it in one of seven Voronoi
regions (three corners, three edges, the face), each with its own closest
point. Written here as masked arithmetic per coordinate, every region's
point computed and the region's chosen by ``where`` in Ericson's order, as
``geometry._offset`` is for segments, so it vectorises and differentiates;
every division sees a safe denominator (``geometry.safe_divide``).

The sign of the gap off the face's interior comes from the angle-weighted
pseudo-normal (Baerentzen and Aanaes, "Signed distance computation using the
angle weighted pseudonormal", IEEE TVCG 11(3), 2005): on an edge, the sum of
its faces' unit normals; at a vertex, the sum of its faces' unit normals
weighted by their angles there. For a closed, consistently oriented surface
its sign is the inside test's at every point whose closest point it is.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.geometry import safe_divide, safe_sqrt
from jaxcontact._pipeline.segments import Segments
from jaxcontact._types import Array

# The regions of Ericson's test, as ``Closest.region`` codes.
INTERIOR, AT_A, AT_B, AT_C, ON_AB, ON_BC, ON_CA = range(7)


class Face(NamedTuple):
    """A triangle as the searches score it: its corners and what they alone decide.

    ``face`` computes it for every triangle at once, before the loop over
    triangles (``geometry.Edge`` says why).
    """

    start: Array  # f[3]  a
    end: Array  # f[3]  b
    apex: Array  # f[3]  c
    ab: Array  # f[3]  b - a
    ac: Array  # f[3]  c - a


def face(a: Array, b: Array, c: Array) -> Face:
    """The ``Face`` of ``a, b, c`` (f[..., 3] each: one triangle, or many at once)."""
    return Face(a, b, c, b - a, c - a)


def _dot(u, v) -> Array:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _minus(p, q) -> tuple:
    return p[0] - q[0], p[1] - q[1], p[2] - q[2]


class Closest(NamedTuple):
    """The closest point of one triangle to one slave."""

    offset: Array  # f[3]  x - p
    point: Array  # f[3]  p
    weights: Array  # f[2]  the barycentric weights of b and c: p = (1 - u - v) a + u b + v c
    region: Array  # i32[]  INTERIOR, AT_A, ..., ON_CA


def closest_point(x: Array, triangle: Face) -> Closest:
    """The closest point of ``triangle`` to ``x`` (f[3]), by Ericson's Voronoi regions.

    The region tests compare products (``d1 * d4 <= d3 * d2``) rather than
    test the sign of their rounded difference, which XLA may contract into a
    fused multiply-add: a slave exactly on a region's border then falls on
    the same side for each of the triangles sharing it. A slave in a corner's
    region is measured from that corner exactly, so two triangles sharing the
    corner tie exactly there.
    """
    a, b, c = triangle.start, triangle.end, triangle.apex
    ab, ac = triangle.ab, triangle.ac
    from_a, from_b, from_c = _minus(x, a), _minus(x, b), _minus(x, c)
    d1, d2 = _dot(ab, from_a), _dot(ac, from_a)
    d3, d4 = _dot(ab, from_b), _dot(ac, from_b)
    d5, d6 = _dot(ab, from_c), _dot(ac, from_c)
    at_a = (d1 <= 0) & (d2 <= 0)
    at_b = (d3 >= 0) & (d4 <= d3)
    on_ab = (d1 * d4 <= d3 * d2) & (d1 >= 0) & (d3 <= 0)
    at_c = (d6 >= 0) & (d5 <= d6)
    on_ca = (d5 * d2 <= d1 * d6) & (d2 >= 0) & (d6 <= 0)
    on_bc = (d3 * d6 <= d5 * d4) & (d4 >= d3) & (d5 >= d6)
    # Ericson's order: the first region whose test holds.
    region = jnp.select(
        [at_a, at_b, on_ab, at_c, on_ca, on_bc],
        [AT_A, AT_B, ON_AB, AT_C, ON_CA, ON_BC],
        INTERIOR,
    ).astype(jnp.int32)
    # Each region's parameters; the unused ones are fed safe denominators.
    along_ab = jnp.clip(safe_divide(d1, d1 - d3), 0, 1)
    along_ca = jnp.clip(safe_divide(d2, d2 - d6), 0, 1)
    into_bc, out_bc = d4 - d3, d5 - d6
    along_bc = jnp.clip(safe_divide(into_bc, into_bc + out_bc), 0, 1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    total = va + vb + vc
    inner_b = jnp.clip(safe_divide(vb, total), 0, 1)
    inner_c = jnp.clip(safe_divide(vc, total), 0, 1)
    zero, one = jnp.zeros_like(d1), jnp.ones_like(d1)
    weight_b = jnp.select(
        [region == AT_B, region == ON_AB, region == ON_BC, region == INTERIOR],
        [one, along_ab, 1 - along_bc, inner_b],
        zero,
    )
    weight_c = jnp.select(
        [region == AT_C, region == ON_CA, region == ON_BC, region == INTERIOR],
        [one, along_ca, along_bc, inner_c],
        zero,
    )

    def per_axis(axis):
        # From the corner the region starts at: exact at the corners, short
        # differences along the edges.
        bc = c[axis] - b[axis]
        offsets = [
            from_a[axis],
            from_b[axis],
            from_c[axis],
            from_a[axis] - along_ab * ab[axis],
            from_b[axis] - along_bc * bc,
            from_a[axis] - along_ca * ac[axis],
            from_a[axis] - inner_b * ab[axis] - inner_c * ac[axis],
        ]
        cases = [region == code for code in (AT_A, AT_B, AT_C, ON_AB, ON_BC, ON_CA)]
        offset = jnp.select(cases, offsets[:6], offsets[6])
        return offset, x[axis] - offset

    axes = [per_axis(axis) for axis in range(3)]
    offset = jnp.stack([axis[0] for axis in axes])
    point = jnp.stack([axis[1] for axis in axes])
    return Closest(offset, point, jnp.stack([weight_b, weight_c]), region)


def squared_distance(x: Array, triangle: Face) -> Array:
    """f[]: ``|x - p|^2``, ``p`` the closest point of ``triangle`` to ``x``: the score."""
    offset = closest_point(x, triangle).offset
    return offset[0] * offset[0] + offset[1] * offset[1] + offset[2] * offset[2]


def unit_normals(segments: Segments) -> Array:
    """f[M, 3]: each triangle's outward unit normal (b - a) x (c - a), normalised;
    zeros where the triangle is not real."""
    normal = jnp.cross(segments.end - segments.start, segments.apex - segments.start)
    length = safe_sqrt(jnp.sum(normal * normal, axis=-1))
    unit = safe_divide(normal, length[:, None])
    return jnp.where(segments.ok[:, None], unit, 0)


class PseudoNormals(NamedTuple):
    """The angle-weighted pseudo-normals of a surface's features (not unit length)."""

    edge: Array  # f[M, 3, 3]  of each triangle's edges ab, bc, ca: the sum of its faces' normals
    vertex: Array  # f[P, 3]  of each node: its faces' normals weighted by their angles


def pseudo_normals(segments: Segments) -> PseudoNormals:
    """The ``PseudoNormals`` of the real triangles of ``segments``, without gradient.

    Triangles are adjacent where they share node indices. The edges are
    matched by sorting their 3M node pairs: O(M log M), once per call, beside
    the O(N M) search. Only their signs are read, so they carry no gradient.
    """
    segments = jax.lax.stop_gradient(segments)
    normal = unit_normals(segments)
    corners = jnp.stack([segments.start, segments.end, segments.apex], axis=1)
    indices = segments.indices
    # The angle of each triangle at each corner, between its two edges there.
    to_next = jnp.roll(corners, -1, axis=1) - corners
    to_previous = jnp.roll(corners, 1, axis=1) - corners
    sine = jnp.linalg.norm(jnp.cross(to_next, to_previous), axis=-1)
    angle = jnp.arctan2(sine, jnp.sum(to_next * to_previous, axis=-1))
    num_nodes = segments.num_nodes
    node = jnp.where(segments.ok[:, None], indices, num_nodes)  # num_nodes: dropped
    weighted = angle[..., None] * normal[:, None, :]
    vertex = jnp.zeros((num_nodes, 3), normal.dtype).at[node].add(weighted, mode="drop")
    # Edge k of each triangle runs from corner k to corner k + 1.
    ends = jnp.stack([indices, jnp.roll(indices, -1, axis=1)], axis=-1).reshape(-1, 2)
    low, high = jnp.min(ends, axis=-1), jnp.max(ends, axis=-1)
    order = jnp.lexsort((high, low))
    low, high = low[order], high[order]
    new = jnp.concatenate([jnp.ones(1, bool), (low[1:] != low[:-1]) | (high[1:] != high[:-1])])
    group = jnp.cumsum(new) - 1
    # A triangle that is not real adds a zero normal, whatever its indices.
    each = jnp.repeat(normal, 3, axis=0)[order]
    sums = jax.ops.segment_sum(each, group, num_segments=each.shape[0])
    edge = jnp.zeros_like(each).at[order].set(sums[group])
    return PseudoNormals(edge.reshape(-1, 3, 3), vertex)
