"""A float64 brute-force oracle for the 3D closest-point query, written from docs/contract.md.

Plain NumPy loops over every (slave, triangle) pair; it shares no code with
the package and takes another road to the closest point than the package's
Voronoi-region tests: the slave is projected onto the triangle's plane and
its barycentric coordinates solved from the 2x2 normal equations; inside the
triangle that is the point, outside it the nearest of the three edges'
clamped projections is. Sign: the face normal on the face's interior, the
angle-weighted pseudo-normal (Baerentzen and Aanaes 2005) of the edge (the
sum of its faces' unit normals) or of the vertex (the sum of its faces' unit
normals weighted by their angles there) otherwise, among the real
triangles only. Triangles are adjacent when they share node indices.

Exact ties are not decided here: ``second`` holds each slave's second-lowest
squared distance over the triangles whose closest point differs from the
chosen one, so a test can tell a clear winner from a near tie.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# A clamped edge parameter this close to 0 or 1, or barycentric coordinates
# this close to the triangle's border, name a vertex or an edge: far below
# any distance a random scene's slaves keep from those features.
FEATURE_SNAP = 1e-12


class OracleContact3D(NamedTuple):
    gap: np.ndarray  # f64[N]
    xi: np.ndarray  # f64[N, 2]  barycentrics of the face's vertices 1 and 2
    segment: np.ndarray  # i64[N]  -1 where not found
    point: np.ndarray  # f64[N, 3]
    normal: np.ndarray  # f64[N, 3]  the face's outward unit normal
    vertex: np.ndarray  # i64[N, 2]  the feature's nodes, ascending, -1 padded
    found: np.ndarray  # bool[N]
    active: np.ndarray  # bool[N]
    distance: np.ndarray  # f64[N]  |x - p| to the chosen face (inf if none is real)
    second: np.ndarray  # f64[N]  the next face's distance, with another closest point


def _unit(v):
    length = np.linalg.norm(v)
    return v / length if length > 0 else np.zeros(3)


def _segment_closest(x, a, b):
    d = b - a
    t = np.clip(np.dot(x - a, d) / np.dot(d, d), 0.0, 1.0)
    return a + t * d, t


def closest_on_triangle(x, a, b, c):
    """``(point, (u, v), feature)``: feature ``("face",)``, ``("edge", i, j)``
    or ``("vertex", i)`` with local corner numbers 0, 1, 2."""
    e1, e2 = b - a, c - a
    gram = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
    u, v = np.linalg.solve(gram, np.array([e1 @ (x - a), e2 @ (x - a)]))
    if u >= 0 and v >= 0 and u + v <= 1:
        return a + u * e1 + v * e2, (u, v), ("face",)
    corners = (a, b, c)
    best = None
    for i, j in ((0, 1), (1, 2), (2, 0)):
        point, t = _segment_closest(x, corners[i], corners[j])
        distance = np.sum((x - point) ** 2)
        if best is None or distance < best[0]:
            best = (distance, point, i, j, t)
    _, point, i, j, t = best
    weights = np.zeros(3)
    weights[i], weights[j] = 1 - t, t
    if t <= FEATURE_SNAP:
        feature = ("vertex", i)
    elif t >= 1 - FEATURE_SNAP:
        feature = ("vertex", j)
    else:
        feature = ("edge", i, j)
    return point, (weights[1], weights[2]), feature


def pseudo_normals(nodes, triangles, real):
    """``(face, edge, vertex)`` normals: f[M, 3], a dict of sorted node pairs, f[P, 3]."""
    face = np.zeros((len(triangles), 3))
    edge: dict[tuple[int, int], np.ndarray] = {}
    vertex = np.zeros((len(nodes), 3))
    for k, corners in enumerate(triangles):
        if not real[k]:
            continue
        a, b, c = (nodes[i] for i in corners)
        face[k] = _unit(np.cross(b - a, c - a))
        for m in range(3):
            i, j, k_ = corners[m], corners[(m + 1) % 3], corners[(m + 2) % 3]
            key = (min(i, j), max(i, j))
            edge[key] = edge.get(key, np.zeros(3)) + face[k]
            u, w = _unit(nodes[j] - nodes[i]), _unit(nodes[k_] - nodes[i])
            angle = np.arctan2(np.linalg.norm(np.cross(u, w)), u @ w)
            vertex[i] += angle * face[k]
    return face, edge, vertex


def oracle_contact_3d(x, nodes, triangles, radius, slave_mask=None, face_mask=None):
    """The 3D closest-point contact of every slave, float64."""
    x = np.asarray(x, np.float64)
    nodes = np.asarray(nodes, np.float64)
    triangles = np.asarray(triangles, np.int64)
    num_rows, num_faces = len(x), len(triangles)
    real = np.ones(num_faces, bool) if face_mask is None else np.asarray(face_mask, bool).copy()
    for k, corners in enumerate(triangles):
        if real[k]:
            a, b, c = (nodes[i] for i in corners)
            real[k] = np.linalg.norm(np.cross(b - a, c - a)) > 0
    face, edge, vertex = pseudo_normals(nodes, triangles, real)
    rows = np.ones(num_rows, bool) if slave_mask is None else np.asarray(slave_mask, bool)
    radius = np.broadcast_to(np.asarray(radius, np.float64), (num_rows,))
    out = OracleContact3D(
        np.zeros(num_rows),
        np.zeros((num_rows, 2)),
        np.full(num_rows, -1),
        np.zeros((num_rows, 3)),
        np.zeros((num_rows, 3)),
        np.full((num_rows, 2), -1),
        np.zeros(num_rows, bool),
        np.zeros(num_rows, bool),
        np.full(num_rows, np.inf),
        np.full(num_rows, np.inf),
    )
    for n in range(num_rows):
        if not rows[n]:
            continue
        candidates = []
        for k in np.flatnonzero(real):
            corners = triangles[k]
            point, weights, feature = closest_on_triangle(x[n], *(nodes[i] for i in corners))
            candidates.append((np.linalg.norm(x[n] - point), k, point, weights, feature))
        if not candidates:
            continue
        candidates.sort(key=lambda item: (item[0], item[1]))
        distance, k, point, weights, feature = candidates[0]
        others = [item[0] for item in candidates[1:] if np.linalg.norm(item[2] - point) > 0]
        out.distance[n], out.second[n] = distance, min(others, default=np.inf)
        offset = x[n] - point
        corners = triangles[k]
        if feature[0] == "face":
            gap, nodes_of = offset @ face[k], (-1, -1)
        else:
            if feature[0] == "edge":
                i, j = sorted((int(corners[feature[1]]), int(corners[feature[2]])))
                pseudo, nodes_of = edge[(i, j)], (i, j)
            else:
                i = int(corners[feature[1]])
                pseudo, nodes_of = vertex[i], (i, -1)
            gap = distance if offset @ pseudo >= 0 else -distance
        if distance > radius[n]:
            continue
        out.gap[n], out.xi[n], out.segment[n] = gap, weights, k
        out.point[n], out.normal[n], out.vertex[n] = point, face[k], nodes_of
        out.found[n], out.active[n] = True, gap < 0
    return out


def winding_number(x, nodes, triangles):
    """f64: the closed surface's winding number around ``x`` (1 inside, 0 outside),
    from the solid angles of its triangles (van Oosterom and Strackee 1983)."""
    total = 0.0
    for corners in triangles:
        a, b, c = (np.asarray(nodes[i], np.float64) - x for i in corners)
        la, lb, lc = np.linalg.norm(a), np.linalg.norm(b), np.linalg.norm(c)
        numerator = a @ np.cross(b, c)
        denominator = la * lb * lc + (a @ b) * lc + (a @ c) * lb + (b @ c) * la
        total += 2 * np.arctan2(numerator, denominator)
    return total / (4 * np.pi)
