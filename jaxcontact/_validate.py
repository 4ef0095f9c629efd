"""``validate``: an eager check of concrete inputs that names the bad rows.

The detectors check shapes and dtypes at trace time, and under ``jit`` they
neutralise bad values silently (a NaN row is not found; a segment with an
out-of-range index is not a segment) because nothing can raise there. That
keeps a long simulation alive, but it also hides a broken mesh. ``validate``
is the loud counterpart, for data at hand: call it once on the first step
(or whenever the data come from outside) and it raises on anything a
detector would drop, naming the rows.
"""

from __future__ import annotations

import warnings

import jax
import numpy as np

from jaxcontact._pipeline import inputs as _inputs
from jaxcontact._pipeline import pairs as _pairs
from jaxcontact._types import Surface

# How many bad row indices a message lists before it only counts them.
_LISTED = 5
# Why a closest-point search with radius 0 is refused (``Search.allocate``) or warned
# about (``validate``).
ZERO_RADIUS = (
    "a radius of 0 finds only the slaves exactly on the master: a penetrating slave lies "
    "|gap| from its segment, so no penetration is found and the body passes through without "
    "a word. Use a radius above the deepest penetration expected in one step (the approach "
    "speed times the time step, plus what the contact lets a node sink)"
)


def _rows(bad: np.ndarray) -> str:
    rows = np.flatnonzero(bad)
    listed = ", ".join(str(int(row)) for row in rows[:_LISTED])
    more = f", ... ({len(rows)} rows in all)" if len(rows) > _LISTED else ""
    return f"rows [{listed}{more}]"


def _concrete(name: str, value):
    if value is not None and any(isinstance(v, jax.core.Tracer) for v in jax.tree.leaves(value)):
        raise ValueError(f"validate needs concrete arrays; {name} is traced (call it outside jit)")


