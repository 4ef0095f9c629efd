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
from jaxcontact._types import Surface

# How many bad row indices a message lists before it only counts them.
_LISTED = 5


def _rows(bad: np.ndarray) -> str:
    rows = np.flatnonzero(bad)
    listed = ", ".join(str(int(row)) for row in rows[:_LISTED])
    more = f", ... ({len(rows)} rows in all)" if len(rows) > _LISTED else ""
    return f"rows [{listed}{more}]"


def _concrete(name: str, value):
    if value is not None and any(isinstance(v, jax.core.Tracer) for v in jax.tree.leaves(value)):
        raise ValueError(f"validate needs concrete arrays; {name} is traced (call it outside jit)")


def validate(x, surface: Surface, *, radius=None, mask=None, x_prev=None) -> None:
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
    naming its rows rather than an error. So do two inputs that are legal
    but give wrong answers without a word (``_clockwise_loops``,
    ``_rounding_against_radius``): a closed loop of real segments listed
    clockwise, whose normals point into it, and float32 coordinates so far
    from the origin that their rounding is not small against ``radius``.

    Args:
      x: f[N, 2] slave coordinates.
      surface: the master ``Surface``.
      radius: optional search radius (for ``all_to_all`` and ``bucket_sort``).
      mask: optional bool[N] slave mask, False for padding.
      x_prev: optional f[N, 2] previous positions (for ``swept`` and
        ``bucket_swept``).

    Raises:
      ValueError: naming the argument and, for bad values, the first few bad
        row indices and their count; also when an argument is traced.

    Example:
      >>> import numpy as np
      >>> from jaxcontact import Surface, validate
      >>> tool = Surface(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0, 1]]))
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


def _clockwise_loops(ends: np.ndarray, segments: np.ndarray, real: np.ndarray) -> list:
    """The closed loops of ``real`` segments whose signed area is negative (clockwise),
    each as its segment indices.

    A segment is followed by the real segment that starts at its end node (the lowest
    index, as the vertex tie rule follows it: ``outline.vertex_neighbours``); a loop is a
    chain that comes back to where it started. The outward normal is ``(t_y, -t_x)``,
    to the right of the direction of travel, which is outside a counter-clockwise loop.
    """
    following = {}
    for k in np.flatnonzero(real)[::-1]:
        following[int(segments[k, 0])] = int(k)
    seen, loops = set(), []
    for first in np.flatnonzero(real):
        path, at, k = [], {}, int(first)
        while k >= 0 and k not in seen and k not in at:
            at[k] = len(path)
            path.append(k)
            k = following.get(int(segments[k, 1]), -1)
        seen.update(path)
        if k >= 0 and k in at:
            loop = np.asarray(path[at[k] :])
            start, end = ends[loop, 0], ends[loop, 1]
            # The shoelace formula, relative to one vertex so far from the origin stays exact.
            start, end = start - start[0], end - start[0]
            area = np.sum(start[:, 0] * end[:, 1] - end[:, 0] * start[:, 1]) / 2
            if area < 0:
                loops.append(loop)
    return loops
