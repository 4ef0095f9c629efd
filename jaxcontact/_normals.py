"""Smooth normals on a faceted outline, sharp corners kept.

A faceted outline's normal jumps at every vertex, so a slave sliding over a
discretised curve feels a force that turns in steps. ``normals=Smooth(corner)``
replaces the facet's normal by one interpolated along the segment between
normals at its two end nodes: ``n(xi) = normalize((1 - xi) m_a + xi m_b)``
(Phong-style normal interpolation, as in the smoothed node-to-segment
contact reviewed by Wriggers, *Computational Contact Mechanics*, 2nd ed.,
2006, section 9.4). At a node where the outline turns by less than the
corner angle, both segments meeting there share one nodal normal, the
normalized sum of their normals (the bisector), so the field is continuous
across the vertex; where it turns by the corner angle or more (a tool's
cutting edge, a 90 degree corner) each segment keeps its own normal there,
and the jump stays.

Why this and not a curved patch (a 2D Nagata or Hermite segment): the
closest point stays the one on the straight segment that the search found,
so nothing is searched again and the point, ``xi``, the segment and the
vertex are the faceted ones; only the direction changes. The gap is
measured along the normal used, ``(x - point) . n(xi)`` (at a vertex kept
sharp, the flat gap ``+-|x - point|``, so ``Smooth(corner=0)`` is the flat
search): continuous across a smoothed vertex (in a convex vertex's region the
point is the vertex and the normal is the nodal one on both sides) and of the faceted gap's sign
wherever the two normals are less than 90 degrees apart. What it leaves out:
the geometry is still the facets', so the gap is not the distance to a
smooth curve (the difference is the interpolation error, of order the
segment length times the turn angle), and the force along ``n(xi)`` is not
the exact gradient of a penalty energy of that gap.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp

from jaxcontact._pipeline import segments as _segments
from jaxcontact._pipeline.outline import vertex_neighbours
from jaxcontact._pipeline.rows import on_rows
from jaxcontact._types import Array, ContactList, Surface

# The default corner angle: an outline that turns by less than this at a node
# is taken as the faceting of a smooth curve (a circle of 8 or more segments);
# by this or more it is a corner.
CORNER_DEGREES = 45.0


@dataclasses.dataclass(frozen=True)
class Smooth:
    """Smooth normals: interpolated along each segment between nodal normals.

    Passed as ``normals=`` to ``all_to_all``, ``bucket_sort`` and ``Search``
    (``None``, the default, is each segment's own flat normal). The nodal
    normal is the bisector of the two segments' normals where the outline
    turns by less than ``corner`` degrees, and each segment's own normal at a
    sharper corner; the gap is measured along the interpolated normal (the
    repository's docs/contract.md, "Smooth normals"). The segment, ``xi`` and
    point are the flat search's.

    Attributes:
      corner: the corner angle in degrees, in [0, 180]; ``0`` keeps every
        vertex sharp (the flat search's gaps).

    Example:
      >>> import jaxcontact
      >>> jaxcontact.Smooth(corner=30)
      Smooth(corner=30.0)
    """

    corner: float = CORNER_DEGREES

    def __post_init__(self):
        try:
            corner = float(self.corner)
        except (TypeError, ValueError):
            raise ValueError(
                f"Smooth.corner must be an angle in degrees; got {self.corner!r}"
            ) from None
        if not (0 <= corner <= 180):
            raise ValueError(f"Smooth.corner must lie in [0, 180] degrees; got {corner}")
        # A plain float: the search that holds it is hashed as a static argument.
        object.__setattr__(self, "corner", corner)


def check_normals(normals) -> Smooth | None:
    """``normals`` checked: ``None`` (flat) or a ``Smooth``."""
    if normals is None or isinstance(normals, Smooth):
        return normals
    if isinstance(normals, str):
        raise TypeError(
            f"normals={normals!r} was removed in 2.0: pass normals=None for flat normals or "
            "normals=jaxcontact.Smooth(corner=45.0) for smooth ones (corner= moved into Smooth)"
        )
    raise ValueError(f"normals must be None or a jaxcontact.Smooth; got {type(normals).__name__}")


def _unit(vectors: Array) -> Array:
    """Each row of f[..., 2] over its length; zero rows stay zero (no NaN, no inf gradient)."""
    squared = jnp.sum(vectors**2, axis=-1, keepdims=True)
    safe = jnp.where(squared > 0, squared, 1)
    return jnp.where(squared > 0, vectors / jnp.sqrt(safe), 0)


def end_normals(surface: Surface, corner: float) -> tuple[Array, Array]:
    """``(f[M, 2, 2], bool[M, 2])``: the normal of each segment at its start and
    at its end node, and whether it is smoothed there.

    The bisector of the two segments' normals where the outline turns there by
    less than ``corner`` degrees, the segment's own normal elsewhere (an open
    end, a sharper corner, a node of more than two segments past the first).
    """
    segments = _segments.resolve_segments(surface)
    tangent = segments.end - segments.start
    own = _unit(jnp.stack([tangent[:, 1], -tangent[:, 0]], axis=-1))  # turned clockwise
    before, after = vertex_neighbours(segments)
    threshold = math.cos(math.radians(corner))

    def at_end(neighbour):
        other = own[jnp.maximum(neighbour, 0)]
        smooth = (neighbour >= 0) & (jnp.sum(own * other, axis=-1) > threshold)
        return jnp.where(smooth[:, None], _unit(own + other), own), smooth

    (start, smooth_start), (end, smooth_end) = at_end(before), at_end(after)
    return jnp.stack([start, end], axis=1), jnp.stack([smooth_start, smooth_end], axis=1)


def smoothed(result, x: Array, surface: Surface, corner: float):
    """``result`` (a ``Contact`` or ``ContactList`` of the slaves ``x``) with
    the smooth normal and the gap along it; ``active`` follows the new gap.
    Only found rows are worked on (``rows.on_rows``)."""
    num_segments = surface.segments.shape[0]
    if num_segments == 0 or x.shape[0] == 0:
        return result
    table = end_normals(surface, corner)
    if isinstance(result, ContactList):
        rows = x.at[result.node].get(mode="fill", fill_value=0)
        normal, gap = _along(result, rows, table, num_segments)
    else:

        def at_rows(rows):
            found = result._replace(
                **{
                    name: getattr(result, name).at[rows].get(mode="fill", fill_value=0)
                    for name in ("gap", "xi", "segment", "point", "vertex", "found")
                }
            )
            return _along(found, x.at[rows].get(mode="fill", fill_value=0), table, num_segments)

        normal, gap = on_rows(result.found, at_rows)
    return result._replace(gap=gap, normal=normal, active=result.found & (gap < 0))


def _along(result, rows: Array, table, num_segments: int):
    """``(normal, gap)`` of the entries of ``result`` at the slaves ``rows``."""
    chosen = jnp.clip(result.segment, 0, num_segments - 1)
    normals, smooth = table
    ends, smooth = normals[chosen], smooth[chosen]
    xi = result.xi[:, None]
    normal = _unit((1 - xi) * ends[:, 0] + xi * ends[:, 1])
    found = result.found
    rows = jnp.where(found[:, None], rows, result.point)
    normal = jnp.where(found[:, None], normal, 0)
    gap = jnp.sum((rows - result.point) * normal, axis=-1)
    # At a vertex kept sharp the normal is the segment's own: keep the flat gap there.
    sharp_vertex = (result.vertex >= 0) & ~jnp.where(result.xi >= 0.5, smooth[:, 1], smooth[:, 0])
    gap = jnp.where(found, jnp.where(sharp_vertex, result.gap, gap), 0)
    return normal, gap


smoothed_jit = jax.jit(smoothed, static_argnums=3)