def validate(x, surface: Surface, *, radius=None, mask=None, x_prev=None, pairs=None) -> None:
    """Checks concrete detector inputs eagerly; raises ``ValueError`` naming the bad rows.

    Everything the detectors check at trace time (shapes, dtypes) is checked,
    and also the values they would silently neutralise under ``jit``:
    non-finite coordinates in real (unmasked) slave rows, of ``x`` and of
    ``x_prev``; non-finite nodes used by real segments; real segments'
    indices that are negative or not below the node count; a negative or
    non-finite radius. Masked rows and masked segments are not looked at:
    they may hold anything (a masked segment's indices ``-1``, say).

    A real segment of zero length is legal (the detectors ignore it, as if
    masked), but it is usually a meshing slip: it gives a ``UserWarning``
    naming its rows rather than an error. So do inputs that are legal but
    give wrong answers without a word: a closed loop of real segments listed
    clockwise, whose normals point into it (``_clockwise_loops``); an open
    chain of segments (a floor, a wall) whose normals face away from the
    slaves near it (``reversed_chains``: more of the slaves closest to it
    lie behind it, deeper than ``radius``, than in front of it); a radius
    of 0, which finds no penetrating slave; and float32 coordinates so far
    from the origin that their rounding is not small against ``radius``
    (``_rounding_against_radius``).

    Args:
      x: f[N, 2] slave coordinates.
      surface: the master ``Surface``.
      radius: optional search radius (for ``all_to_all`` and ``bucket_sort``).
      mask: optional bool[N] slave mask, False for padding.
      x_prev: optional f[N, 2] previous positions (for ``swept`` and
        ``bucket_swept``).
      pairs: optional pair rule (``Pairs``), as the detectors take it: the
        open chains' side is judged from the pairs it lets meet (not with
        self-contact or a rule of your own, which the check leaves out).

    Raises:
      ValueError: naming the argument and, for bad values, the first few bad
        row indices and their count; also when an argument is traced.

    Example:
      >>> import numpy as np
      >>> from jaxcontact import Surface, validate
      >>> tool = Surface(np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([[0, 1]]))
      >>> validate(np.array([[0.5, 0.1], [np.nan, 0.0]]), tool, radius=0.1)
      Traceback (most recent call last):
        ...
      ValueError: x has non-finite coordinates in real rows [1]
      >>> validate(np.array([[0.5, 0.1], [np.nan, 0.0]]), tool, mask=np.array([True, False]))
      >>> validate(np.array([[0.5, 0.1]]), tool._replace(segments=np.array([[0, 1], [1, 2]])))
      Traceback (most recent call last):
        ...
      ValueError: surface.segments has indices outside [0, 1] in rows [1]
    """
    for name, value in (("x", x), ("surface", surface), ("radius", radius), ("mask", mask)):
        _concrete(name, value)
    _concrete("x_prev", x_prev)
    _concrete("pairs", pairs)
    x = _inputs.check_points("x", x)
    mask = _inputs.check_mask("mask", mask, x.shape[0])
    if not isinstance(surface, Surface):
        raise ValueError(f"surface must be a jaxcontact.Surface; got {type(surface).__name__}")
    nodes = np.asarray(_inputs.check_points("surface.nodes", surface.nodes, x.dtype))
    segments = np.asarray(_inputs.check_segments(surface.segments))
    seg_mask = _inputs.check_mask("surface.mask", surface.mask, segments.shape[0])
    real_segments = np.ones(len(segments), bool) if seg_mask is None else np.asarray(seg_mask)
    outside = real_segments & np.any((segments < 0) | (segments >= len(nodes)), axis=-1)
    if outside.any():
        raise ValueError(
            f"surface.segments has indices outside [0, {len(nodes) - 1}] in {_rows(outside)}"
        )
    if radius is not None:
        _inputs.check_radius(radius, x.dtype)
    real = np.ones(x.shape[0], bool) if mask is None else np.asarray(mask)
    positions = [("x", np.asarray(x))]
    if x_prev is not None:
        x_prev, _, _ = _inputs.check_path_inputs(x_prev, x, mask)
        positions.insert(0, ("x_prev", np.asarray(x_prev)))
    for name, points in positions:
        bad = real & ~np.all(np.isfinite(points), axis=-1)
        if bad.any():
            raise ValueError(f"{name} has non-finite coordinates in real {_rows(bad)}")
    # Masked segments' indices may lie anywhere: only real ones are read.
    ends = np.zeros(segments.shape + (2,), nodes.dtype)
    ends[real_segments] = nodes[segments[real_segments]]
    bad_ends = real_segments & ~np.all(np.isfinite(ends), axis=(-1, -2))
    if bad_ends.any():
        raise ValueError(
            f"surface.nodes are not finite at the ends of real segments {_rows(bad_ends)}"
        )
    zero_length = real_segments & np.all(ends[:, 0] == ends[:, 1], axis=-1)
    if zero_length.any():
        warnings.warn(
            f"surface.segments {_rows(zero_length)} have zero length; the detectors ignore them",
            UserWarning,
            stacklevel=2,
        )
    for loop in _clockwise_loops(ends, segments, real_segments & ~zero_length):
        listed = np.zeros(len(segments), bool)
        listed[loop] = True
        warnings.warn(
            f"surface.segments {_rows(listed)} form a closed loop listed clockwise: its normals "
            "point into it, so a slave outside it gets a negative gap and one inside a positive "
            "one. List the loop counter-clockwise (reverse each segment and their order), unless "
            "the slaves are meant to be inside it (a container)",
            UserWarning,
            stacklevel=2,
        )
    pairs = _pairs.check(pairs, x, surface._replace(nodes=nodes, segments=segments), mask)
    reversed_open = reversed_chains(
        x, nodes, segments, real_segments, real, body=surface.body, pairs=pairs, radius=radius
    )
    for message in reversed_open:
        warnings.warn(message, UserWarning, stacklevel=2)
    if radius is not None and float(radius) == 0:
        warnings.warn(f"validate: {ZERO_RADIUS}", UserWarning, stacklevel=2)
    if radius is not None and float(radius) > 0:
        used = [np.asarray(x)[real], ends[real_segments].reshape(-1, 2)]
        message = _rounding_against_radius(np.concatenate(used), float(radius))
        if message:
            warnings.warn(message, UserWarning, stacklevel=2)


# ``validate`` warns where the coordinates' rounding exceeds this share of the radius.
ROUNDING_SHARE = 0.01


def _rounding_against_radius(points: np.ndarray, radius: float) -> str | None:
    """A warning's text where the spacing of ``points``' numbers (eps |x|, twice their
    rounding) is over ``ROUNDING_SHARE`` of ``radius``, else None.

    The detectors measure from the nearer end of a segment, so they add only a few ulps of
    the local lengths; what they cannot undo is the rounding of the inputs themselves, eps
    times the coordinates' magnitude. In float32 at 10^4 from the origin that is 1.2e-3,
    10 % of a radius of 0.012: gaps near the radius are that far off, and contacts appear
    and vanish with it.
    """
    if points.size == 0 or not np.issubdtype(points.dtype, np.floating):
        return None
    largest = float(np.max(np.abs(points)))
    rounding = float(np.finfo(points.dtype).eps) * largest
    if rounding <= ROUNDING_SHARE * radius:
        return None
    return (
        f"coordinates reach |x| = {largest:.3g}, where {points.dtype} numbers lie up to "
        f"{rounding:.2g} apart, {100 * rounding / radius:.2g} % of the radius {radius:.3g}: gaps "
        "near the radius are that far off and contacts there may flip. Subtract a local "
        "origin (the tool tip, say) from x and surface.nodes before searching, or use float64"
    )


