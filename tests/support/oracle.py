"""A brute-force oracle, written from docs/contract.md alone, returning float64 NumPy arrays.

Plain loops over every (slave, segment) pair, one textbook formula each; it
shares no code with the package. Every input float is an exact rational, and
the oracle computes in exact rational arithmetic (``fractions.Fraction``):
closest points, squared distances, crossing times, and so every comparison
(which segment is nearest, which crossing is first, whether a distance is
within the radius, whether a path touches an end point) is decided exactly,
ties included. Values are rounded to float64 once, at the end (a square root
and a division by a length are the only other roundings). So the oracle of a
float32 scene is the float64 answer for the very same float32 numbers, and no
rounding of the oracle's own can decide a tie or a boundary case.

The pair rule (several bodies, self-contact): a slave pairs only with its
*allowed* real segments, and the closest segment, the ``found`` test, the
vertex tie's rival and the first crossing are all taken among those alone.
A segment is not allowed for slave ``i`` when

- (a) it starts or ends at the slave's own node ``slave_node[i]`` (where that
  index is in ``[0, P)``);
- (b) without ``self_contact``, and with labels on both sides, it belongs to
  the slave's own body (``body[k] == slave_body[i]``);
- (c) with ``self_contact``, it lies within the slave's neighbourhood along
  the outline: on the chain of ``slave_node[i]`` at an arc distance below
  ``window_i`` (``4 * radius_i`` for contact, four times the path's length
  for crossings). Body labels exclude nothing then.

Chains follow real segments end to start (``oracle_chains``); arc lengths are
float64 sums of float64 segment lengths, the one place where the oracle is
not exact: they only decide which pairs are allowed, so a test should keep
arc distances clear of the window.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import NamedTuple

import numpy as np


class OracleContact(NamedTuple):
    gap: np.ndarray  # f64[N]
    xi: np.ndarray  # f64[N]
    segment: np.ndarray  # i64[N], -1 where not found
    point: np.ndarray  # f64[N, 2]
    normal: np.ndarray  # f64[N, 2]
    vertex: np.ndarray  # i64[N], the master node at an end-point closest point, else -1
    found: np.ndarray  # bool[N]
    active: np.ndarray  # bool[N]


class OracleCrossing(NamedTuple):
    t: np.ndarray  # f64[N]
    segment: np.ndarray  # i64[N], -1 where none
    point: np.ndarray  # f64[N, 2]
    crossed: np.ndarray  # bool[N]


def _exact(row) -> tuple[Fraction, Fraction]:
    """One (2,) float row as an exact rational pair."""
    u, v = np.asarray(row).reshape(2)
    return Fraction(float(u)), Fraction(float(v))


def _rows(points) -> np.ndarray:
    return np.asarray(points).reshape(-1, 2)


def _sub(p, q):
    return (p[0] - q[0], p[1] - q[1])


def _add_scaled(p, s, v):
    return (p[0] + s * v[0], p[1] + s * v[1])


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1]


def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _floats(p) -> list[float]:
    return [float(p[0]), float(p[1])]


def _is_on(mask, row) -> bool:
    return mask is None or bool(np.asarray(mask)[row])


def _real_segments(nodes, segments, seg_mask):
    """``(k, a, b)`` for every real segment, in index order.

    Real: kept by the mask, both indices in ``[0, P)``, both nodes finite, and
    of non-zero length; any other segment is ignored as if masked out.
    """
    segments = np.asarray(segments).reshape(-1, 2)
    nodes = np.asarray(nodes).reshape(-1, 2)
    real = []
    for k, (i, j) in enumerate(segments):
        if not _is_on(seg_mask, k):
            continue  # masked: its nodes may be padding (NaN, inf), never read
        if not (0 <= int(i) < len(nodes) and 0 <= int(j) < len(nodes)):
            continue
        if not (np.all(np.isfinite(nodes[int(i)])) and np.all(np.isfinite(nodes[int(j)]))):
            continue
        a, b = _exact(nodes[int(i)]), _exact(nodes[int(j)])
        if a != b:  # zero length: ignored as if masked out
            real.append((k, a, b))
    return real


# Chains along the outlines and the pair rule.


class OracleChains(NamedTuple):
    """Arc-length coordinates along the chains of real segments.

    Segment ``j`` follows ``k`` when it is the lowest-index real segment other
    than ``k`` that starts at ``k``'s end node. An open chain starts at a
    segment that no real segment leads into; a closed loop starts at its
    lowest index. ``s`` is 0 at the chain's first start node and grows by each
    segment's length along it. A chain is named by its first segment's index.
    """

    real: np.ndarray  # bool[M]
    chain: np.ndarray  # i64[M], -1 where not real
    s_start: np.ndarray  # f64[M], s at the segment's start node (NaN where not real)
    s_end: np.ndarray  # f64[M], s at its end node (s_start + its length)
    loop: np.ndarray  # f64[M], the chain's length for a closed loop, inf for an open chain
    node_chain: np.ndarray  # i64[P], chain of each node, -1 on no real segment
    node_s: np.ndarray  # f64[P], s of each node (NaN on no real segment)


def oracle_chains(nodes, segments, seg_mask=None) -> OracleChains:
    """The chains of real segments, by walking them one link at a time.

    Written for simple outlines (each node starts at most one real segment
    and ends at most one). Elsewhere (branches) it is still deterministic:
    chains are walked from their first segments in index order, then the
    loops, and a walk stops at a segment an earlier walk took.

    A node's ``s`` is that of the lowest-index real segment starting at it,
    else of the lowest-index one ending at it (so a loop's first node is 0,
    not the loop's length: ``arc_distance`` wraps around).
    """
    segments = np.asarray(segments).reshape(-1, 2)
    num_nodes = len(np.asarray(nodes).reshape(-1, 2))
    real = _real_segments(nodes, segments, seg_mask)
    start = {k: int(segments[k, 0]) for k, _, _ in real}
    end = {k: int(segments[k, 1]) for k, _, _ in real}
    length = {k: math.sqrt(float(_dot(_sub(b, a), _sub(b, a)))) for k, a, b in real}

    # Per node, the real segments starting (ending) there, in index order.
    starting, ending = {}, {}
    for k in start:
        starting.setdefault(start[k], []).append(k)
        ending.setdefault(end[k], []).append(k)

    def successor(k):
        following = [j for j in starting.get(end[k], []) if j != k]
        return following[0] if following else None

    def has_predecessor(k):
        return any(j != k for j in ending.get(start[k], []))

    count = len(segments)
    result = OracleChains(
        real=np.zeros(count, bool),
        chain=np.full(count, -1, np.int64),
        s_start=np.full(count, np.nan),
        s_end=np.full(count, np.nan),
        loop=np.full(count, np.nan),
        node_chain=np.full(num_nodes, -1, np.int64),
        node_s=np.full(num_nodes, np.nan),
    )
    heads = [k for k in start if not has_predecessor(k)]
    for first in heads + list(start):  # open chains first, then the loops
        if result.real[first]:
            continue  # already on a chain
        members, taken = [first], {first}
        following = successor(first)
        while following is not None and not result.real[following] and following not in taken:
            members.append(following)
            taken.add(following)
            following = successor(following)
        closed = following == first
        s = 0.0
        for k in members:
            result.real[k], result.chain[k] = True, first
            result.s_start[k] = s
            s += length[k]
            result.s_end[k] = s
        result.loop[members] = s if closed else np.inf
    # Node coordinates: from the lowest-index segment starting there, else ending there.
    for k in sorted(start, reverse=True):
        result.node_chain[end[k]], result.node_s[end[k]] = result.chain[k], result.s_end[k]
    for k in sorted(start, reverse=True):
        result.node_chain[start[k]], result.node_s[start[k]] = result.chain[k], result.s_start[k]
    return result


def arc_distance(s, s_start, s_end, loop) -> float:
    """Arc distance from the point ``s`` of a chain to the segment ``[s_start, s_end]`` on it.

    0 inside the interval; otherwise the shorter way to it: straight on an
    open chain (``loop`` inf), either way round a closed loop of length ``loop``.
    """
    if s_start <= s <= s_end:
        return 0.0
    if math.isinf(loop):
        return max(s_start - s, s - s_end)
    ahead = (s_start - s) % loop  # from the point forward to the segment's start
    behind = (s - s_end) % loop  # from the segment's end forward to the point
    return min(ahead, behind)


class _PairRule:
    """Which real segments each slave may pair with (see the module docstring)."""

    def __init__(self, nodes, segments, seg_mask, body, slave_node, slave_body, self_contact):
        self.segments = np.asarray(segments).reshape(-1, 2)
        self.num_nodes = len(np.asarray(nodes).reshape(-1, 2))
        self.real = [k for k, _, _ in _real_segments(nodes, segments, seg_mask)]
        self.body = None if body is None else np.asarray(body).reshape(-1)
        self.slave_node = None if slave_node is None else np.asarray(slave_node).reshape(-1)
        self.slave_body = None if slave_body is None else np.asarray(slave_body).reshape(-1)
        self.self_contact = bool(self_contact)
        self.places = {}
        if not self.self_contact:
            return  # no chains needed
        self.chains = oracle_chains(nodes, segments, seg_mask)
        # Where each node sits along the chains: (chain, s) at every real segment end there.
        for k in self.real:
            for node, s in (
                (self.segments[k, 0], self.chains.s_start[k]),
                (self.segments[k, 1], self.chains.s_end[k]),
            ):
                self.places.setdefault(int(node), []).append((self.chains.chain[k], s))

    def _own_node(self, i):
        """The slave's master node index, or None (none given, or out of range)."""
        if self.slave_node is None:
            return None
        node = int(self.slave_node[i])
        return node if 0 <= node < self.num_nodes else None

    def _near_along_outline(self, node, k, window) -> bool:
        """Segment ``k`` lies within ``window`` of ``node`` along ``node``'s chain.

        The node's places are the ends of the real segments at it (one chain,
        and one ``s`` but for a loop's first node, on a simple outline); ``k``
        is near if it is near any of them. A node on no real segment has none.
        """
        chains = self.chains
        for chain, s in self.places.get(node, []):
            if chain != chains.chain[k]:
                continue
            if arc_distance(s, chains.s_start[k], chains.s_end[k], chains.loop[k]) < window:
                return True
        return False

    def allowed(self, i, window) -> set[int]:
        """The real segments slave ``i`` may pair with; ``window`` is its rule (c) window."""
        node = self._own_node(i)
        allowed = set()
        for k in self.real:
            if node is not None and node in (int(self.segments[k, 0]), int(self.segments[k, 1])):
                continue  # (a) the slave's own segments
            if self.self_contact:
                if node is not None and self._near_along_outline(node, k, window):
                    continue  # (c) its neighbourhood along the outline
            elif self.body is not None and self.slave_body is not None:
                if int(self.body[k]) == int(self.slave_body[i]):
                    continue  # (b) its own body
            allowed.add(k)
        return allowed


def oracle_allowed(
    nodes,
    segments,
    seg_mask=None,
    window=0.0,
    *,
    body=None,
    slave_node=None,
    slave_body=None,
    self_contact=False,
    count=None,
) -> np.ndarray:
    """bool[N, M]: the pair rule's table, True where slave ``i`` may pair with segment ``k``.

    ``window`` is rule (c)'s window per slave (a scalar or f[N]); ``N`` is
    ``count`` if given, else the length of whichever of ``window``,
    ``slave_node``, ``slave_body`` is an array. Segments that are not real are
    never allowed.
    """
    if count is None:
        sizes = [np.size(a) for a in (window, slave_node, slave_body) if np.ndim(a) > 0]
        count = sizes[0] if sizes else 1
    windows = np.broadcast_to(np.asarray(window, np.float64), (count,))
    rule = _PairRule(nodes, segments, seg_mask, body, slave_node, slave_body, self_contact)
    table = np.zeros((count, len(rule.segments)), bool)
    for i in range(count):
        table[i, sorted(rule.allowed(i, float(windows[i])))] = True
    return table


def closest_point(x, a, b):
    """``(distance_squared, xi_free, xi, point)`` of segment ``a -> b`` for slave ``x``, exact."""
    d = _sub(b, a)
    xi_free = _dot(_sub(x, a), d) / _dot(d, d)
    xi = min(max(xi_free, Fraction(0)), Fraction(1))
    point = _add_scaled(a, xi, d)
    offset = _sub(x, point)
    return _dot(offset, offset), xi_free, xi, point


def _prefer_outside(slave, nearest, candidates, ends):
    """The README's tie rule (where it departs from the first contract): ``(chosen, sign)``.

    Where the nearest segment's closest point is its start (end) node, the
    lowest-index real segment that ends (starts) at that same node index ties
    with it. At a convex corner (``d_in x d_out >= 0``) the one with the
    larger signed normal distance (x - p) . n is taken, at a concave one the
    smaller, if strictly so; compared exactly through s |s| / |d|^2 of
    s = (x - p) . n |d|. Only neighbours sharing the node index count.
    ``sign`` is the gap's sign at such a tie (+-1): negative when the slave
    is inside either face at a concave corner, inside both at a convex one
    (zero counts as outside); None without a tie.
    """
    (k, _, _), (_, xi_free, _, _) = nearest
    if 0 < xi_free < 1:
        return nearest, None
    at_end = xi_free >= 1
    node = ends[k][1] if at_end else ends[k][0]
    rivals = [c for c in candidates if c[0][0] != k and ends[c[0][0]][0 if at_end else 1] == node]
    if not rivals:
        return nearest, None
    rival = rivals[0]

    def direction(candidate):
        (_, a, b), _ = candidate
        return _sub(b, a)

    def side(candidate):
        (_, a, b), (_, _, _, point) = candidate
        return _cross(_sub(slave, point), _sub(b, a))

    def key(candidate):
        d = direction(candidate)
        return side(candidate) * abs(side(candidate)) / _dot(d, d)

    incoming, outgoing = (nearest, rival) if at_end else (rival, nearest)
    convex = _cross(direction(incoming), direction(outgoing)) >= 0
    better = key(rival) > key(nearest) if convex else key(rival) < key(nearest)
    sides = side(nearest), side(rival)
    inside = max(sides) < 0 if convex else min(sides) < 0
    return (rival if better else nearest), (-1 if inside else 1)


def oracle_contact(
    x,
    nodes,
    segments,
    seg_mask=None,
    slave_mask=None,
    radius=0.0,
    *,
    body=None,
    slave_node=None,
    slave_body=None,
    self_contact=False,
) -> OracleContact:
    """The ``Contact`` docs/contract.md describes, by looping over every pair.

    ``radius`` is a scalar or one per slave (f[N]); the pair rule's window is
    ``4 * radius`` per slave.
    """
    slaves = _rows(x)
    count = len(slaves)
    result = OracleContact(
        gap=np.zeros(count),
        xi=np.zeros(count),
        segment=np.full(count, -1, np.int64),
        point=np.zeros((count, 2)),
        normal=np.zeros((count, 2)),
        vertex=np.full(count, -1, np.int64),
        found=np.zeros(count, bool),
        active=np.zeros(count, bool),
    )
    segments = np.asarray(segments).reshape(-1, 2)
    real = _real_segments(nodes, segments, seg_mask)
    rule = _PairRule(nodes, segments, seg_mask, body, slave_node, slave_body, self_contact)
    radii = np.broadcast_to(np.asarray(radius), (count,))
    for i, row in enumerate(slaves):
        if not _is_on(slave_mask, i):
            continue  # masked: the row may be padding (NaN, inf), never read
        radius_i = float(radii[i])
        allowed = rule.allowed(i, 4.0 * radius_i)
        mine = [segment for segment in real if segment[0] in allowed]
        if not mine:
            continue
        slave = _exact(row)

        candidates = [(segment, closest_point(slave, *segment[1:])) for segment in mine]
        # Nearest; of exactly equal distances the lower index (min keeps the
        # first), then the README's vertex-tie rule (rivals among the allowed).
        nearest = min(candidates, key=lambda candidate: candidate[1][0])
        ((k, a, b), (distance_squared, xi_free, xi, point)), tie_sign = _prefer_outside(
            slave, nearest, candidates, segments
        )
        if distance_squared > Fraction(radius_i) ** 2:
            continue
        d = _sub(b, a)
        length = math.sqrt(float(_dot(d, d)))
        # (x - p) . n times |b - a|, exactly; n = (d_y, -d_x) / |b - a|.
        normal_offset = _cross(_sub(slave, point), d)
        if 0 < xi_free < 1:
            gap = float(normal_offset) / length
        elif tie_sign is not None:
            gap = math.copysign(math.sqrt(float(distance_squared)), tie_sign)
        else:
            # Magnitude |x - p|, sign of (x - p) . n; zero counts as positive.
            gap = math.copysign(math.sqrt(float(distance_squared)), -1 if normal_offset < 0 else 1)
        result.gap[i], result.xi[i], result.segment[i] = gap, float(xi), k
        result.point[i] = _floats(point)
        result.normal[i] = [float(d[1]) / length, -float(d[0]) / length]
        if xi_free <= 0:
            result.vertex[i] = int(segments[k, 0])
        elif xi_free >= 1:
            result.vertex[i] = int(segments[k, 1])
        result.found[i], result.active[i] = True, gap < 0
    return result


def first_meeting(p0, p1, a, b):
    """The smallest ``t`` in [0, 1] with ``p0 + t (p1 - p0)`` on ``a -> b`` (exact), or None."""
    u, d, w = _sub(p1, p0), _sub(b, a), _sub(a, p0)
    denominator = _cross(u, d)
    if denominator != 0:
        # p0 + t u = a + s d, solved by Cramer's rule.
        t = _cross(w, d) / denominator
        s = _cross(w, u) / denominator
        return t if (0 <= t <= 1 and 0 <= s <= 1) else None
    if _cross(d, _sub(p0, a)) != 0:
        return None  # parallel (or not moving) and off the segment's line
    # On the segment's line: s(t) = s0 + t (s1 - s0) must reach [0, 1].
    length_squared = _dot(d, d)
    s0 = _dot(_sub(p0, a), d) / length_squared
    s1 = _dot(_sub(p1, a), d) / length_squared
    if 0 <= s0 <= 1:
        return Fraction(0)
    if s1 == s0:
        return None
    t = ((0 if s0 < 0 else 1) - s0) / (s1 - s0)
    return t if 0 <= t <= 1 else None


def oracle_crossing(
    x_prev,
    x,
    nodes,
    segments,
    seg_mask=None,
    slave_mask=None,
    *,
    body=None,
    slave_node=None,
    slave_body=None,
    self_contact=False,
) -> OracleCrossing:
    """The ``Crossing`` docs/contract.md describes, by looping over every pair.

    The pair rule's window is four times the path's length ``|x - x_prev|``.
    """
    starts, ends = _rows(x_prev), _rows(x)
    count = len(ends)
    result = OracleCrossing(
        t=np.zeros(count),
        segment=np.full(count, -1, np.int64),
        point=np.zeros((count, 2)),
        crossed=np.zeros(count, bool),
    )
    real = _real_segments(nodes, segments, seg_mask)
    rule = _PairRule(nodes, segments, seg_mask, body, slave_node, slave_body, self_contact)
    for i in range(count):
        if not _is_on(slave_mask, i):
            continue  # masked: the rows may be padding (NaN, inf), never read
        start, end = _exact(starts[i]), _exact(ends[i])
        path = _sub(end, start)
        allowed = rule.allowed(i, 4.0 * math.sqrt(float(_dot(path, path))))
        meetings = [(first_meeting(start, end, a, b), k) for k, a, b in real if k in allowed]
        meetings = [(t, k) for t, k in meetings if t is not None]
        if not meetings:
            continue
        t, k = min(meetings)  # earliest; of equal times, the lower index
        result.t[i], result.segment[i], result.crossed[i] = float(t), k, True
        result.point[i] = _floats(_add_scaled(start, t, path))
    return result


# Per-pair exact quantities for the property tests (tests/core/test_properties.py),
# which need more than the winner: how far every other segment is, and how
# close each decision was to going the other way.


class ExactPair(NamedTuple):
    """One (slave, real segment) pair in exact arithmetic."""

    segment: int
    distance_squared: Fraction  # |x - p|^2
    point: tuple[Fraction, Fraction]  # the closest point p
    scale: float  # |x - a| + |b - a|: the size the float error scales with
    length: float  # |b - a|
    at_end: bool  # p is an end point of the segment
    normal_distance: float  # (x - p) . n, the vertex-tie key


def exact_pairs(x_row, nodes, segments, seg_mask=None) -> list[ExactPair]:
    """Every real segment's exact closest point to the slave ``x_row`` (f[2])."""
    slave = _exact(x_row)
    pairs = []
    for k, a, b in _real_segments(nodes, segments, seg_mask):
        distance_squared, _, xi, point = closest_point(slave, a, b)
        d, from_a = _sub(b, a), _sub(slave, a)
        length = math.sqrt(float(_dot(d, d)))
        scale = math.sqrt(float(_dot(from_a, from_a))) + length
        side = float(_cross(_sub(slave, point), d)) / length
        pairs.append(ExactPair(k, distance_squared, point, scale, length, xi in (0, 1), side))
    return pairs


class ExactMeeting(NamedTuple):
    """One (path, real segment) pair in exact arithmetic."""

    segment: int
    t: Fraction | None  # first meeting time, None if the path misses the segment
    orientations: tuple[float, ...]  # the four orientation tests, each over its bound scale
    conditioning: float  # d t / d (orientation): the scale of t's rounding error


def exact_meetings(start_row, end_row, nodes, segments, seg_mask=None) -> list[ExactMeeting]:
    """Every real segment's exact meeting with the path ``start_row -> end_row``.

    ``orientations`` are the cross products the crossing decision is made of
    (the path's ends against the segment's line, the segment's ends against
    the path's line), each divided by the product of the lengths it is made
    from: in floating point each is computed with an error of a few ulps of
    that product, so a ratio within a few eps of zero may take either sign.
    """
    start, end = _exact(start_row), _exact(end_row)
    u = _sub(end, start)
    length_u = math.sqrt(float(_dot(u, u)))
    meetings = []
    for k, a, b in _real_segments(nodes, segments, seg_mask):
        d = _sub(b, a)
        length_d = math.sqrt(float(_dot(d, d)))

        def norm(v):
            return math.sqrt(float(_dot(v, v)))

        def ratio(value, scale):
            return abs(float(value)) / scale if scale > 0 else math.inf

        from_start, from_end = _sub(start, a), _sub(end, a)
        orientations = (
            ratio(_cross(d, from_start), length_d * norm(from_start)),
            ratio(_cross(d, from_end), length_d * norm(from_end)),
            ratio(_cross(u, _sub(a, start)), length_u * norm(_sub(a, start))),
            ratio(_cross(u, _sub(b, start)), length_u * norm(_sub(b, start))),
        )
        # t is a ratio of orientations (crossing the line) or of projections
        # on the path (through an end point, along the line): its error is a
        # few eps times these conditionings.
        turn = abs(float(_cross(u, d)))
        reach = norm(from_start) + norm(from_end) + length_d
        conditioning = length_d * reach / turn if turn else 0.0
        conditioning += reach / length_u if length_u else 0.0
        meeting = first_meeting(start, end, a, b)
        meetings.append(ExactMeeting(k, meeting, orientations, conditioning))
    return meetings
