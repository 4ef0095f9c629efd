"""Slip history: how far each slave slid along the master since the last step.

A slave's contact at the last step is a *material point* of the master:
segment ``k`` at ``xi``. Carried to the master's current position it is the
``anchor``, ``(1 - xi) a_k + xi b_k`` with the current nodes, so a master
that translates, rotates or stretches carries the material point with it. The
``slip`` is the signed path length along the current outline from the anchor
to this step's closest point, positive along the direction of the segment the
slave touches now (from its start node to its end node). When the closest
segment changed, the path walks across the vertices between the two, by the
segments' links (``_outline.vertex_neighbours``), so no numbering is assumed:
outlines in any order, several outlines, segments that appeared since.

The walk goes up to ``WALK`` segments each way. Farther along the same
outline (a slave that slid past more than ``WALK`` segments in one step) the
slip is the difference of the arc coordinates of ``_outline.chains`` (the
shorter way round a loop); these carry no gradient with respect to the nodes
in between. Across outlines (the slave now touches another chain, or last
step's segment is no longer real) there is no path along the master: the
slip is the anchor-to-point vector projected on the current tangent.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact import _inputs
from jaxcontact._outline import chains, vertex_neighbours
from jaxcontact._types import Array, Contact, ContactList, Surface

# Segments walked each way from last step's segment before the arc
# coordinates are used: a slave in an explicit simulation moves a fraction
# of a segment per step, so 8 covers every step but a jump.
WALK = 8


class History(NamedTuple):
    """Last step's contact of each slave, as ``Search(track=True)`` carries it."""

    segment: Array  # i32[N]  the segment, -1 where none was found
    xi: Array  # f[N]  the material point on it
    found: Array  # bool[N]
    active: Array  # bool[N]


class Slip(NamedTuple):
    """What each slave did along the master since the last step.

    Rows that were not ``found`` at this step or at the last hold zeros (and
    ``persisted`` False).
    """

    slip: Array  # f[N]  signed tangential slip along the current master outline
    persisted: Array  # bool[N]  active now and at the last step
    anchor: Array  # f[N, 2]  last step's material point on the master, where it is now


def empty_history(num_slaves: int, dtype, batch: tuple = ()) -> History:
    """A history with nothing found: the first step persists nothing."""
    shape = batch + (num_slaves,)
    return History(
        segment=jnp.full(shape, -1, jnp.int32),
        xi=jnp.zeros(shape, dtype),
        found=jnp.zeros(shape, bool),
        active=jnp.zeros(shape, bool),
    )


def history_of(contact: Contact | ContactList, num_slaves: int) -> History:
    """The ``History`` a contact leaves (a ``ContactList`` is spread over ``num_slaves`` rows)."""
    if isinstance(contact, ContactList):
        contact = contact.to_contact(num_slaves)
    found = contact.found
    return History(
        segment=jnp.where(found, contact.segment, -1),
        xi=jax.lax.stop_gradient(jnp.where(found, contact.xi, 0)),
        found=found,
        active=contact.active,
    )


def forget(history: History, rows) -> History:
    """``history`` with the rows where ``rows`` (bool[N]) is True forgotten."""
    rows = jnp.asarray(rows, bool)
    if rows.shape != history.found.shape[-1:]:
        raise ValueError(
            f"rows must have shape {history.found.shape[-1:]} (one per slave); "
            f"got shape {rows.shape}"
        )
    keep = ~rows
    return History(
        segment=jnp.where(keep, history.segment, -1),
        xi=jnp.where(keep, history.xi, 0),
        found=history.found & keep,
        active=history.active & keep,
    )


def track(last, contact: Contact | ContactList, surface: Surface) -> Slip:
    """The slip of every slave between two steps' contacts.

    The plain-call form of what ``Search(track=True)`` returns: ``last`` is
    the ``Contact`` of the last step (or a ``History``), ``contact`` this
    step's (a ``Contact``, or a ``ContactList`` of as many slaves as
    ``last`` has rows), ``surface`` the master now. Runs under ``jit``,
    ``vmap``, ``grad`` (the slip's gradient with respect to this step's
    points and the master's nodes) and ``lax.scan``.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, all_to_all, track
      >>> floor = Surface(jnp.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]),
      ...                 jnp.array([[2, 1], [1, 0]]))  # two segments, right to left
      >>> before = all_to_all(jnp.array([[1.2, -0.01]]), floor, radius=0.1)
      >>> after = all_to_all(jnp.array([[0.7, -0.01]]), floor, radius=0.1)
      >>> slip = track(before, after, floor)
      >>> round(float(slip.slip[0]), 6), bool(slip.persisted[0])  # along the segments
      (0.5, True)
    """
    if not isinstance(last, History):
        last = history_of(last, last.found.shape[0])
    num_slaves = last.found.shape[0]
    if isinstance(contact, ContactList):
        contact = contact.to_contact(num_slaves)
    if contact.found.shape != last.found.shape:
        raise ValueError(
            f"contact must have the last step's {num_slaves} rows; got {contact.found.shape[0]}"
        )
    surface = _inputs.check_surface(surface, contact.point.dtype)
    return _track(last, contact, surface)