def _following(segments: np.ndarray, real: np.ndarray) -> dict:
    """Each real segment's successor: the real segment that starts at its end node (the
    lowest index, as the vertex tie rule follows it: ``outline.vertex_neighbours``), as a
    map from a start node to that segment."""
    following = {}
    for k in np.flatnonzero(real)[::-1]:
        following[int(segments[k, 0])] = int(k)
    return following


def _clockwise_loops(ends: np.ndarray, segments: np.ndarray, real: np.ndarray) -> list:
    """The closed loops of ``real`` segments whose signed area is negative (clockwise),
    each as its segment indices.

    A segment is followed by its successor (``_following``); a loop is a chain that comes
    back to where it started. The outward normal is ``(t_y, -t_x)``, to the right of the
    direction of travel, which is outside a counter-clockwise loop.
    """
    return [loop for loop in _loops(segments, real) if _signed_area(ends[loop]) < 0]


def _signed_area(ends: np.ndarray) -> float:
    """The shoelace area of a loop's segments' ``ends`` (f[L, 2, 2]), relative to one
    vertex, so a loop far from the origin stays exact."""
    start, end = ends[:, 0] - ends[0, 0], ends[:, 1] - ends[0, 0]
    return float(np.sum(start[:, 0] * end[:, 1] - end[:, 0] * start[:, 1]) / 2)


def _loops(segments: np.ndarray, real: np.ndarray) -> list:
    """Every closed loop of ``real`` segments, each as its segment indices in order."""
    following = _following(segments, real)
    seen, loops = set(), []
    for first in np.flatnonzero(real):
        path, at, k = [], {}, int(first)
        while k >= 0 and k not in seen and k not in at:
            at[k] = len(path)
            path.append(k)
            k = following.get(int(segments[k, 1]), -1)
        seen.update(path)
        if k >= 0 and k in at:
            loops.append(np.asarray(path[at[k] :]))
    return loops


# ``reversed_chains`` decides an open chain's side from a sample of the real slaves
# (evenly spaced rows): at most SIDE_SAMPLE, fewer on a long master, so that the
# sample times the segments stays near SIDE_PAIRS (NumPy spends 0.1-0.2 us a pair: a
# full 1,024 against the rough die's 10^5 segments took 6 s of a 9.5 s allocate), and
# at least SIDE_SAMPLE_LEAST: a vote of 16 still tells a floor under a body.
SIDE_SAMPLE = 1024
SIDE_SAMPLE_LEAST = 16
SIDE_PAIRS = 1 << 21
# Segments measured against the sampled slaves at once (bounds the check's memory).
_SEGMENT_CHUNK = 512


