"""The swept query: the first crossing of each slave's path ``x_prev -> x`` with the master.

The paper's detection strategy: a node whose path crosses a tool segment
between two steps has penetrated it, whatever its gap now. The search keeps
the earliest time of first hit along each path (exact ties to the lower
segment index); the pair is then evaluated once more (``path_hit``).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._pipeline import inputs
from jaxcontact._pipeline.broad import Box, conservative_margin, segment_boxes
from jaxcontact._pipeline.geometry import first_hit_time, path_hit
from jaxcontact._pipeline.segments import Segments, paths_ok, sanitize_paths, squared_norm
from jaxcontact._query.base import Query
from jaxcontact._types import Array, Crossing, CrossingList


def path_lengths(x_prev: Array, x: Array) -> Array:
    """f[N]: each path's length, a path's reach for the self-contact window."""
    return jnp.sqrt(squared_norm(x - x_prev))


def crossing_from_choice(
    x_prev: Array, x: Array, segments: Segments, choice: Array, overflow: Array, row_ok: Array
) -> Crossing:
    """Builds the ``Crossing`` of paths ``x_prev -> x`` (f[N, 2] each, bad rows zeroed).

    Arguments as for ``closest.contact_from_choice``.
    """
    choice = jax.lax.stop_gradient(choice)
    has_choice = row_ok & (choice >= 0)
    index = jnp.maximum(choice, 0)
    if segments.ok.shape[0] == 0:
        start = end = jnp.zeros_like(x)
    else:
        start, end = segments.start[index], segments.end[index]
    hit = jax.vmap(path_hit)(x_prev, x, start, end)
    crossed = has_choice & hit.hit
    t = jnp.where(crossed, hit.t, 0)
    point = jnp.where(crossed[:, None], x_prev + t[:, None] * (x - x_prev), 0)
    return Crossing(
        t=t,
        segment=jnp.where(crossed, choice, -1).astype(jnp.int32),
        point=point,
        crossed=crossed,
        overflow=overflow,
    )


class Swept(Query):
    """The first crossing of each path ``x_prev -> x``: a ``Crossing``."""

    name = "swept"
    result = Crossing
    listing = CrossingList
    flag = "crossed"
    num_points = 2
    uses_radius = False
    # The exhaustive swept search's rows come in whole vectors: with XLA's
    # CPU fusion emitters it ran 3x slower on 81,937 or 81,939 rows than
    # padded to 81,944 (measured with commit 5928bf7f76cc:benchmarks/archive/row_counts.py).
    row_multiple = 8

    def check(self, points, surface, radius, mask):
        x_prev, x = points
        x_prev, x, mask = inputs.check_path_inputs(x_prev, x, mask)
        return (x_prev, x), inputs.check_surface(surface, x.dtype), None, mask

    def sizing(self, points, reach):
        return {"x_prev": points[0]}

    def kernel(self, x_prev, x, edge):
        return first_hit_time(x_prev, x, edge)

    def sanitize(self, points, mask):
        x_prev, x, ok = sanitize_paths(*points, mask)
        return (x_prev, x), ok

    def pair_reach(self, points, ok, radius):
        return jnp.where(ok, path_lengths(*points), 0)

    def row_boxes(self, points, mask):
        # A path meets a segment only if their boxes meet.
        x_prev, x = points
        return jnp.minimum(x_prev, x), jnp.maximum(x_prev, x), paths_ok(x_prev, x, mask)

    def inflate(self, points, radius, mask):
        return jnp.zeros((), points[0].dtype)

    def cell_boxes(self, segments: Segments, kept, ok, culled) -> Box:
        # Where a path meets a segment, its start lies within the path's
        # length of that segment: bin the segments inflated by the longest
        # kept path and look up each path's start (the paper's boxes
        # inflated by d_max).
        start, end = kept
        longest = jnp.max(jnp.where(ok, jnp.max(jnp.abs(end - start), axis=-1), 0), initial=0)
        return segment_boxes(segments, conservative_margin(longest, segments.start, segments.end))

    def assemble(self, kept, segments, choice, radius, overflow, ok, ruling):
        return crossing_from_choice(*kept, segments, choice, overflow, ok)

    def reportable(self, choice, score, ok, segments, radius):
        return ok & (choice >= 0)


SWEPT = Swept()
