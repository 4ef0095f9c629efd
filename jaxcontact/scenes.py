"""The reference scenes of docs/scenes.md, built for any size and tool position.

Every builder returns a ``Scene``: slave coordinates before and after the
step (``x_prev`` equals ``x`` where nothing moves), the master ``Surface`` and
the scene's search radius. Builders run in NumPy float64 and convert once to
the requested dtype, so a float32 scene is the float64 scene rounded.

The self-contact builders (``corner_outline``, ``folded_u``, ``curling_chip``,
``two_blocks``) return a ``BodiesScene`` instead: deformable outlines whose
every node is a slave, labelled by body, with the nodes that penetrate
another part of the outline and their analytic depths.

In 3D (``all_to_all`` alone in this release), ``split_quads`` turns quads
into triangles and ``box_surface`` builds a closed triangulated box.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from jaxcontact._removed import listing as _listing
from jaxcontact._types import Array, Surface

__all__ = [
    "BodiesScene",
    "Scene",
    "box_surface",
    "corner_outline",
    "curling_chip",
    "cutting_scene",
    "cutting_tool_outline",
    "folded_u",
    "grid",
    "paper_scene",
    "paper_tool",
    "rough_die_scene",
    "split_quads",
    "two_blocks",
]


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


# Self-contact and several deformable bodies.


class BodiesScene(NamedTuple):
    """Deformable outlines whose every node is a slave: self-contact and several bodies."""

    x: Array  # f[N, 2]  the slaves: every outline node (the same array as surface.nodes)
    surface: Surface  # nodes = x, segments i32[M, 2] of the outlines
    body: Array  # i32[M]  body label of each segment
    slave_node: Array  # i32[N]  surface node of each slave: arange(N)
    slave_body: Array  # i32[N]  body of each node
    radius: float  # the scene's search radius
    pressed: Array  # bool[N]  the node lies inside another part of the outline (or body)
    depth: Array  # f[N]  its analytic penetration depth, > 0; 0 where not pressed, NaN if unknown


def _surface(nodes: np.ndarray, segments: np.ndarray, body: np.ndarray, dtype) -> Surface:
    """The ``Surface``, with its ``body`` labels where ``Surface`` has that field."""
    parts = (jnp.asarray(nodes, dtype), jnp.asarray(segments, jnp.int32), None)
    if "body" in Surface._fields:
        return Surface(*parts, body=jnp.asarray(body, jnp.int32))
    return Surface(*parts)


def _bodies_scene(nodes, segments, node_body, radius, depth, dtype) -> BodiesScene:
    """The ``BodiesScene`` of float64 nodes; ``pressed`` is ``depth != 0`` (NaN included)."""
    segment_body = node_body[segments[:, 0]]
    surface = _surface(nodes, segments, segment_body, dtype)
    return BodiesScene(
        x=surface.nodes,
        surface=surface,
        body=jnp.asarray(segment_body, jnp.int32),
        slave_node=jnp.arange(len(nodes), dtype=jnp.int32),
        slave_body=jnp.asarray(node_body, jnp.int32),
        radius=float(radius),
        pressed=jnp.asarray(depth != 0),
        depth=jnp.asarray(depth, dtype),
    )


def _loop(count: int, first: int = 0) -> np.ndarray:
    """i32[count, 2]: the segments of a closed outline of nodes ``first .. first + count - 1``."""
    starts = np.arange(count)
    return first + np.stack([starts, (starts + 1) % count], axis=-1).astype(np.int32)


# An outline is traced along pieces, each a (length, at) pair: ``at(u)`` gives
# the points at parameters u in [0, 1). A piece cut into n steps contributes its
# start and n - 1 points inside; its end is the next piece's start.


def _line(a, b):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return float(np.linalg.norm(b - a)), lambda u: a + u[:, None] * (b - a)


def _arc(centre, radius: float, start: float, stop: float):
    """The arc from angle ``start`` to ``stop`` (radians; counter-clockwise when stop > start)."""
    centre = np.asarray(centre, np.float64)

    def at(u):
        angle = start + u * (stop - start)
        return centre + radius * np.stack([np.cos(angle), np.sin(angle)], axis=-1)

    return radius * abs(stop - start), at


def _polygon(corners) -> list:
    """The pieces of the closed polygon through ``corners``."""
    return [
        _line(a, b) for a, b in zip(corners, np.roll(np.asarray(corners), -1, axis=0), strict=True)
    ]


def _trace(pieces, counts) -> np.ndarray:
    """f64[sum(counts), 2]: piece ``k`` cut into ``counts[k]`` equal steps."""
    return np.concatenate([at(np.arange(n) / n) for (_, at), n in zip(pieces, counts, strict=True)])


def corner_outline(*, fine: float = 0.05, coarse: float = 0.5, dtype=jnp.float32) -> BodiesScene:
    """One undeformed body whose outline has 90 deg and 40 deg corners, convex and concave.

    The closed counter-clockwise outline (mm), from the origin: the bottom
    ``(0, 0) -> (8, 0)`` and the right side up to ``(8, 2.5)`` (coarse), a step
    left to ``(5.5, 2.5)`` (fine; a 90 deg convex corner between coarse and
    fine faces) and up to ``(5.5, 4.5)`` (coarse; a 90 deg concave corner), a
    spike of 40 deg on the base ``[4, 5.5]`` with its apex at ``(4.75, 6.56)``
    (fine), the top ``y = 4.5`` (fine) with a notch of 40 deg, 1.5 deep, whose
    bottom is ``(2.25, 3)`` (fine), the rest of the top to ``(0, 4.5)`` and the
    left side (coarse). Each face is cut into equal segments at most ``fine``
    or ``coarse`` long. Faces that share no corner stay at least 1 mm apart,
    so only the two faces of a corner come within the radius of each other.

    Nothing is deformed: ``pressed`` is all False and ``depth`` all 0. The
    radius is ``2 * fine``.

    Example:
      >>> corner_outline().x.shape
      (265, 2)
    """
    half_spike = 0.75 / math.tan(math.radians(20))  # base half-width 0.75: apex at 40 deg
    half_notch = 1.5 * math.tan(math.radians(20))  # 1.5 deep: opening of 40 deg
    corners_and_steps = [
        ((0.0, 0.0), coarse),
        ((8.0, 0.0), coarse),
        ((8.0, 2.5), fine),  # 90 deg convex
        ((5.5, 2.5), coarse),  # 90 deg concave
        ((5.5, 4.5), fine),
        ((4.75, 4.5 + half_spike), fine),  # the spike's apex, 40 deg convex
        ((4.0, 4.5), fine),
        ((2.25 + half_notch, 4.5), fine),
        ((2.25, 3.0), fine),  # the notch's bottom, 40 deg concave
        ((2.25 - half_notch, 4.5), coarse),
        ((0.0, 4.5), coarse),
    ]
    corners, steps = zip(*corners_and_steps, strict=True)
    pieces = _polygon(corners)
    counts = [
        math.ceil(length / step - 1e-9) for (length, _), step in zip(pieces, steps, strict=True)
    ]
    nodes = _trace(pieces, counts)
    count = len(nodes)
    return _bodies_scene(
        nodes, _loop(count), np.zeros(count, np.int32), 2 * fine, np.zeros(count), dtype
    )


def _distance_to_segment(points: np.ndarray, a, b) -> np.ndarray:
    """f64[N]: the distance from each point to the segment ``a -> b``."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    t = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=-1)