def reversed_chains(
    x, nodes, segments, real_segments, rows, *, body=None, pairs=None, radius=None
) -> list:
    """The warnings' texts, one per open chain of the master whose normals face away
    from the slaves near it; [] where none does (or where the pair rule is a
    self-contact or a user's own ``allow``, which this check does not apply).

    An open chain is a connected set of real segments (``_following`` links) that holds
    no closed loop: a floor, a wall, a tool's face. Each real slave (a sample of 16
    to ``SIDE_SAMPLE``, fewer on a longer master) is given its closest real segment of
    the whole master, at any distance, among the segments the pair rule lets it meet;
    it counts for that segment's chain where its side of the segment's line is decided:
    always when its closest point lies inside the segment, and past an end only when it
    lies farther across the line than past the end (above a vertex, not beside a free
    end). The
    chain is reported when more of its slaves lie behind it (negative gap) deeper than
    ``radius`` than lie in front of it. The slaves in contact with a master penetrate it
    by less than the radius, or the search would not see them: they never count against
    it, so a body pressed into a floor never fires the check, while a body lying behind
    a floor listed the wrong way does (all but its nodes within the radius count).
    Without a radius every slave behind counts.
    """
    x, nodes, segments = np.asarray(x), np.asarray(nodes), np.asarray(segments)
    pairs = _pairs.given(pairs)
    if pairs.self_contact or pairs.allow is not None:
        return []
    usable = np.array(real_segments, bool)
    usable &= np.all((segments >= 0) & (segments < len(nodes)), axis=-1)
    ends = np.zeros(segments.shape + (2,), nodes.dtype)
    ends[usable] = nodes[segments[usable]]
    usable &= np.all(np.isfinite(ends), axis=(-1, -2)) & np.any(ends[:, 0] != ends[:, 1], -1)
    chain = _chain_labels(segments, usable)
    closed = {int(chain[loop[0]]) for loop in _loops(segments, usable)}
    open_chain = usable & ~np.isin(chain, list(closed))
    if not open_chain.any():
        return []
    sample = np.flatnonzero(np.asarray(rows, bool) & np.all(np.isfinite(x), axis=-1))
    most = int(np.clip(SIDE_PAIRS // max(int(usable.sum()), 1), SIDE_SAMPLE_LEAST, SIDE_SAMPLE))
    if len(sample) > most:
        sample = sample[np.linspace(0, len(sample) - 1, most).round().astype(int)]
    nearest, decided, side = _nearest_sides(x[sample], ends, usable, sample, segments, body, pairs)
    depth = 0.0 if radius is None else float(np.max(radius))
    counted = decided & (nearest >= 0)
    counted[counted] &= open_chain[nearest[counted]]
    labels = chain[nearest[counted]]
    behind = np.bincount(labels[side[counted] < -depth], minlength=len(segments))
    front = np.bincount(labels[side[counted] > 0], minlength=len(segments))
    messages = []
    for label in np.flatnonzero(behind > front):
        listed = chain == label
        messages.append(
            f"surface.segments {_rows(listed)} form an open chain whose normals face away "
            f"from the slaves near it: of the slaves closest to it, {behind[label]} lie behind "
            f"it deeper than the radius and {front[label]} in front of it. Its segments are "
            "listed so that the normals (each segment's direction turned clockwise) point "
            "away from them: a slave on that side gets a negative gap and is reported "
            "penetrating, and one that comes through it is lost. List the chain the other "
            "way: reverse the order of its segments and each segment's node order "
            "(segments[::-1, ::-1] where the chain is the whole master), unless the slaves "
            "are meant to be behind it"
        )
    return messages


def _chain_labels(segments: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """i[M]: one label per connected chain of ``usable`` segments (linked by
    ``_following``), the lowest segment index of the chain; -1 elsewhere."""
    parent = np.arange(len(segments))

    def root(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    following = _following(segments, usable)
    for k in np.flatnonzero(usable):
        after = following.get(int(segments[k, 1]))
        if after is not None:
            low, high = sorted((root(k), root(after)))
            parent[high] = low
    labels = np.array([root(k) for k in range(len(segments))])
    return np.where(usable, labels, -1)


def _nearest_sides(points, ends, usable, rows, segments, body, pairs):
    """For each of ``points`` (its row ``rows`` of x), its closest ``usable`` segment
    that the pair rule lets it meet (-1 for none), whether its side of that segment is
    decided, and its signed distance from the segment's line (negative: behind)."""
    count = len(points)
    best = np.full(count, np.inf)
    nearest = np.full(count, -1)
    decided = np.zeros(count, bool)
    side = np.zeros(count)
    own = None if pairs.slave_node is None else np.asarray(pairs.slave_node)[rows]
    bodies = pairs.slave_body is not None and body is not None
    candidates = np.flatnonzero(usable)
    for first in range(0, len(candidates), _SEGMENT_CHUNK):
        chunk = candidates[first : first + _SEGMENT_CHUNK]
        start, step = ends[chunk, 0], ends[chunk, 1] - ends[chunk, 0]
        rel = points[:, None, :] - start[None]
        along = np.sum(rel * step, -1) / np.sum(step * step, -1)
        off = rel - np.clip(along, 0, 1)[..., None] * step
        distance = np.sum(off * off, -1)
        if own is not None:
            distance[np.any(segments[chunk][None] == own[:, None, None], -1)] = np.inf
        if bodies:
            mine = np.asarray(pairs.slave_body)[rows][:, None] == np.asarray(body)[chunk][None]
            distance[mine] = np.inf
        pick = np.argmin(distance, axis=1)
        closest = distance[np.arange(count), pick]
        better = closest < best
        best[better] = closest[better]
        nearest[better] = chunk[pick[better]]
        length = np.sqrt(np.sum(step * step, -1))[pick]
        t = along[np.arange(count), pick]
        cross = rel[..., 0] * step[..., 1] - rel[..., 1] * step[..., 0]
        signed = cross[np.arange(count), pick] / length
        # Past an end, the side is the line's only where the slave lies more across the
        # line than along it: above a vertex, not beside the chain's free end.
        past = np.maximum(np.maximum(-t, t - 1), 0) * length
        decided[better] = (np.abs(signed) > past)[better]
        side[better] = signed[better]
    return nearest, decided, side
