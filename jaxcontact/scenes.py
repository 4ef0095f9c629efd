"""The reference scenes of docs/scenes.md, built for any size and tool position.

Every builder returns a ``Scene``: slave coordinates before and after the
step (``x_prev`` equals ``x`` where nothing moves), the master ``Surface`` and
the scene's search radius. Builders run in NumPy float64 and convert once to
the requested dtype, so a float32 scene is the float64 scene rounded.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from jaxcontact._types import Array, Surface


class Scene(NamedTuple):
    """One reference configuration."""

    x_prev: Array  # f[N, 2]  slave positions at the previous step
    x: Array  # f[N, 2]  slave positions now
    surface: Surface  # the master
    radius: float  # the scene's search radius d_max


def grid(x_range, y_range, nx: int, ny: int) -> np.ndarray:
    """f64[nx * ny, 2]: a uniform grid numbered row by row (y outer, x inner)."""
    xs = np.linspace(*x_range, nx)
    ys = np.linspace(*y_range, ny)
    return np.stack(np.meshgrid(xs, ys, indexing="xy"), axis=-1).reshape(-1, 2)


def _polyline(points: np.ndarray, closed: bool, dtype) -> Surface:
    count = len(points)
    starts = np.arange(count if closed else count - 1)
    segments = np.stack([starts, (starts + 1) % count], axis=-1).astype(np.int32)
    return Surface(jnp.asarray(points, dtype), jnp.asarray(segments))


def paper_tool(length: float = 10.0, tip=(50.9, 7.0), dtype=jnp.float32) -> Surface:
    """The paper's sharp tool: rake angle 7 deg, clearance 2 deg, faces ``length`` long.

    Two segments, counter-clockwise ``R -> T -> C``: segment 0 is the rake
    face, segment 1 the clearance face.
    """
    tip = np.asarray(tip, np.float64)
    rake_end = tip + [length * math.tan(math.radians(7)), length]
    clearance_end = tip + [length, length * math.tan(math.radians(2))]
    return _polyline(np.stack([rake_end, tip, clearance_end]), closed=False, dtype=dtype)


def paper_scene(n: int, *, length: float = 10.0, d: float = 5.0, dtype=jnp.float32) -> Scene:
    """The source paper's scene: ``(n + 1)**2`` workpiece nodes on ``[0, 50] x [0, 9]``.

    The tool's motion by ``-d`` in x is applied, as in the paper, as ``+d`` to
    every node: ``x_prev`` is the grid, ``x`` the grid moved by ``d``. The
    radius is the paper's ``d_max = length / 10``.

    Example:
      >>> scene = paper_scene(250)
      >>> scene.x.shape, scene.surface.segments.shape
      ((63001, 2), (2, 2))
    """
    start = grid((0.0, 50.0), (0.0, 9.0), n + 1, n + 1)
    moved = start + [d, 0.0]
    return Scene(
        jnp.asarray(start, dtype),
        jnp.asarray(moved, dtype),
        paper_tool(length, dtype=dtype),
        length / 10,
    )


def cutting_tool_outline(x_tip: float, *, arc_segments: int = 16) -> np.ndarray:
    """f64[K, 2]: the cutting tool's closed outline, counter-clockwise.

    Sharp tip at ``(x_tip, 4)``, rake angle 10 deg, clearance angle 7 deg,
    faces 3 long, the tip rounded by an arc of radius 0.05 cut into
    ``arc_segments`` segments: ``arc_segments + 4`` segments in all.
    """
    rake, clearance, face, edge_radius = math.radians(10), math.radians(7), 3.0, 0.05
    tip = np.array([x_tip, 4.0])
    rake_dir = np.array([math.sin(rake), math.cos(rake)])
    flank_dir = np.array([math.cos(clearance), math.sin(clearance)])
    rake_end, flank_end = tip + face * rake_dir, tip + face * flank_dir
    back = np.array([flank_end[0], rake_end[1]])
    # The arc's centre lies on the bisector of the tip's wedge, at the distance
    # from the tip where a circle of radius r touches both faces.
    wedge = math.acos(float(rake_dir @ flank_dir))
    bisector = (rake_dir + flank_dir) / np.linalg.norm(rake_dir + flank_dir)
    centre = tip + bisector * edge_radius / math.sin(wedge / 2)
    along = edge_radius / math.tan(wedge / 2)
    on_flank, on_rake = tip + along * flank_dir, tip + along * rake_dir
    angle_flank = math.atan2(*(on_flank - centre)[::-1])
    angle_rake = math.atan2(*(on_rake - centre)[::-1])
    # Counter-clockwise the outline runs rake end -> tip -> flank end, so the arc
    # turns counter-clockwise (increasing angle) from the rake tangent point,
    # past the tip, to the flank tangent point.
    if angle_flank < angle_rake:
        angle_flank += 2 * math.pi
    angles = np.linspace(angle_rake, angle_flank, arc_segments + 1)
    arc = centre + edge_radius * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    return np.concatenate([arc, [flank_end, back, rake_end]])


def cutting_scene(
    num_nodes: int, x_tip: float, *, x_tip_prev: float | None = None, dtype=jnp.float32
) -> Scene:
    """The cutting scene: a ``[0, 20] x [0, 5]`` grid and the rounded 20-segment tool.

    ``ny = max(2, round(sqrt(N / 4)))``, ``nx = max(2, round(N / ny))``. The tool
    moves in ``-x``; its previous tip position ``x_tip_prev`` (default: no
    motion) sets ``x_prev``, the nodes' previous positions seen from the tool in
    its current place: ``x - (x_tip_prev - x_tip)`` in x. Radius 0.1.

    Example:
      >>> scene = cutting_scene(81_939, 18.0)
      >>> scene.x.shape, scene.surface.segments.shape
      ((81939, 2), (20, 2))
    """
    ny = max(2, round(math.sqrt(num_nodes / 4)))
    nx = max(2, round(num_nodes / ny))
    nodes = grid((0.0, 20.0), (0.0, 5.0), nx, ny)
    travel = 0.0 if x_tip_prev is None else x_tip_prev - x_tip
    surface = _polyline(cutting_tool_outline(x_tip), closed=True, dtype=dtype)
    return Scene(jnp.asarray(nodes - [travel, 0.0], dtype), jnp.asarray(nodes, dtype), surface, 0.1)


def rough_die_scene(num_nodes: int, num_segments: int, *, dtype=jnp.float32) -> Scene:
    """The rough-die scene: ``y = 0.1 sin(2 pi x)`` on ``[0, 20]`` in ``num_segments`` steps.

    The polyline runs from ``x = 20`` to ``x = 0`` so its normals point up.
    Slaves: a grid over ``[0, 20] x [-0.25, 0.25]`` with ``nx / ny ~ 40``. Radius 0.02.
    """
    ny = max(2, round(math.sqrt(num_nodes / 40)))
    nx = max(2, round(num_nodes / ny))
    nodes = grid((0.0, 20.0), (-0.25, 0.25), nx, ny)
    xs = np.linspace(20.0, 0.0, num_segments + 1)
    die = np.stack([xs, 0.1 * np.sin(2 * np.pi * xs)], axis=-1)
    x = jnp.asarray(nodes, dtype)
    return Scene(x, x, _polyline(die, closed=False, dtype=dtype), 0.02)