def folded_u(
    num_per_arm: int = 40, *, thickness: float = 0.5, depth: float = 0.05, dtype=jnp.float32
) -> BodiesScene:
    """A strip folded into a U whose upper arm is pressed into the lower one (self-contact).

    One body, one closed counter-clockwise outline (mm). Two arms ``thickness``
    thick over ``x in [0, 4]``, joined at ``x = 0`` by a half-circle centred on
    ``(0, thickness + 0.1)``: the lower arm is ``[0, 4] x [0, thickness]``; the
    upper arm's bottom face lies 0.2 above the lower arm's top face
    (``y = thickness + 0.2``) except on ``x in [1.5, 3.5]``, where it has been
    pushed down to ``y = thickness - depth``, with straight transitions over
    ``[1.2, 1.5]`` and ``[3.5, 3.8]``; its top face follows ``thickness`` above.
    The fold's inner half-circle has radius 0.1 (half the gap), the outer one
    ``thickness + 0.1``. Each arm face is cut into about ``num_per_arm``
    segments, steps of ``4 / num_per_arm`` in x with a node at every kink; the
    ends and the half-circles are cut into steps of about that length.

    ``pressed``: the upper arm's bottom-face nodes below the lower arm's top
    face (``depth`` = their distance below it) and the lower arm's top-face
    nodes above the upper arm's bottom face (``depth`` = their distance to
    it: ``depth`` on the pushed stretch, less near its ends where the
    transition is nearer). All depths are exact. Radius 0.1; away from the
    fold gap no node comes within the radius of a segment that is not its
    neighbour.

    Example:
      >>> folded_u().x.shape
      (192, 2)
    """
    radius, gap, length = 0.1, 0.2, 4.0
    if not thickness > 2 * radius:
        raise ValueError(f"thickness {thickness} must exceed twice the radius {radius}")
    if not 0 <= depth < thickness / 2:
        raise ValueError(f"depth {depth} must lie in [0, thickness / 2)")
    step, t = length / num_per_arm, thickness
    y_gap, y_low = t + gap, t - depth
    # The upper arm's bottom face, left to right, through its kinks.
    bottom = np.array(
        [(0, y_gap), (1.2, y_gap), (1.5, y_low), (3.5, y_low), (3.8, y_gap), (length, y_gap)]
    )
    lower_bottom = bottom * [1, 0]
    fold = (0.0, t + gap / 2)

    def face(points, label):  # an arm face, steps of ``step`` in x between its kinks
        return [
            (_line(a, b), max(1, round(abs(b[0] - a[0]) / step)), label)
            for a, b in zip(points[:-1], points[1:], strict=True)
        ]

    def other(piece):  # an end or a half-circle, steps of about ``step``
        return [(piece, max(1, round(piece[0] / step)), 0)]

    # Counter-clockwise from (0, 0); label 1: the lower arm's top face, 2: the
    # upper arm's bottom face.
    pieces, counts, labels = zip(
        *face(lower_bottom, 0),
        *other(_line((length, 0), (length, t))),
        *face(lower_bottom[::-1] + [0, t], 1),
        *other(_arc(fold, gap / 2, -math.pi / 2, -3 * math.pi / 2)),
        *face(bottom, 2),
        *other(_line((length, y_gap), (length, y_gap + t))),
        *face(bottom[::-1] + [0, t], 0),
        *other(_arc(fold, t + gap / 2, math.pi / 2, 3 * math.pi / 2)),
        strict=True,
    )
    nodes = _trace(pieces, counts)
    label = np.repeat(labels, counts)
    # Lower top-face nodes share their x with the upper bottom face's nodes,
    # kinks included, so the upper face's height there is exact.
    upper_y = np.interp(nodes[:, 0], bottom[:, 0], bottom[:, 1])
    to_upper = [
        _distance_to_segment(nodes, a, b) for a, b in zip(bottom[1:4], bottom[2:5], strict=True)
    ]
    node_depth = np.where((label == 2) & (nodes[:, 1] < t), t - nodes[:, 1], 0.0)
    node_depth = np.where((label == 1) & (upper_y < t), np.min(to_upper, axis=0), node_depth)
    count = len(nodes)
    return _bodies_scene(nodes, _loop(count), np.zeros(count, np.int32), radius, node_depth, dtype)


