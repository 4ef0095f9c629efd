"""The float64 reference every benchmark checks its answers against.

A NumPy brute force in float64: the closest segment of non-zero length and,
of segments at exactly equal float64 distance (any of them, whether or not
they share a vertex), the one with the larger signed normal distance
``(x - p) . n``, then the lower index. The gap is ``+-|x - p|`` with the sign
of the chosen segment's ``(x - p) . n`` (zero counts as positive).

That is the library's vertex-tie rule at a convex corner only
(docs/contract.md, "Ties"). The library gives a tie at a concave corner to
the smaller normal distance, with the gap's sign from exact sign tests
(inside when inside either face), and a tie away from a shared vertex, or
between segments that do not share the node index, to the lower index. Where
the two differ the segments are at the same distance, so ``compare`` counts
the library's answer as a tie, not an error: on the rough die, whose troughs
are concave corners, the library's own rows show such ties.

Slaves are taken in chunks sorted by x, and each chunk is projected only on
the segments whose box comes within the radius of the chunk's box, so the
rough die at 10^6 x 10^5 stays affordable while every pair that could matter
is still evaluated exactly as the dense brute force would.

The inputs are converted to float64 as given: the reference of a float32
scene is the float64 answer for the very same float32 numbers.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Reference(NamedTuple):
    """The float64 answer, one row per slave."""

    segment: np.ndarray  # i64[N], -1 where not found
    gap: np.ndarray  # f64[N], signed; 0 where not found
    found: np.ndarray  # bool[N]


class Mismatch(NamedTuple):
    """How one method's answer differs from the reference."""

    missed: int  # found by the reference, not by the method
    false: int  # found by the method, not by the reference
    ties: int  # both found, another segment at exactly the reference's distance
    wrong_segment: int  # both found, another segment that is farther: a real error
    max_gap_error: float  # largest |gap - reference gap| where both found (ties: that segment's)
    wrong_by: float  # how much farther the farthest wrong segment is than the closest (0: none)


def _project(x, start, end):
    """f64 ``(distance_squared, signed_normal)`` of slaves on segments, broadcast over ``...``.

    ``x``, ``start`` and ``end`` are ``(..., 2)``: pass ``x[:, None]`` with
    ``start[None]`` for every pair, or rows of equal length for one pair each.
    """
    direction = end - start
    from_start = x - start
    xi = np.sum(from_start * direction, axis=-1) / np.sum(direction * direction, axis=-1)
    # The end points themselves where clamped, not start + 1 * direction, so a
    # vertex shared by two segments is the same point seen from both: its tie is exact.
    point = np.where(
        (xi <= 0)[..., None],
        start,
        np.where((xi >= 1)[..., None], end, start + xi[..., None] * direction),
    )
    offset = x - point
    normal = np.stack([direction[..., 1], -direction[..., 0]], axis=-1)
    normal = normal / np.linalg.norm(direction, axis=-1, keepdims=True)
    return np.sum(offset * offset, axis=-1), np.sum(offset * normal, axis=-1)


def _endpoints(x, start, end):
    x, start, end = (np.asarray(a, np.float64).reshape(-1, 2) for a in (x, start, end))
    real = np.any(start != end, axis=1)  # zero-length segments are ignored (docs/contract.md)
    return x, start, end, real


