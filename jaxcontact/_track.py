"""Slip history: how far each slave slid along the master since the last step.

A slave's contact at the last step is a *material point* of the master:
segment ``k`` at ``xi``. Carried to the master's current position it is the
``anchor``, ``(1 - xi) a_k + xi b_k`` with the current nodes, so a master
that translates, rotates or stretches carries the material point with it. The
``slip`` is the signed path length along the current outline from the anchor
to this step's closest point, positive along the direction of the segment the
slave touches now (from its start node to its end node). When the closest
segment changed, the path walks across the vertices between the two, by the
segments' links (``outline.vertex_neighbours``), so no numbering is assumed:
outlines in any order, several outlines, segments that appeared since.

The walk goes up to ``WALK`` segments each way. Farther along the same
outline (a slave that slid past more than ``WALK`` segments in one step) the
slip is the difference of the arc coordinates of ``outline.chains`` (the
shorter way round a loop); these carry no gradient with respect to the nodes
in between. Across outlines (the slave now touches another chain, or last
step's segment is no longer real) there is no path along the master: the
slip is the anchor-to-point vector projected on the current tangent.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline import inputs as _inputs
from jaxcontact._pipeline import segments as _segments
from jaxcontact._pipeline.outline import chains, vertex_neighbours
from jaxcontact._pipeline.rows import on_rows
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


def no_slip(num_slaves: int, dtype, batch: tuple = ()) -> Slip:
    """The ``Slip`` before any step: zeros, nothing persisted."""
    shape = batch + (num_slaves,)
    return Slip(jnp.zeros(shape, dtype), jnp.zeros(shape, bool), jnp.zeros(shape + (2,), dtype))


def history_of(contact: Contact | ContactList, num_slaves: int) -> History:
    """The ``History`` a contact leaves (a ``ContactList`` is spread over ``num_slaves`` rows)."""
    if isinstance(contact, ContactList):
        rows = contact.node

        def spread(values, empty):
            base = jnp.full((num_slaves,), empty, values.dtype)
            return base.at[rows].set(values, mode="drop")

        found = contact.found
        return History(
            segment=spread(jnp.where(found, contact.segment, -1), -1),
            xi=spread(jnp.where(found, contact.xi, 0), 0),
            found=spread(found, False),
            active=spread(contact.active, False),
        )
    found = contact.found
    return History(
        segment=jnp.where(found, contact.segment, -1),
        xi=jnp.where(found, contact.xi, 0),
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
    if isinstance(last, ContactList):
        raise ValueError(
            "last must be a Contact or a History (N rows); got a ContactList, whose N is "
            "not known: pass last.to_contact(N)"
        )
    _inputs.check_2d_result("contact", contact)
    if not isinstance(last, History):
        _inputs.check_2d_result("last", last)
        last = history_of(last, last.found.shape[0])
    num_slaves = last.found.shape[0]
    if isinstance(contact, Contact) and contact.found.shape != last.found.shape:
        raise ValueError(
            f"contact must have the last step's {num_slaves} rows; got {contact.found.shape[0]}"
        )
    surface = _inputs.check_surface(surface, contact.point.dtype)
    return _track(last, contact, surface)


class _Now(NamedTuple):
    """This step's contact at some rows."""

    segment: Array
    xi: Array
    point: Array
    found: Array
    active: Array


@jax.jit
def _track(last: History, contact, surface: Surface) -> Slip:
    num_slaves = last.found.shape[0]
    if surface.segments.shape[0] == 0:  # nothing was found, now or then
        dtype = contact.point.dtype
        zeros = jnp.zeros((num_slaves,), dtype)
        return Slip(zeros, jnp.zeros((num_slaves,), bool), jnp.zeros((num_slaves, 2), dtype))
    links = _links(surface)
    if isinstance(contact, ContactList):
        # The entries are the rows: no slave outside them was found.
        now = _Now(contact.segment, contact.xi, contact.point, contact.found, contact.active)
        slip = _slip_at(last, contact.node, now, surface, links)

        def spread(values):
            empty = jnp.zeros((num_slaves,) + values.shape[1:], values.dtype)
            return empty.at[contact.node].set(values, mode="drop")

        return jax.tree.map(spread, slip)

    def at_rows(rows):
        def read(values, fill):
            return values.at[rows].get(mode="fill", fill_value=fill)

        now = _Now(
            read(contact.segment, -1),
            read(contact.xi, 0),
            read(contact.point, 0),
            read(contact.found, False),
            read(contact.active, False),
        )
        return _slip_at(last, rows, now, surface, links)

    return on_rows(contact.found & last.found, at_rows)


def _links(surface: Surface):
    """The segments resolved, and each one's neighbours ``(before, after)``."""
    segments = _segments.resolve_segments(surface)
    return segments, vertex_neighbours(segments)


def _slip_at(last: History, rows: Array, now: _Now, surface: Surface, links) -> Slip:
    """The ``Slip`` of the slaves ``rows`` (``N`` in unused slots), this step's contact ``now``."""
    dtype = now.point.dtype
    segments, (before, after) = links
    nodes, indices = surface.nodes, surface.segments
    num_segments = indices.shape[0]

    def read(values, fill):
        return values.at[rows].get(mode="fill", fill_value=fill)

    last_found, last_active = read(last.found, False), read(last.active, False)
    both = now.found & last_found
    ends = _segments.ends_of(nodes, indices)  # f[M, 2, 2], the current nodes
    squared = jnp.sum((ends[:, 1] - ends[:, 0]) ** 2, axis=-1)
    # 0 with a zero gradient for a zero-length segment (padding reading one node twice).
    length = jnp.where(squared > 0, jnp.sqrt(jnp.where(squared > 0, squared, 1)), 0)
    was = jnp.clip(read(last.segment, -1), 0, num_segments - 1)
    now_segment = jnp.clip(now.segment, 0, num_segments - 1)
    xi_was = jnp.where(both, read(last.xi, 0), 0).astype(dtype)
    xi_now = jnp.where(both, now.xi, 0)
    anchor = (1 - xi_was)[:, None] * ends[was, 0] + xi_was[:, None] * ends[was, 1]

    same = was == now_segment
    along = (xi_now - xi_was) * length[now_segment]

    def walk(links, first, sign):
        """Slip to ``now`` walking from ``was`` along ``links`` (after: +, before: -)."""
        covered = first
        at = links[was]
        hit = jnp.zeros(both.shape, bool)
        value = jnp.zeros(both.shape, dtype)
        for _ in range(WALK):
            here = (at == now_segment) & (at >= 0) & ~hit
            last_part = xi_now if sign > 0 else 1 - xi_now
            value = jnp.where(here, sign * (covered + last_part * length[now_segment]), value)
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
    safe_length = jnp.where(length[now_segment] > 0, length[now_segment], 1)
    tangent = (ends[now_segment, 1] - ends[now_segment, 0]) / safe_length[:, None]
    projected = jnp.sum((now.point - anchor) * tangent, axis=-1)
    far = both & ~same & ~hit_after & ~hit_before
    on_chain = jax.lax.cond(
        jnp.any(far),
        lambda: _arc_slip(segments, was, now_segment, xi_was, xi_now, projected),
        lambda: projected,
    )
    slip = jnp.where(same, along, jnp.where(hit_after | hit_before, walked, on_chain))
    slip = jnp.where(both, slip, 0)
    anchor = jnp.where(both[:, None], anchor, 0)
    return Slip(slip, now.active & last_active, anchor)


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