def _counts(lengths: np.ndarray, total: int) -> np.ndarray:
    """int[K]: steps per piece, proportional to ``lengths``, at least 1, ``total`` in all."""
    share = lengths / lengths.sum() * total
    counts = np.maximum(1, np.floor(share)).astype(int)
    extra = np.argsort(counts - share)[: total - counts.sum()]  # the largest remainders
    counts[extra] += 1
    return counts


def _unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def curling_chip(num_nodes: int, *, dtype=jnp.float32) -> BodiesScene:
    """A workpiece after orthogonal cutting whose curled chip comes down onto its surface.

    One body, one closed counter-clockwise outline (mm) of exactly
    ``num_nodes`` nodes, about ``h`` apart (``h``: the outline's length over
    ``num_nodes``; each straight or circular piece is cut into equal steps,
    a node at every corner). The workpiece ``[0, 10] x [-2, 0]``: bottom,
    sides and the machined surface ``y = 0``. A chip 0.3 thick rises from
    ``x = 8`` on the surface, its centre line running 1 mm at 80 deg from the
    x axis (along a rake face of 10 deg), then curling back counter-clockwise
    by 190 deg round a radius of 1.5 until it heads straight down at
    ``x = 5.2``; it drops vertically onto the surface and ends in a flat tip
    0.3 wide at ``y = -h``. Near the tip the nodes are placed, not spaced: each
    side of the chip has nodes at ``y = h / 2`` (outside, within the radius)
    and ``y = -h / 4``, and the surface nodes keep at least ``h / 2`` from the
    chip's sides. Radius ``2 h``.

    ``pressed``: the chip-tip nodes below the surface (``depth = -y``: ``h`` on
    the tip's end, ``h / 4`` on its sides) and the surface nodes under the
    tip, inside the chip (``depth``: their distance to the tip's end, ``h``,
    or to the nearer of its sides). All depths are exact.

    Example:
      >>> scene = curling_chip(10_000)
      >>> scene.x.shape, scene.surface.segments.shape
      ((10000, 2), (10000, 2))
    """
    if num_nodes < 100:
        raise ValueError(f"num_nodes {num_nodes} < 100")
    thick, bend, rake = 0.3, 1.5, math.radians(80)
    root = thick / 2 / math.sin(rake)  # the root's half-width along the surface
    centre = np.array([8.0, 0.0]) + _unit(rake) + bend * _unit(rake + math.pi / 2)
    start, stop = rake - math.pi / 2, math.pi  # the arcs' angles round ``centre``
    outer, inner = bend + thick / 2, bend - thick / 2
    x_out, x_in, top = centre[0] - outer, centre[0] - inner, centre[1]

    def outline(h):  # the pieces; those with a fixed number of steps say it
        return [
            (_line((0, -2), (10, -2)), None),
            (_line((10, -2), (10, 0)), None),
            (_line((10, 0), (8 + root, 0)), None),
            (_line((8 + root, 0), centre + outer * _unit(start)), None),
            (_arc(centre, outer, start, stop), None),
            (_line((x_out, top), (x_out, h / 2)), None),  # the tip: down,
            (_line((x_out, h / 2), (x_out, -h)), 2),
            (_line((x_out, -h), (x_in, -h)), None),  # across,
            (_line((x_in, -h), (x_in, h / 2)), 2),
            (_line((x_in, h / 2), (x_in, top)), None),  # and up
            (_arc(centre, inner, stop, start), None),
            (_line(centre + inner * _unit(start), (8 - root, 0)), None),
            (_line((8 - root, 0), (x_in + h / 2, 0)), None),
            (_line((x_in + h / 2, 0), (x_out - h / 2, 0)), None),  # under the tip
            (_line((x_out - h / 2, 0), (0, 0)), None),
            (_line((0, 0), (0, -2)), None),
        ]

    h = sum(piece[0] for piece, _ in outline(0.0)) / num_nodes
    pieces, fixed = zip(*outline(h), strict=True)
    free = np.array([n is None for n in fixed])
    counts = np.array([n or 0 for n in fixed])
    lengths = np.array([length for length, _ in pieces])
    counts[free] = _counts(lengths[free], num_nodes - counts.sum())
    nodes = _trace(pieces, counts)
    piece = np.repeat(np.arange(len(pieces)), counts)
    x, y = nodes[:, 0], nodes[:, 1]
    tip = (piece >= 6) & (piece <= 8) & (y < 0)
    under = (piece == 13) & (x > x_out) & (x < x_in)
    node_depth = np.where(tip, -y, 0.0)
    node_depth = np.where(under, np.minimum(h, np.minimum(x - x_out, x_in - x)), node_depth)
    return _bodies_scene(
        nodes, _loop(num_nodes), np.zeros(num_nodes, np.int32), 2 * h, node_depth, dtype
    )


