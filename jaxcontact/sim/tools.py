"""Rigid tools: a wedge with a rounded edge, in ``jax.numpy`` (differentiable in the rake).

A ``Tool`` is the static part of the geometry (lengths, clearance, the edge's
radius and how finely it is drawn, an optional chip breaker); the rake angle
and the place are traced arguments of ``outline``. The wedge is the one of
orthogonal cutting (ISO 3002-1's tool-in-hand angles): the rake face leans
back by the rake angle ``gamma`` from the vertical and faces ``-x``, the
cutting direction; the flank rises from the edge at the clearance angle
``alpha``; the wedge between them is ``90° - gamma - alpha``. The edge is a
circular arc of ``edge_radius`` tangent to both faces, so its centre lies on
the wedge's bisector at ``r / sin(wedge / 2)`` from the sharp tip where the
faces would meet.

Smooth normals (``jaxcontact.Smooth``) turn the arc's end node's normal
halfway towards the arc's first segment, and interpolate it along the face
from there: on a face drawn as one segment, a pressure on its flat part
pushes along the face (a cut's rake face made 10 of its 69 N/mm of thrust
so). ``Tool(split_faces=True)`` puts a node on each face one arc segment
(its chord) from the arc: the normal turns over that short segment, as it
does over each of the arc's, and the rest of each face has its own normal.
One node does it wherever the mesh's nodes are, where splitting the face
into element-long segments would tie the tool to a mesh and still tilt
the normal over the first element.

The outline, counter-clockwise: the arc from the rake face's outward normal
(angle ``180° - gamma``) past the edge's lowest point (270°) to the flank's
(``270° + alpha``), then the flank's end, the back corner and the rake face's
end; with ``split_faces``, a node on the flank one chord after the arc and
one on the rake face one chord before it. With a ``breaker`` the rake face
stops at a land and a backwall turns towards the chip (the same node count:
the back corner is left out).

Face lengths are measured from the sharp tip, as a tool drawing gives them.
A run places the tool by its sharp ``tip`` or by its edge's ``lowest`` point.
"""

from __future__ import annotations

import dataclasses
import math

import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact import Surface

__all__ = ["Tool", "outline", "rings", "surface"]


@dataclasses.dataclass(frozen=True)
class Tool:
    """A rigid tool's static geometry (mm, degrees).

    Lengths in mm and angles in degrees, as a tool drawing gives them (the
    rake angle, which a run may differentiate, is ``outline``'s, in radians).

    Attributes:
      edge_radius: the cutting edge's radius (mm; > 0).
      clearance: the clearance angle (degrees, in (0, 90)).
      rake_face: the rake face's length from the sharp tip (mm).
      flank: the flank's length from the sharp tip (mm).
      arc_segments: segments drawing the edge's arc.
      breaker: ``(land, angle, length)``: a chip breaker's backwall, the rake
        face ``land`` mm long, then a wall ``length`` mm long turned ``angle``
        degrees from the rake face towards the chip; None: a plain rake face.
      split_faces: a node on each face one arc chord from the arc, so that
        smooth normals are the faces' own beyond it (two nodes more).
    """

    edge_radius: float
    clearance: float
    rake_face: float
    flank: float
    arc_segments: int = 8
    breaker: tuple[float, float, float] | None = None
    split_faces: bool = False

    def __post_init__(self):
        if not self.edge_radius > 0:
            raise ValueError(f"Tool.edge_radius must be > 0 mm; got {self.edge_radius!r}")
        if not 0 < self.clearance < 90:
            raise ValueError(f"Tool.clearance must be in (0, 90) degrees; got {self.clearance!r}")
        if not (self.rake_face > 0 and self.flank > 0):
            raise ValueError(
                f"Tool.rake_face and Tool.flank must be > 0 mm; got {self.rake_face!r} "
                f"and {self.flank!r}"
            )
        if not (isinstance(self.arc_segments, int) and self.arc_segments >= 1):
            raise ValueError(f"Tool.arc_segments must be an int >= 1; got {self.arc_segments!r}")
        if not isinstance(self.split_faces, bool):
            raise ValueError(f"Tool.split_faces must be a bool; got {self.split_faces!r}")
        if self.breaker is not None:
            try:
                land, angle, length = (float(v) for v in self.breaker)
            except (TypeError, ValueError):
                raise ValueError(
                    "Tool.breaker must be None or (land mm, angle degrees, length mm); "
                    f"got {self.breaker!r}"
                ) from None
            if not (land > 0 and 0 < angle < 90 and length > 0):
                raise ValueError(
                    "Tool.breaker (land, angle, length) needs land > 0, 0 < angle < 90 "
                    f"degrees and length > 0; got {self.breaker!r}"
                )
            object.__setattr__(self, "breaker", (land, angle, length))

    @property
    def nodes(self) -> int:
        """The outline's node count: the arc's, three more, and two with ``split_faces``."""
        return self.arc_segments + 4 + 2 * self.split_faces


