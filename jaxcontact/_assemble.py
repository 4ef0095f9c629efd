"""Turning a chosen segment per slave into a ``Contact`` or ``Crossing``.

Every method (dense or binned) first decides, without gradients, which
segment each slave belongs to; then the per-pair kernel is evaluated once more
for that one pair. The values and their gradients therefore come from the same
code whatever the search was, and a binned search that picks the same segment
as the dense one returns bit-identical rows.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._geometry import path_hit, project
from jaxcontact._inputs import Segments
from jaxcontact._types import Array, Contact, Crossing


def contact_from_choice(
    x: Array, segments: Segments, choice: Array, radius: Array, overflow: Array, row_ok: Array
) -> Contact:
    """Builds the ``Contact`` of slaves ``x`` (f[N, 2], bad rows zeroed).

    Args:
      x: f[N, 2] sanitised slaves.
      segments: the resolved master segments.
      choice: i32[N] chosen segment per slave, -1 for none.
      radius: f[] search radius.
      overflow: bool[] passed through.
      row_ok: bool[N] real rows; the others are reported not found.
    """
    choice = jax.lax.stop_gradient(choice)
    has_choice = row_ok & (choice >= 0)
    index = jnp.maximum(choice, 0)
    if segments.ok.shape[0] == 0:
        start = end = jnp.zeros_like(x)
    else:
        start, end = segments.start[index], segments.end[index]
    projection = jax.vmap(project)(x, start, end)
    found = has_choice & (jnp.abs(projection.gap) <= radius)

    def keep(value):
        return jnp.where(found.reshape(found.shape + (1,) * (value.ndim - 1)), value, 0)

    gap = keep(projection.gap)
    return Contact(
        gap=gap,
        xi=keep(projection.xi),
        segment=jnp.where(found, choice, -1).astype(jnp.int32),
        point=keep(projection.point),
        normal=keep(projection.normal),
        found=found,
        active=found & (gap < 0),
        overflow=overflow,
    )


def crossing_from_choice(
    x_prev: Array, x: Array, segments: Segments, choice: Array, overflow: Array, row_ok: Array
) -> Crossing:
    """Builds the ``Crossing`` of paths ``x_prev -> x`` (f[N, 2] each, bad rows zeroed).

    Arguments as for ``contact_from_choice``.
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