def two_blocks(n: int = 10, *, overlap: float = 0.05, dtype=jnp.float32) -> BodiesScene:
    """Two deformable unit squares, the upper one pressed ``overlap`` into the lower one.

    Body 0 is ``[0, 1] x [-1, 0]``; body 1 is ``[s, 1 + s] x [-overlap, 1 - overlap]``
    with ``s = 0.4 / n``, four tenths of a node spacing, so that no corners
    and no nodes of the facing faces coincide (and, at the default overlap,
    no pressed node is equally near two sides of the other square). Each is
    a closed counter-clockwise outline from its lower-left corner, every side
    cut into ``n`` segments: ``4 n`` nodes a body, body 0's first. Units mm.

    ``pressed``: the nodes strictly inside the other square; ``depth``: their
    distance to its outline (the nearest of its four sides), exact. Radius
    ``max(2 overlap, 1 / n)``.

    Example:
      >>> two_blocks().x.shape
      (80, 2)
    """
    shift = 0.4 / n
    lows = np.array([(0.0, -1.0), (shift, -overlap)])  # lower-left corner of each body
    square = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], np.float64)
    nodes = np.concatenate([_trace(_polygon(low + square), [n] * 4) for low in lows])
    node_body = np.repeat(np.arange(2, dtype=np.int32), 4 * n)
    other = lows[1 - node_body]
    inside = np.minimum(nodes - other, other + 1 - nodes).min(axis=-1)
    segments = np.concatenate([_loop(4 * n), _loop(4 * n, 4 * n)])
    radius = max(2 * overlap, 1 / n)
    return _bodies_scene(nodes, segments, node_body, radius, np.maximum(inside, 0.0), dtype)