def _wedge(tool: Tool, rake, dtype):
    """(rake face's direction up it, flank's direction, the edge centre's offset from the tip)."""
    rake = jnp.asarray(rake, dtype)
    clearance = math.radians(tool.clearance)
    up = jnp.stack([jnp.sin(rake), jnp.cos(rake)])
    flank = jnp.asarray([math.cos(clearance), math.sin(clearance)], dtype)
    wedge = math.pi / 2 - rake - clearance
    bisector = (up + flank) / jnp.linalg.norm(up + flank)
    return up, flank, bisector * tool.edge_radius / jnp.sin(wedge / 2)


def outline(tool: Tool, rake, *, tip=None, lowest=None, dtype=None) -> Array:
    """f[tool.nodes, 2]: the outline, counter-clockwise, placed by ``tip`` or ``lowest``.

    Args:
      tool: the static geometry.
      rake: the rake angle (radians; traced: the outline is differentiable in it).
      tip: f[2], the sharp tip where the faces would meet; or
      lowest: f[2], the edge's lowest point. Exactly one of the two.
      dtype: the float dtype (default: the rake's, at least float32).
    """
    if (tip is None) == (lowest is None):
        raise ValueError("tools.outline needs exactly one of tip= and lowest=")
    dtype = jnp.result_type(rake, float) if dtype is None else jnp.dtype(dtype)
    rake = jnp.asarray(rake, dtype)
    up, flank, offset = _wedge(tool, rake, dtype)
    radius = tool.edge_radius
    if tip is None:
        centre = jnp.asarray(lowest, dtype) + jnp.asarray([0.0, radius], dtype)
        tip = centre - offset
    else:
        tip = jnp.asarray(tip, dtype)
        centre = tip + offset
    clearance = math.radians(tool.clearance)
    first = jnp.pi - rake
    last = jnp.asarray(1.5 * math.pi + clearance, dtype)
    angles = first + (last - first) * jnp.linspace(0.0, 1.0, tool.arc_segments + 1, dtype=dtype)
    arc = centre[None, :] + radius * jnp.stack([jnp.cos(angles), jnp.sin(angles)], -1)
    flank_end = tip + tool.flank * flank
    if tool.split_faces:
        chord = 2 * radius * jnp.sin((last - first) / (2 * tool.arc_segments))
        start = jnp.stack([arc[-1] + chord * flank])
        end = jnp.stack([arc[0] + chord * up])
    else:
        start = end = jnp.zeros((0, 2), dtype)
    if tool.breaker is not None:
        land, angle, length = tool.breaker
        land_end = tip + land * up
        turn = math.radians(angle)
        wall = jnp.stack(
            [
                up[0] * math.cos(turn) - up[1] * math.sin(turn),
                up[0] * math.sin(turn) + up[1] * math.cos(turn),
            ]
        )
        corners = jnp.stack([flank_end, land_end + length * wall, land_end])
        return jnp.concatenate([arc, start, corners, end])
    rake_end = tip + tool.rake_face * up
    back = jnp.stack([flank_end[0], rake_end[1]])
    return jnp.concatenate([arc, start, jnp.stack([flank_end, back, rake_end]), end])


def rings(nodes: int, count: int = 1) -> np.ndarray:
    """i32[count * nodes, 2]: the segments of ``count`` closed outlines of ``nodes`` each."""
    starts = np.arange(nodes)
    ring = np.stack([starts, (starts + 1) % nodes], -1).astype(np.int32)
    return np.concatenate([ring + k * nodes for k in range(count)])


def surface(tool: Tool, rake, *, tip=None, lowest=None, dtype=None) -> Surface:
    """The closed ``Surface`` of ``outline(tool, rake, tip=..., lowest=...)``."""
    nodes = outline(tool, rake, tip=tip, lowest=lowest, dtype=dtype)
    return Surface(nodes, jnp.asarray(rings(tool.nodes)))
