"""IPC Toolkit (``ipctk``, its Python bindings) as a peer for both queries.

IPC Toolkit is the collision library of Incremental Potential Contact; its
broad phases find the edge-vertex pairs whose boxes overlap, and its narrow
phase answers distances and continuous collision detection (CCD) one pair at
a time. Read from ``help(ipctk)`` in version 1.6.1:

- ``ipctk.LBVH().build(vertices, edges, faces, inflation_radius)`` builds the
  linear bounding volume hierarchy over every vertex and edge of one mesh
  (static form), or over their boxes swept from ``vertices_t0`` to
  ``vertices_t1`` (continuous form); ``detect_edge_vertex_candidates()``
  returns the overlapping pairs as a Python list of ``EdgeVertexCandidate``
  (``edge_id``, ``vertex_id``), with the pairs of an edge and its own
  vertices left out. The build runs on TBB's threads (``ipctk.get_num_threads``:
  every core allowed unless ``ipctk.set_num_threads`` says otherwise).
- ``ipctk.TightInclusionCCD(tolerance, max_iterations, conservative_rescaling)``
  has ``point_edge_ccd(p_t0, e0_t0, e1_t0, p_t1, e0_t1, e1_t1, min_distance,
  tmax) -> (hit, toi)`` for one pair. There is no call that answers a list of
  pairs at once (``Candidates.compute_collision_free_stepsize`` returns one
  step for the whole mesh, not a time per vertex), so the per-vertex first
  crossing is a Python loop over the candidates.
- There is no closest-edge query per vertex either (the distance functions
  take one pair): ``lbvh_pairs`` returns the candidate pairs, and the
  closest-point peer projects them in NumPy (``baselines.ipctk_lbvh_project``),
  as the KD-tree peers do theirs.

The slaves are the mesh's first N vertices; each segment brings its own two
end points (``start`` then ``end``: shared vertices are not merged, as the
peers receive segments, not a node list), so the broad phase also pairs tool
vertices with neighbouring edges; those pairs are dropped before the narrow
phase. ``ipctk`` is optional: imported inside the functions.
"""

from __future__ import annotations

import numpy as np


def _mesh(num_slaves, start, end):
    """The tool's vertices f64[2M, 2] and its edges i32[M, 2], numbered after the slaves'."""
    count = len(start)
    tool = np.concatenate([start, end]).astype(np.float64)
    edges = num_slaves + np.stack([np.arange(count), count + np.arange(count)], axis=1)
    return tool, np.asfortranarray(edges, np.int32)


def _slave_pairs(broad_phase, num_slaves):
    """``(slave, segment)`` i64[K] of the broad phase's edge-vertex candidates with a slave."""
    candidates = broad_phase.detect_edge_vertex_candidates()
    vertex = np.fromiter((pair.vertex_id for pair in candidates), np.int64, len(candidates))
    edge = np.fromiter((pair.edge_id for pair in candidates), np.int64, len(candidates))
    slave = vertex < num_slaves
    return vertex[slave], edge[slave]


_NO_FACES = np.zeros((0, 3), np.int32, order="F")


def lbvh_pairs(x, start, end, radius):
    """``(slave, segment)`` i64[K]: IPC Toolkit's LBVH pairs of slaves and segments.

    The LBVH is built on every call over the slaves and the segments, every
    box inflated by half the radius: a slave's box and a segment's box then
    overlap where the slave lies in the segment's box inflated by the radius,
    so every segment within the radius of a slave is paired with it. (The
    whole radius gave twice the pairs on the cutting scene, for the same
    answer.)
    """
    import ipctk

    tool, edges = _mesh(len(x), start, end)
    vertices = np.asfortranarray(np.concatenate([x.astype(np.float64), tool]))
    broad_phase = ipctk.LBVH()
    broad_phase.build(vertices, edges, _NO_FACES, float(radius) / 2)
    return _slave_pairs(broad_phase, len(x))


def ipctk_lbvh_ccd(x_prev, x, start, end):
    """``(segment, t, crossed)``: IPC Toolkit's LBVH of swept boxes, then its point-edge CCD.

    The tool does not move (it is the same at ``t0`` and ``t1``). Tight
    Inclusion CCD (tolerance 1e-6, its default) reports the time of impact as
    a lower bound within that tolerance; ``conservative_rescaling=1`` so
    that it is the time itself (IPC's default, 0.8, shortens it for its line
    search). Each slave keeps its smallest time of impact, ties to the lower
    segment index; the candidates are those the broad phase returns, in its
    order, and each CCD call is told to look no later than the best time
    found so far for that slave (``tmax``).
    """
    import ipctk

    tool, edges = _mesh(len(x), start, end)
    vertices_t0 = np.asfortranarray(np.concatenate([x_prev.astype(np.float64), tool]))
    vertices_t1 = np.asfortranarray(np.concatenate([x.astype(np.float64), tool]))
    broad_phase = ipctk.LBVH()
    broad_phase.build(vertices_t0, vertices_t1, edges, _NO_FACES, 0.0)
    slave, pair_segment = _slave_pairs(broad_phase, len(x))
    ccd = ipctk.TightInclusionCCD(conservative_rescaling=1.0)
    segment = np.full(len(x), -1)
    t = np.full(len(x), 2.0)
    count = len(start)
    for vertex, edge in zip(slave.tolist(), pair_segment.tolist(), strict=True):
        a, b = tool[edge], tool[count + edge]
        hit, toi = ccd.point_edge_ccd(
            vertices_t0[vertex], a, b, vertices_t1[vertex], a, b, 0.0, min(t[vertex], 1.0)
        )
        if hit and (toi < t[vertex] or (toi == t[vertex] and edge < segment[vertex])):
            segment[vertex], t[vertex] = edge, toi
    crossed = segment >= 0
    return segment, np.where(crossed, t, 0).astype(x.dtype), crossed