@jax.jit
def _track(last: History, contact: Contact, surface: Surface) -> Slip:
    dtype = contact.point.dtype
    nodes, indices = surface.nodes, surface.segments
    num_segments = indices.shape[0]
    both = contact.found & last.found
    if num_segments == 0:
        zeros = jnp.zeros(both.shape, dtype)
        return Slip(zeros, both & False, jnp.zeros(both.shape + (2,), dtype))
    ends = _inputs.ends_of(nodes, indices)  # f[M, 2, 2], the current nodes
    length = jnp.sqrt(jnp.sum((ends[:, 1] - ends[:, 0]) ** 2, axis=-1))
    was = jnp.clip(last.segment, 0, num_segments - 1)
    now = jnp.clip(contact.segment, 0, num_segments - 1)
    xi_was = jnp.where(both, last.xi, 0).astype(dtype)
    xi_now = jnp.where(both, contact.xi, 0)
    anchor = (1 - xi_was)[:, None] * ends[was, 0] + xi_was[:, None] * ends[was, 1]

    segments = _inputs.resolve_segments(surface)
    before, after = vertex_neighbours(segments)
    same = was == now
    along = (xi_now - xi_was) * length[now]

    def walk(links, first, sign):
        """Slip to ``now`` walking from ``was`` along ``links`` (after: +, before: -)."""
        covered = first
        at = links[was]
        hit = jnp.zeros(both.shape, bool)
        value = jnp.zeros(both.shape, dtype)
        for _ in range(WALK):
            here = (at == now) & (at >= 0) & ~hit
            last_part = xi_now if sign > 0 else 1 - xi_now
            value = jnp.where(here, sign * (covered + last_part * length[now]), value)
            hit = hit | here
            safe = jnp.maximum(at, 0)
            covered = covered + jnp.where(at >= 0, length[safe], 0)
            at = jnp.where(at >= 0, links[safe], -1)
        return hit, value

    hit_after, slip_after = walk(after, (1 - xi_was) * length[was], 1)
    hit_before, slip_before = walk(before, xi_was * length[was], -1)
    walked = jnp.where(
        hit_after & hit_before,
        jnp.where(jnp.abs(slip_after) <= jnp.abs(slip_before), slip_after, slip_before),
        jnp.where(hit_after, slip_after, slip_before),
    )
    tangent = (ends[now, 1] - ends[now, 0]) / jnp.where(length[now] > 0, length[now], 1)[:, None]
    projected = jnp.sum((contact.point - anchor) * tangent, axis=-1)
    far = both & ~same & ~hit_after & ~hit_before
    on_chain = jax.lax.cond(
        jnp.any(far),
        lambda: _arc_slip(segments, was, now, xi_was, xi_now, projected),
        lambda: projected,
    )
    slip = jnp.where(same, along, jnp.where(hit_after | hit_before, walked, on_chain))
    slip = jnp.where(both, slip, 0)
    anchor = jnp.where(both[:, None], anchor, 0)
    return Slip(slip, contact.active & last.active, anchor)


def _arc_slip(segments, was, now, xi_was, xi_now, projected):
    """Slip from the arc coordinates where both segments lie on one chain, else ``projected``."""
    outline = chains(segments)
    # u runs from a chain's end back to its start: along a segment it falls
    # from ``high`` (start) to ``low`` (end).
    u_was = outline.high[was] - xi_was * (outline.high[was] - outline.low[was])
    u_now = outline.high[now] - xi_now * (outline.high[now] - outline.low[now])
    slip = u_was - u_now
    loop = outline.loop[now]
    wrapped = slip - loop * jnp.round(slip / jnp.where(jnp.isfinite(loop), loop, 1))
    slip = jnp.where(jnp.isfinite(loop), wrapped, slip)
    one_chain = (outline.chain[was] == outline.chain[now]) & (outline.chain[now] >= 0)
    return jnp.where(one_chain, slip, projected)
