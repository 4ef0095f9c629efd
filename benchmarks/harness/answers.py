"""How a method's closest-point answer differs from a reference answer on the same scene.

The reference is ``jaxcontact.all_to_all`` in float64 on the scene's very
numbers (the reference of a float32 scene is the float64 answer for the same
float32 numbers), with the library's own tie rules (docs/contract.md,
"Ties"); the test suite's exact oracle (``tests/support/oracle.py``) is what checks
``all_to_all`` itself. ``compare`` counts a segment other than the
reference's, at exactly the reference's float64 distance, as a tie, not an
error: a peer may pick either of two equally near segments.

Slaves are taken in chunks sorted by x, and each chunk is searched only among
the segments whose box comes within the radius of the chunk's box, so the
rough die at 10^6 x 10^5 stays affordable while every pair that could matter
is still evaluated.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import numpy as np

from jaxcontact import all_to_all


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


def reference_contact(x, surface, radius, *, chunk: int = 2048) -> Reference:
    """The closest segment of every slave within ``radius``: ``all_to_all`` in float64.

    Args:
      x: f[N, 2] slaves (any float dtype; converted to float64).
      surface: the master ``Surface`` (its nodes converted to float64).
      radius: the search radius, a scalar.
      chunk: slaves searched together.

    Returns:
      A ``Reference``.

    Raises:
      ValueError: where ``jax_enable_x64`` is off (the benchmarks' entry points set it).

    Example:
      >>> import numpy as np
      >>> from jaxcontact import Surface
      >>> tool = Surface(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0, 1]]))
      >>> ref = reference_contact([[0.5, -0.1], [5.0, 5.0]], tool, 0.2)
      >>> ref.segment.tolist(), np.round(ref.gap, 6).tolist(), ref.found.tolist()
      ([0, -1], [0.1, 0.0], [True, False])
    """
    if not jax.config.jax_enable_x64:
        raise ValueError("reference_contact needs jax_enable_x64 (the bench entry points set it)")
    x = np.asarray(x, np.float64).reshape(-1, 2)
    nodes = np.asarray(surface.nodes, np.float64)
    segments = np.asarray(surface.segments)
    real = np.ones(len(segments), bool) if surface.mask is None else np.asarray(surface.mask)
    body = None if surface.body is None else np.asarray(surface.body)
    start, end = nodes[np.maximum(segments[:, 0], 0)], nodes[np.maximum(segments[:, 1], 0)]
    low = np.minimum(start, end) - radius
    high = np.maximum(start, end) + radius
    count = len(x)
    segment = np.full(count, -1, np.int64)
    gap = np.zeros(count)
    detect = jax.jit(all_to_all)
    order = np.argsort(x[:, 0], kind="stable")
    for first in range(0, count, chunk):
        rows = order[first : first + chunk]
        box_low, box_high = x[rows].min(axis=0), x[rows].max(axis=0)
        near = np.flatnonzero(real & np.all((high >= box_low) & (low <= box_high), axis=1))
        if near.size == 0:
            continue
        # Padded to a power of two (slaves and segments, masked), so that a few
        # programs serve every chunk instead of one compiled per chunk's shape.
        width = 1 << int(near.size - 1).bit_length()
        kept = np.zeros(width, bool)
        kept[: near.size] = True
        taken = np.zeros(width, np.int64)
        taken[: near.size] = near
        slaves = np.zeros((chunk, 2))
        slaves[: len(rows)] = x[rows]
        mask = np.arange(chunk) < len(rows)
        part = surface._replace(
            nodes=nodes,
            segments=segments[taken],
            mask=kept,
            body=None if body is None else body[taken],
        )
        contact = detect(slaves, part, radius=radius, mask=mask)
        found = np.asarray(contact.found)[: len(rows)]
        chosen = np.asarray(contact.segment)[: len(rows)]
        segment[rows[found]] = taken[chosen[found]]
        gap[rows[found]] = np.asarray(contact.gap)[: len(rows)][found]
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
    distance (both measured by ``evaluate``) is a tie: a shared vertex, or two
    segments equally near, of which a peer may pick either. Its gap is
    compared with that segment's own, signed by its own ``(x - p) . n``.

    Example:
      >>> x, start, end = [[0.5, -0.1]], [[0.0, 0.0]], [[1.0, 0.0]]
      >>> ref = Reference(np.array([0]), np.array([0.1]), np.array([True]))
      >>> compare([-1], [0.0], [False], x, start, end, ref).missed
      1
    """
    segment, found = np.asarray(segment), np.asarray(found, bool)
    gap = np.asarray(gap, np.float64)
    segment = np.where(found, segment, -1)
    both = found & reference.found
    other = both & (segment != reference.segment)
    distance, own_gap = evaluate(x, start, end, segment)
    reference_distance, _ = evaluate(x, start, end, reference.segment)
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