def split_quads(quads) -> np.ndarray:
    """i32[2Q, 3]: each quad ``(a, b, c, d)`` of ``quads`` (i[Q, 4]) as the
    triangles ``(a, b, c)`` and ``(a, c, d)``, in the quads' order.

    Both triangles keep the quad's orientation: a quad counter-clockwise
    seen from outside (normal out, as a 3D ``Surface`` wants its triangles)
    gives two such triangles. The diagonal is always ``a-c``: for a quad
    that is not flat, list it from the corner whose diagonal you want.

    Raises:
      ValueError: when ``quads`` is not of shape (Q, 4) with integer entries.

    Example:
      >>> split_quads([[0, 1, 2, 3]]).tolist()
      [[0, 1, 2], [0, 2, 3]]
    """
    quads = np.asarray(quads)
    if quads.ndim != 2 or quads.shape[-1] != 4 or quads.dtype.kind not in "iu":
        raise ValueError(
            f"quads must have shape (Q, 4) and an integer dtype; got shape {quads.shape} "
            f"and dtype {quads.dtype}"
        )
    first, second = quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]
    return np.stack([first, second], axis=1).reshape(-1, 3).astype(np.int32)


def box_surface(low, high, subdivisions: int = 1, *, dtype=jnp.float32) -> Surface:
    """A closed 3D ``Surface``: the box ``[low, high]`` (3 floats each), each
    side cut into ``subdivisions`` x ``subdivisions`` quads, split into
    triangles (``split_quads``) counter-clockwise seen from outside.

    Nodes are shared between sides: ``6 s^2 + 2`` nodes (s = ``subdivisions``)
    and ``12 s^2`` triangles, the sides in the order -x, +x, -y, +y, -z, +z.

    Example:
      >>> box = box_surface((0, 0, 0), (1, 1, 1))
      >>> box.nodes.shape, box.segments.shape
      ((8, 3), (12, 3))
    """
    low, high = np.asarray(low, np.float64), np.asarray(high, np.float64)
    steps = np.arange(subdivisions + 1) / subdivisions
    index: dict[tuple, int] = {}
    nodes, quads = [], []

    def node(point) -> int:
        key = tuple(np.round(point, 12))
        if key not in index:
            index[key] = len(nodes)
            nodes.append(point)
        return index[key]

    for axis in range(3):
        # (u, v) spans the side with u x v along the outward normal.
        for outward in (-1, 1):
            u, v = (axis + 1) % 3, (axis + 2) % 3
            if outward < 0:
                u, v = v, u
            ids = np.empty((subdivisions + 1, subdivisions + 1), int)
            for i, s in enumerate(steps):
                for j, t in enumerate(steps):
                    point = low.copy()
                    point[u] = low[u] + s * (high[u] - low[u])
                    point[v] = low[v] + t * (high[v] - low[v])
                    point[axis] = high[axis] if outward > 0 else low[axis]
                    ids[i, j] = node(point)
            for i in range(subdivisions):
                for j in range(subdivisions):
                    quads.append([ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]])
    triangles = split_quads(np.asarray(quads))
    return Surface(jnp.asarray(np.asarray(nodes), dtype), jnp.asarray(triangles))


# dir() lists the public names (numpy, jnp and the helpers stay out of it).
__dir__ = _listing(__name__)