def reference_contact(x, start, end, radius, *, chunk: int = 2048) -> Reference:
    """The closest segment of every slave within ``radius``, in float64.

    Args:
      x: f[N, 2] slaves (any float dtype; converted to float64).
      start: f[M, 2] segment starts.
      end: f[M, 2] segment ends.
      radius: the search radius.
      chunk: slaves projected together.

    Returns:
      A ``Reference``.

    Example:
      >>> import numpy as np
      >>> ref = reference_contact([[0.5, -0.1], [5.0, 5.0]], [[0.0, 0.0]], [[1.0, 0.0]], 0.2)
      >>> ref.segment.tolist(), np.round(ref.gap, 6).tolist(), ref.found.tolist()
      ([0, -1], [0.1, 0.0], [True, False])
    """
    x, start, end, real = _endpoints(x, start, end)
    count = len(x)
    segment = np.full(count, -1, np.int64)
    gap = np.zeros(count)
    low = np.minimum(start, end) - radius
    high = np.maximum(start, end) + radius
    order = np.argsort(x[:, 0], kind="stable")
    for first in range(0, count, chunk):
        rows = order[first : first + chunk]
        box_low, box_high = x[rows].min(axis=0), x[rows].max(axis=0)
        near = np.flatnonzero(real & np.all((high >= box_low) & (low <= box_high), axis=1))
        if near.size == 0:
            continue
        distance_squared, normal = _project(x[rows, None], start[near][None], end[near][None])
        nearest = distance_squared.min(axis=1, keepdims=True)
        # Of exactly equal distances (at a vertex or not, convex or concave), the
        # larger signed normal distance, then the lower index (argmax returns the
        # first of equal maxima; near is ascending).
        best = np.argmax(np.where(distance_squared == nearest, normal, -np.inf), axis=1)
        within = nearest[:, 0] <= radius * radius
        taken = np.arange(len(rows))
        distance = np.sqrt(nearest[:, 0])
        signed = np.where(normal[taken, best] < 0, -distance, distance)
        segment[rows[within]] = near[best[within]]
        gap[rows[within]] = signed[within]
    return Reference(segment, gap, segment >= 0)


def evaluate(x, start, end, segment):
    """f64 ``(distance, gap)`` of each slave on its given segment (zeros where ``-1``).

    Example:
      >>> distance, gap = evaluate([[0.5, 0.25]], [[0.0, 0.0]], [[1.0, 0.0]], [0])
      >>> distance.tolist(), gap.tolist()
      ([0.25], [-0.25])
    """
    x, start, end, _ = _endpoints(x, start, end)
    segment = np.asarray(segment)
    chosen = np.maximum(segment, 0)
    distance_squared, normal = _project(x, start[chosen], end[chosen])
    distance = np.where(segment >= 0, np.sqrt(distance_squared), 0.0)
    return distance, np.where(normal < 0, -distance, distance)


def compare(segment, gap, found, x, start, end, reference: Reference) -> Mismatch:
    """Counts how ``(segment, gap, found)`` differs from ``reference`` on the same scene.

    A segment other than the reference's at exactly the reference's float64
    distance is a tie (a shared vertex, or two segments equally near: a peer
    may pick either, and at a concave corner the library's rule picks the
    face this reference does not); its gap is compared with that segment's
    own, signed by its own ``(x - p) . n``.

    Example:
      >>> x, start, end = [[0.5, -0.1]], [[0.0, 0.0]], [[1.0, 0.0]]
      >>> ref = reference_contact(x, start, end, 0.2)
      >>> compare([-1], [0.0], [False], x, start, end, ref).missed
      1
    """
    segment, found = np.asarray(segment), np.asarray(found, bool)
    gap = np.asarray(gap, np.float64)
    segment = np.where(found, segment, -1)
    both = found & reference.found
    other = both & (segment != reference.segment)
    distance, own_gap = evaluate(x, start, end, segment)
    reference_distance = np.abs(reference.gap)
    ties = other & (distance == reference_distance)
    expected = np.where(ties, own_gap, reference.gap)
    errors = np.abs(gap - expected)[both & ~(other & ~ties)]
    # Wrong segments by float32 rounding are farther by about an ulp of the coordinates.
    excess = (distance - reference_distance)[other & ~ties]
    return Mismatch(
        missed=int(np.sum(reference.found & ~found)),
        false=int(np.sum(found & ~reference.found)),
        ties=int(ties.sum()),
        wrong_segment=int(np.sum(other & ~ties)),
        max_gap_error=float(errors.max()) if errors.size else 0.0,
        wrong_by=float(excess.max()) if excess.size else 0.0,
    )


def describe(mismatch: Mismatch) -> str:
    """One short line: ``"exact"`` or the counts that are not zero."""
    wrong = f"wrong segment (up to {mismatch.wrong_by:.2g} farther)"
    parts = [
        f"{count:,} {label}"
        for count, label in (
            (mismatch.missed, "missed"),
            (mismatch.false, "false"),
            (mismatch.wrong_segment, wrong),
            (mismatch.ties, "ties"),
        )
        if count
    ]
    return ", ".join(parts) if parts else "same contacts"
