"""Checking a detector's rows against the exact oracle, within stated float bounds.

Shared by the property tests (tests/core/test_properties.py) and the continuity
tests (tests/core/test_continuity.py), on the suite's one scene type
(``tests.support.helpers.Scene``), without a slave mask.

Error bounds (``ULPS`` = 8 units of eps of the dtype):

- gap and point: ``ULPS * eps * (|x - a| + |b - a|)`` (plus half an ulp of
  the coordinates for the point, its own rounding). ``x - a`` and ``b - a``
  are differences of the inputs, each within eps/2 of exact; the rest is a
  handful of products and sums of numbers no larger than those lengths (a
  dot product, one ratio, one multiply-subtract, a normalisation), each
  adding at most eps/2 of that scale. The coordinates' offset from the
  origin does not enter: the oracle is exact for the same rounded inputs.
- xi: the same over ``|b - a|`` (a ratio of lengths: ill-conditioned on a
  1e-9-long segment, which the bound says).
- gap sign at an end point: the gap there is ``+-|x - p|`` and jumps across
  the line of the face (or faces, at a vertex) that decide its sign; a sign
  other than the oracle's is accepted only where one of those normal
  distances is within the gap bound of zero (the magnitude must still match).
- segment choice: a different segment than the oracle's is accepted only
  where the exact distances of the two differ by at most twice the gap
  bound (both are computed with that error). At a vertex shared by both
  the distances tie exactly in floating point too (both measure from the
  vertex), and the other face is accepted only where the tie rule's keys,
  the two normal distances, are within that bound of each other; the gap
  (sign included) must then match the oracle's either way. ``found`` may
  differ only within the gap bound of the radius.
- crossings: each orientation test is a cross product of two differences,
  computed within ``ULPS * eps`` of the product of their lengths; a decision
  may differ from the oracle's only where such a test is that close to zero,
  or where two segments are met at times within the bound of ``t``:
  ``ULPS * eps * conditioning`` (``oracle.exact_meetings``), which grows as
  the path turns parallel to the segment. Where a path is collinear with the
  chosen segment to within rounding, t itself is unconditioned (along the
  line or across it once): only the point is checked, to lie on the segment.
"""

from __future__ import annotations

import functools
import math

import jax
import numpy as np

from tests.support import oracle
from tests.support.helpers import Scene, assert_all_finite
from tests.support.tolerances import EXACT_ULPS as ULPS


def _unmasked(scene: Scene) -> Scene:
    """``scene`` with its segment mask spelled out; these checks take no slave mask."""
    assert scene.slave_mask is None, "the exact checks take every slave"
    if scene.seg_mask is None:
        scene = scene._replace(seg_mask=np.ones(len(scene.segments), bool))
    return scene


def bound(dtype, scale):
    return ULPS * float(np.finfo(dtype).eps) * scale


# The exact oracle is plain Python over rationals, slow for a thousand rows,
# and several detectors are checked on the same scene: its answers are kept,
# keyed by the scene's bytes.
def _key(*arrays) -> tuple:
    return tuple((a.dtype.str, a.shape, a.tobytes()) for a in map(np.asarray, arrays))


def _arrays(key) -> list[np.ndarray]:
    return [np.frombuffer(data, dtype).reshape(shape) for dtype, shape, data in key]


@functools.lru_cache(maxsize=64)
def _exact_contacts(key, radius):
    x, nodes, segments, seg_mask = _arrays(key)
    expected = oracle.oracle_contact(x, nodes, segments, seg_mask, None, radius)
    pairs = [
        {p.segment: p for p in oracle.exact_pairs(row, nodes, segments, seg_mask)} for row in x
    ]
    return expected, pairs


@functools.lru_cache(maxsize=64)
def _exact_meetings(key):
    x_prev, x, nodes, segments, seg_mask = _arrays(key)
    return [
        {m.segment: m for m in oracle.exact_meetings(start, end, nodes, segments, seg_mask)}
        for start, end in zip(x_prev, x, strict=True)
    ]


