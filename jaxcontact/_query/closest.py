"""The closest-point query: each slave's nearest real segment (3D: triangle) within its radius.

The search decides, without gradients, which segment each slave belongs to
(the lowest squared distance, exact ties to the lower index); then the pair
is evaluated once more (``project``) for that one segment, with the vertex
tie rule (``prefer_outside``). Values and gradients therefore come from the
same code whatever the search was, and a binned search that picks the same
segment as the exhaustive one returns bit-identical rows.

In 3D (slaves f[N, 3], triangles i32[M, 3]) the pair kernel is
``triangles.squared_distance`` and the assembly ``contact_on_faces``: exact
ties stay with the lower face index, and the gap's sign off a face's
interior comes from the feature's pseudo-normal, so no tie rule of its own
is needed for the sign.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._pipeline import inputs, triangles
from jaxcontact._pipeline.broad import Box
from jaxcontact._pipeline.geometry import (
    cross_sign,
    dot,
    project,
    safe_sqrt,
    squared_distance,
    unit_normal,
)
from jaxcontact._pipeline.outline import vertex_neighbours
from jaxcontact._pipeline.pairs import allows, pick
from jaxcontact._pipeline.segments import Segments, sanitize_points
from jaxcontact._query.base import Query
from jaxcontact._types import Array, Contact, ContactList


def _on_chosen(kernel, x: Array, segments: Segments, choice: Array):
    index = jnp.maximum(choice, 0)
    return jax.vmap(kernel)(x, segments.start[index], segments.end[index])


def prefer_outside(
    x: Array, segments: Segments, choice: Array, rule=None, row_tags=None
) -> tuple[Array, Array, Array]:
    """``(choice, sign, vertex)``: vertex ties given to the face that decides the gap's sign.

    The search gives exact ties to the lower index. Where the chosen closest
    point is a node v shared with the neighbouring segment, both are at the
    same distance |x - v|, and the slave is outside the master near v when
    it is outside EITHER face at a convex corner (left turn, or straight on),
    and only when it is outside BOTH at a concave one (right turn). So the
    face with the larger signed normal distance (x - v) . n is taken at a
    convex corner, the smaller at a concave one, and the gap's sign is that
    face's. Giving such ties to the lower index would report slaves in the
    blind spot beyond a sharp convex corner (the tool tip) as penetrating,
    and slaves inside a sharp concave notch as outside. Only neighbours
    that share the node index are seen.

    Only a neighbour the pair rule allows for the slave (``pairs.allows``)
    is a rival.

    ``vertex`` (i32[N]) is the node at the closest point when it is an end
    of the chosen segment, decided by the sign tests that clamp ``xi``
    (``geometry._offset``), and -1 on the face's interior: the tie keeps
    the node, whichever face it picks.

    ``sign`` (f[N]) is the gap's sign at a vertex tie (+1 or -1; 0 where
    there is no tie). It is decided from the signs of the cross products
    ``(x - v) x d`` of both faces and ``d_in x d_out`` of the corner, exact
    when the inputs' products are, not from the rounded unit normals: where
    the two normal distances are equal to within rounding the choice of
    face may go either way, the sign may not. (A slave on the extension of
    a face beyond a concave corner has normal distance 0 to it and is inside
    the other face: negative, as its neighbours on either side.)
    """
    before, after = vertex_neighbours(segments)
    start, end = segments.start, segments.end
    normal = jax.vmap(unit_normal)(start, end)
    index = jnp.maximum(choice, 0)
    a, b = start[index], end[index]
    d = b - a
    # The sign tests ``geometry._offset`` clamps by: the closest point is an end.
    at_start = jax.vmap(dot)(x - a, d) <= 0
    at_end = jax.vmap(dot)(x - b, d) >= 0
    other = jnp.where(at_end, after[index], jnp.where(at_start, before[index], -1))
    rival = jnp.maximum(other, 0)
    # No distance test is needed: the neighbour contains v, so it is at most
    # as far as v, and the search did not find it nearer, so the two tie up
    # to rounding (the neighbour's own closest point may round 1e-16 inside
    # it, where it ties exactly in reals). Both then measure from v.
    offset = x - jnp.where(at_end[:, None], b, a)
    rival_d = end[rival] - start[rival]
    incoming = jnp.where(at_end[:, None], d, rival_d)
    outgoing = jnp.where(at_end[:, None], rival_d, d)
    convex = jax.vmap(cross_sign)(incoming, outgoing) >= 0
    own_key = jax.vmap(dot)(offset, normal[index])
    rival_key = jax.vmap(dot)(offset, normal[rival])
    better = jnp.where(convex, rival_key > own_key, rival_key < own_key)
    tied = (choice >= 0) & (other >= 0) & segments.ok[rival]
    if rule is not None:
        tied = tied & allows(rule, row_tags, pick(segments.tags, rival))
    own_side = jax.vmap(cross_sign)(offset, d)
    rival_side = jax.vmap(cross_sign)(offset, rival_d)
    larger, smaller = jnp.maximum(own_side, rival_side), jnp.minimum(own_side, rival_side)
    inside = jnp.where(convex, larger < 0, smaller < 0)
    sign = jnp.where(tied, jnp.where(inside, -1, 1), 0).astype(x.dtype)
    ends = segments.indices[index]
    vertex = jnp.where(at_end, ends[:, 1], jnp.where(at_start, ends[:, 0], -1))
    vertex = jnp.where(choice >= 0, vertex, -1).astype(jnp.int32)
    return jnp.where(tied & better, other, choice), sign, vertex


def contact_from_choice(
    x: Array,
    segments: Segments,
    choice: Array,
    radius: Array,
    overflow: Array,
    row_ok: Array,
    rule=None,
    row_tags=None,
) -> Contact:
    """Builds the ``Contact`` of slaves ``x`` (f[N, 2], bad rows zeroed).

    Args:
      x: f[N, 2] sanitised slaves.
      segments: the resolved master segments.
      choice: i32[N] chosen segment per slave, -1 for none; vertex ties are
        settled here (``prefer_outside``).
      radius: f[] search radius, or f[N] one per slave.
      overflow: bool[] passed through.
      row_ok: bool[N] real rows; the others are reported not found.
      rule: the pair rule (``pairs.Rule``) the search applied, or None, and
      row_tags: the slaves' tags it read: the vertex tie rule asks it too.
    """
    choice = jax.lax.stop_gradient(choice)
    if segments.ok.shape[0] == 0:
        choice = vertex = jnp.full(choice.shape, -1, jnp.int32)
        projection = jax.vmap(project)(x, jnp.zeros_like(x), jnp.zeros_like(x))
    else:
        tie = prefer_outside(x, segments, choice, rule, row_tags)
        choice, sign, vertex = jax.lax.stop_gradient(tie)
        projection = _on_chosen(project, x, segments, choice)
        tied_gap = sign * jnp.abs(projection.gap)
        projection = projection._replace(gap=jnp.where(sign != 0, tied_gap, projection.gap))
    has_choice = row_ok & (choice >= 0)
    found = has_choice & (jnp.abs(projection.gap) <= radius)

    def keep(value):
        return jnp.where(found.reshape(found.shape + (1,) * (value.ndim - 1)), value, 0)

    gap = keep(projection.gap)
    return Contact(
        gap=gap,
        xi=keep(projection.xi),
        segment=jnp.where(found, choice, -1).astype(jnp.int32),
        point=keep(projection.point),
        normal=keep(projection.normal),
        vertex=jnp.where(found, vertex, -1),
        found=found,
        active=found & (gap < 0),
        overflow=overflow,
    )


def contact_on_faces(
    x: Array, segments: Segments, choice: Array, radius: Array, overflow: Array, row_ok: Array
) -> Contact:
    """The 3D ``Contact`` of slaves ``x`` (f[N, 3], bad rows zeroed) on their chosen triangles.

    ``choice`` (i32[N], -1 for none) keeps exact ties with the lower face
    index. The gap is ``(x - p) . n`` on the face's interior and ``+-|x - p|``
    on an edge or at a vertex, signed by that feature's pseudo-normal
    (``triangles.pseudo_normals``; zero counted positive); the two agree
    where they meet. ``xi`` holds the barycentric weights of the face's
    corners 1 and 2, ``normal`` the face's outward unit normal, ``vertex``
    (i32[N, 2]) the feature's nodes: ``(-1, -1)`` on the interior, ``(v, -1)``
    at a vertex, the edge's two nodes in increasing order on an edge.
    """
    choice = jax.lax.stop_gradient(choice)
    num_rows = x.shape[0]
    if segments.ok.shape[0] == 0:
        return Contact(
            gap=jnp.zeros(num_rows, x.dtype),
            xi=jnp.zeros((num_rows, 2), x.dtype),
            segment=jnp.full(num_rows, -1, jnp.int32),
            point=jnp.zeros_like(x),
            normal=jnp.zeros_like(x),
            vertex=jnp.full((num_rows, 2), -1, jnp.int32),
            found=jnp.zeros(num_rows, bool),
            active=jnp.zeros(num_rows, bool),
            overflow=overflow,
        )
    index = jnp.maximum(choice, 0)
    chosen = triangles.face(segments.start[index], segments.end[index], segments.apex[index])
    closest = jax.vmap(triangles.closest_point)(x, chosen)
    normal = triangles.unit_normals(segments)[index]
    pseudo = triangles.pseudo_normals(segments)
    region = jax.lax.stop_gradient(closest.region)
    corners = segments.indices[index]
    # The feature's corners: a vertex region's corner, an edge region's two.
    first = jnp.select(
        [region == triangles.AT_B, region == triangles.ON_BC, region == triangles.AT_C],
        [1, 1, 2],
        jnp.where(region == triangles.ON_CA, 2, 0),
    )
    on_edge = region >= triangles.ON_AB
    at_vertex = (region > triangles.INTERIOR) & ~on_edge
    node = jnp.take_along_axis(corners, first[:, None], axis=1)[:, 0]
    following = jnp.take_along_axis(corners, ((first + 1) % 3)[:, None], axis=1)[:, 0]
    edge_of = jnp.where(region == triangles.ON_AB, 0, jnp.where(region == triangles.ON_BC, 1, 2))
    edge_normal = jnp.take_along_axis(pseudo.edge[index], edge_of[:, None, None], axis=1)[:, 0]
    feature_normal = jnp.where(at_vertex[:, None], pseudo.vertex[node], edge_normal)
    offset = closest.offset
    distance = safe_sqrt(jnp.sum(offset * offset, axis=-1))
    outside = jnp.sum(jax.lax.stop_gradient(offset) * feature_normal, axis=-1) >= 0
    corner_gap = jnp.where(outside, distance, -distance)
    gap = jnp.where(region == triangles.INTERIOR, jnp.sum(offset * normal, axis=-1), corner_gap)
    vertex = jnp.stack(
        [
            jnp.where(on_edge, jnp.minimum(node, following), jnp.where(at_vertex, node, -1)),
            jnp.where(on_edge, jnp.maximum(node, following), -1),
        ],
        axis=-1,
    )
    has_choice = row_ok & (choice >= 0)
    found = has_choice & (jnp.abs(gap) <= radius)

    def keep(value):
        return jnp.where(found.reshape(found.shape + (1,) * (value.ndim - 1)), value, 0)

    gap = keep(gap)
    return Contact(
        gap=gap,
        xi=keep(closest.weights),
        segment=jnp.where(found, choice, -1).astype(jnp.int32),
        point=keep(closest.point),
        normal=keep(normal),
        vertex=jnp.where(found[:, None], vertex, -1).astype(jnp.int32),
        found=found,
        active=found & (gap < 0),
        overflow=overflow,
    )


def rounding_reach(segments: Segments, radius):
    """f[]: ``radius`` plus a bound on how far the search's score (its squared
    distance) and the reported gap may differ by rounding.

    They are two evaluations of one distance D that differ in how ``xi`` is
    rounded (a product with the inverse length, a quotient) and in the
    interior's gap being a dot product with the rounded unit normal: each is
    within a few ulps of ``D + 2 |d|`` (``geometry._offset`` measures from
    the nearer end, ``|x - a| <= D + |d|``). 64 ulps of ``radius + 4 L``,
    L the longest real segment, bounds both with room to spare.
    """
    lengths = jnp.max(jnp.abs(segments.end - segments.start), axis=-1)
    longest = 2 * jnp.max(jnp.where(segments.ok, lengths, 0), initial=0)  # >= |d|
    eps = jnp.finfo(segments.start.dtype).eps
    return radius + 64 * eps * (radius + 4 * longest)


class Closest(Query):
    """The closest real segment of each slave ``x`` within its radius: a ``Contact``."""

    name = "closest"
    result = Contact
    listing = ContactList
    flag = "found"
    num_points = 1
    uses_radius = True

    def check(self, points, surface, radius, mask):
        # The query takes 3D input; the forms that do not yet refuse it themselves.
        (x,) = points
        x, surface, radius, mask = inputs.check_contact_inputs(x, surface, radius, mask, (2, 3))
        return (x,), surface, radius, mask

    def sizing(self, points, reach):
        return {"radius": reach}

    def kernel(self, x, edge):
        if x.shape[-1] == 3:
            return triangles.squared_distance(x, edge)
        return squared_distance(x, edge)

    def sanitize(self, points, mask):
        x, ok = sanitize_points(points[0], mask)
        return (x,), ok

    def pair_reach(self, points, ok, radius):
        return radius

    def row_boxes(self, points, mask):
        # Only the mask is given to the cull: a row with a NaN or an infinite
        # coordinate fails every comparison with the master's box, which is
        # finite (real segments are) or empty, and ``broad.kept_rows`` tests
        # the kept rows; a finiteness test per row here would be a pass over
        # x of its own.
        return points[0], points[0], mask

    def inflate(self, points, radius, mask):
        return inputs.reach_of(radius, mask)

    def cell_boxes(self, segments, kept, ok, culled: Box) -> Box:
        return culled

    def assemble(self, kept, segments, choice, radius, overflow, ok, ruling):
        if segments.apex is not None:
            return contact_on_faces(kept[0], segments, choice, radius, overflow, ok)
        rule, tags = ruling
        return contact_from_choice(kept[0], segments, choice, radius, overflow, ok, rule, tags)

    def reportable(self, choice, score, ok, segments, radius):
        # Every row the exhaustive form finds, and a few at the radius to
        # within rounding: the score and the assembled gap round differently.
        reach = rounding_reach(segments, radius)
        return ok & (choice >= 0) & (score <= reach * reach)


CLOSEST = Closest()