def check_contact(contact, scene: Scene, dtype):
    """Every row of ``contact`` against the exact oracle, within the module's bounds."""
    contact = jax.tree.map(np.asarray, contact)  # read row by row: NumPy, not a dispatch each
    scene = _unmasked(scene)
    assert_all_finite(contact)
    assert not bool(contact.overflow)
    expected, every_pairs = _exact_contacts(
        _key(scene.x, scene.nodes, scene.segments, scene.seg_mask), float(scene.radius)
    )
    for row in range(len(scene.x)):
        pairs = every_pairs[row]
        if not pairs:
            assert not contact.found[row]
            continue
        best = min(pairs.values(), key=lambda p: p.distance_squared)
        distance = math.sqrt(float(best.distance_squared))
        found_tol = bound(dtype, best.scale)
        if bool(contact.found[row]) != bool(expected.found[row]):
            assert abs(distance - scene.radius) <= found_tol, (row, distance, scene.radius)
            continue
        if not expected.found[row]:
            assert int(contact.segment[row]) == -1
            continue
        chosen = int(contact.segment[row])
        wanted = int(expected.segment[row])
        want = expected
        if chosen != wanted:
            mine, theirs = pairs[chosen], pairs[wanted]
            gap = abs(math.sqrt(float(mine.distance_squared)) - math.sqrt(
                float(theirs.distance_squared)))  # fmt: skip
            tol = 2 * bound(dtype, max(mine.scale, theirs.scale))
            assert gap <= tol, (row, chosen, wanted, gap, tol)
            # Both measured from the same end point: the distances tie exactly in
            # floating point too, and the tie rule's key, the normal distance,
            # decides unless the two keys are within their rounding.
            if mine.at_end and theirs.at_end and mine.point == theirs.point:
                keys = abs(mine.normal_distance - theirs.normal_distance)
                assert keys <= tol, f"row {row}: vertex tie decided against the tie rule"
            # The chosen face's own values; its gap's sign, at a vertex tie,
            # from the faces that tie with it there (the tie rule's sign).
            only = np.arange(len(scene.segments)) == chosen
            want = oracle.oracle_contact(
                scene.x[row], scene.nodes, scene.segments, only, None, 1e300
            )
            for k, other in pairs.items():
                only[k] |= mine.at_end and other.at_end and other.point == mine.point
            want_gap = oracle.oracle_contact(
                scene.x[row], scene.nodes, scene.segments, only, None, 1e300
            ).gap[0]
            pair, index = mine, 0
        else:
            pair, index, want_gap = pairs[chosen], row, expected.gap[row]
        tol = bound(dtype, pair.scale)
        gap = float(contact.gap[row])
        if pair.at_end and np.sign(gap) != np.sign(want_gap):
            # At an end point the gap is +-|x - p| with the sign of a normal
            # distance, which jumps across the face's line: the sign may go
            # either way only where a deciding normal distance (this face's,
            # or a face tied with it at that vertex) is within rounding of 0.
            deciding = [p for p in pairs.values() if p.at_end and p.point == pair.point]
            assert min(abs(p.normal_distance) for p in deciding) <= tol, (row, "gap sign")
            gap = -gap
        assert abs(gap - want_gap) <= tol, (row, "gap")
        xi_tol = bound(dtype, pair.scale / pair.length)
        assert abs(float(contact.xi[row]) - want.xi[index]) <= xi_tol, (row, "xi")
        assert np.abs(np.asarray(contact.normal[row], np.float64) - want.normal[index]).max() <= (
            bound(dtype, 1.0)
        ), (row, "normal")
        ulp = float(np.max(np.spacing(np.abs(scene.x[row]))))
        point_error = np.abs(np.asarray(contact.point[row], np.float64) - want.point[index]).max()
        assert point_error <= tol + ulp, (row, "point", point_error)


def fragile(meeting: oracle.ExactMeeting, dtype) -> bool:
    """A crossing decision of this pair that rounding may flip."""
    return min(meeting.orientations) <= bound(dtype, 1.0)


def check_crossing(crossing, scene: Scene, dtype):
    """Every row of ``crossing`` against the exact oracle, within the module's bounds."""
    crossing = jax.tree.map(np.asarray, crossing)
    scene = _unmasked(scene)
    assert_all_finite(crossing)
    assert not bool(crossing.overflow)
    every_meetings = _exact_meetings(
        _key(scene.x_prev, scene.x, scene.nodes, scene.segments, scene.seg_mask)
    )
    for row in range(len(scene.x)):
        meetings = every_meetings[row]
        hits = [m for m in meetings.values() if m.t is not None]
        first = min(hits, key=lambda m: (m.t, m.segment)) if hits else None
        chosen = int(crossing.segment[row])
        if not bool(crossing.crossed[row]):
            assert chosen == -1
            # A miss where the oracle hits: only if every hit is fragile.
            assert all(fragile(m, dtype) for m in hits), (row, "missed", first)
            continue
        mine = meetings[chosen]
        if mine.t is None:
            assert fragile(mine, dtype), (row, "crossed a segment it misses", chosen)
            continue
        t = float(crossing.t[row])
        if fragile(mine, dtype):
            # Collinear to within rounding: the path may be taken as running
            # along the segment's line or as crossing it once, so t may be any
            # time the path is on the segment; the point must be on it.
            point = crossing.point[row]
            on = oracle.exact_pairs(point, scene.nodes, scene.segments, scene.seg_mask)
            pair = next(p for p in on if p.segment == chosen)
            travel = float(np.abs(scene.x[row] - scene.x_prev[row]).max())
            tol = bound(dtype, mine.conditioning * travel + 1)
            assert math.sqrt(float(pair.distance_squared)) <= tol, (row, "point off the segment")
            continue
        assert abs(t - float(mine.t)) <= bound(dtype, mine.conditioning), (row, "t")
        if chosen != first.segment:
            # Another segment met first in exact arithmetic: it must be fragile,
            # or met at a time within the bound of this one.
            tol = bound(dtype, mine.conditioning + first.conditioning)
            assert fragile(first, dtype) or float(mine.t - first.t) <= tol, (row, chosen, first)
        start, end = (np.asarray(v[row], np.float64) for v in (scene.x_prev, scene.x))
        point = start + float(mine.t) * (end - start)
        ulp = float(np.max(np.spacing(np.abs(scene.x[row]))))
        tol = bound(dtype, mine.conditioning) * float(np.abs(end - start).max()) + 2 * ulp
        assert np.abs(np.asarray(crossing.point[row], np.float64) - point).max() <= tol
