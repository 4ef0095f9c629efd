"""The exhaustive detectors: every slave against every master segment.

The per-pair kernel is ``vmap``-ed over the slaves for one segment at a time
and reduced by ``lowest_score`` over the segments; the kernel is then
evaluated once more for each slave's chosen pair.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from jaxcontact import _inputs
from jaxcontact._assemble import contact_from_choice, crossing_from_choice
from jaxcontact._geometry import first_hit_time, squared_distance
from jaxcontact._inputs import Segments
from jaxcontact._lowest import one_scene_at_a_time
from jaxcontact._narrow import in_stages, search_all, vmapped
from jaxcontact._normals import CORNER_DEGREES, check_normals, smoothed_jit
from jaxcontact._padded import cut_rows, pad_contact_scene, pad_scene
from jaxcontact._pairs import NO_PAIRING, Pairing, ruled, tag
from jaxcontact._placement import searched_whole
from jaxcontact._types import Array, Contact, Crossing, Surface


def all_to_all(
    x: Array,
    surface: Surface,
    *,
    radius,
    mask: Array | None = None,
    slave_node: Array | None = None,
    slave_body: Array | None = None,
    self_contact: bool = False,
    normals: str = "flat",
    corner: float = CORNER_DEGREES,
) -> Contact:
    """Closest master segment of every slave, by dense N x M projection.

    Args:
      x: f[N, 2] slave coordinates (float32 or float64).
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: search radius, >= 0: a scalar, or f[N] one per slave; a slave
        is ``found`` when its closest real segment lies within its radius.
      mask: optional bool[N], False for padding slaves.
      slave_node: optional i32[N], the index in ``surface.nodes`` that each
        slave is (-1 for none): a slave never pairs with a segment that has
        its own node as an end.
      slave_body: optional i32[N], each slave's body: with ``surface.body``
        too, a slave pairs only with other bodies' segments.
      self_contact: a slave also pairs with its own body's segments, except
        those in its neighbourhood along the outline (docs/contract.md,
        "Bodies and self-contact"). Needs ``slave_node``; with no body
        labels the whole surface is one body.
      normals: ``"flat"`` (each segment's own normal) or ``"smooth"``: a
        normal interpolated along each segment between nodal normals, the
        bisectors at nodes where the outline turns by less than ``corner``
        degrees, and the gap measured along it (docs/contract.md, "Smooth
        normals"). The segment, ``xi`` and point are the same either way.
      corner: the corner angle of smooth normals, in degrees.

    Returns:
      A ``Contact`` with one row per slave, in ``x``'s dtype. ``overflow`` is
      always False. Costs O(N M) time and O(N + M) memory.

    Raises:
      ValueError: on a wrong shape or dtype, and (outside ``jit``) on a real
        segment's index out of range (masked segments' indices may be
        anything) or a negative or non-finite radius.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, all_to_all
      >>> floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]]), jnp.array([[0, 1]]))
      >>> contact = all_to_all(jnp.array([[0.5, 0.25], [0.5, -0.125]]), floor, radius=0.5)
      >>> contact.gap.tolist(), contact.active.tolist(), contact.normal.tolist()
      ([0.25, -0.125], [False, True], [[0.0, 1.0], [0.0, 1.0]])
    """
    x, surface, radius, mask = _inputs.check_contact_inputs(x, surface, radius, mask)
    pairing = _inputs.check_pairing(slave_node, slave_body, self_contact, x, surface, mask)
    x, mask, surface, radius, pairing, num_rows = pad_contact_scene(
        x, mask, surface, radius, pairing
    )
    corner = check_normals(normals, corner)
    contact = _all_to_all(x, surface, radius, mask, pairing)
    return cut_rows(with_normals(contact, x, surface, normals, corner), num_rows)


def with_normals(result, x, surface, normals: str, corner: float):
    """``result`` with the normals asked for; a no-op for flat normals."""
    return result if normals == "flat" else smoothed_jit(result, x, surface, corner)


def _search_all(kernel, rows, segments: Segments, slave_ok, assemble):
    """``assemble(choice)`` for the segment of lowest ``kernel(*row, row_tags, segment)``
    per row, over every segment (``kernel`` from ``_pairs.ruled``, the
    rows' tags last in ``rows``).

    The search runs in a ``lax.cond`` (``_narrow.in_stages``), scene by
    scene under ``vmap`` (``_lowest.one_scene_at_a_time``). Masked rows are
    dropped when assembling, not inside the search's loop (a row mask fused
    into it made it 3-4x slower, measured).
    """
    fixed = jax.lax.stop_gradient((rows, segments))
    search = one_scene_at_a_time(functools.partial(_lowest, kernel))
    choice = search(*fixed, slave_ok)
    # The search's cond already separates it from the gathers; a cond here
    # would only skip assembling rows that are all masked (and under vmap run
    # both branches).
    return assemble(choice)


def _lowest(kernel, rows, segments: Segments, slave_ok):
    """i32[N]: per row, the segment of lowest ``kernel``; -1 if no row is real."""

    def search(_):
        pair_value = vmapped(kernel, *rows)
        return search_all(pair_value, segments, slave_ok.shape[0], segments.start.dtype)[0]

    return in_stages(jnp.any(slave_ok), [search], [jnp.full(slave_ok.shape, -1, jnp.int32)])


# The swept search's rows come in whole vectors: with XLA's CPU fusion
# emitters (its default code generator) it ran 3x slower on 81,937 or 81,939
# rows than padded to 81,944 (python benchmarks/row_counts.py). Masked rows of zeros
# fill the last vector; a real row never sees them. all_to_all is slower on
# such counts too (2.5x, 81,939 against 81,936 rows), but padding it the same
# way did not help: the cause is elsewhere, not found yet.
ROW_MULTIPLE = 8


def _whole_vectors(rows: tuple, mask, per_row=None):
    """``rows`` (each f[N, 2]), ``mask`` and ``per_row`` (a pytree of other
    per-row arrays: the pair keywords), padded with masked rows (zeros) to a
    multiple of ``ROW_MULTIPLE``."""
    extra = -rows[0].shape[0] % ROW_MULTIPLE
    if extra == 0:
        return rows, mask, per_row
    ok = jnp.ones(rows[0].shape[0], bool) if mask is None else mask

    def pad(values):
        return jnp.pad(values, ((0, extra),) + ((0, 0),) * (values.ndim - 1))

    padded = tuple(map(pad, rows)), pad(ok), jax.tree.map(pad, per_row)
    # Written out once: a pad fused into the search's loops would keep the odd count.
    return jax.lax.optimization_barrier(padded)


def _first_rows(result, num_rows: int):
    """``result`` (a ``Contact`` or ``Crossing``) cut back to its first ``num_rows`` rows."""
    result = jax.lax.optimization_barrier(result)  # the search writes whole vectors too
    return jax.tree.map(lambda field: field[:num_rows] if field.ndim else field, result)


# Compiled as one program even when called outside jit: op by op, the unrolled
# search took seconds to dispatch on a new shape.
@jax.jit
@searched_whole(rows="x")
def _all_to_all(x, surface, radius, mask, pairing: Pairing = NO_PAIRING):
    x, slave_ok = _inputs.sanitize_points(x, mask)
    segments = _inputs.resolve_segments(surface)
    rule, tags, segments = tag(pairing, segments, surface.body, radius)

    def assemble(choice):
        return contact_from_choice(x, segments, choice, radius, no_overflow, slave_ok, rule, tags)

    no_overflow = jnp.zeros((), bool)
    kernel = ruled(squared_distance, rule)
    return _search_all(kernel, (x, tags), segments, slave_ok, assemble)


def swept(
    x_prev: Array,
    x: Array,
    surface: Surface,
    *,
    mask: Array | None = None,
    slave_node: Array | None = None,
    slave_body: Array | None = None,
    self_contact: bool = False,
) -> Crossing:
    """First crossing of every slave's path ``x_prev -> x`` with the master, densely.

    The earliest crossing along the path wins; exact ties go to the lower
    segment index.

    Args:
      x_prev: f[N, 2] previous slave positions.
      x: f[N, 2] current slave positions, same shape and dtype.
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      mask: optional bool[N], False for padding slaves.
      slave_node, slave_body, self_contact: the pair rule, as for
        ``all_to_all``; a path's self-contact neighbourhood is measured in
        multiples of its length.

    Returns:
      A ``Crossing`` with one row per slave, in ``x``'s dtype; ``overflow`` is
      always False. Costs O(N M) time and O(N + M) memory.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, swept
      >>> wall = Surface(jnp.array([[1.0, 0.0], [1.0, 2.0]]), jnp.array([[0, 1]]))
      >>> crossing = swept(jnp.array([[0.0, 1.0]]), jnp.array([[4.0, 1.0]]), wall)
      >>> crossing.crossed.tolist(), crossing.t.tolist(), crossing.point.tolist()
      ([True], [0.25], [[1.0, 1.0]])
    """
    x_prev, x, mask = _inputs.check_path_inputs(x_prev, x, mask)
    surface = _inputs.check_surface(surface, x.dtype)
    pairing = _inputs.check_pairing(slave_node, slave_body, self_contact, x, surface, mask)
    (x_prev, x), mask, surface, pairing, num_rows = pad_scene((x_prev, x), mask, surface, pairing)
    return cut_rows(_swept(x_prev, x, surface, mask, pairing), num_rows)


def path_lengths(x_prev: Array, x: Array) -> Array:
    """f[N]: each path's length, a path's reach for the self-contact window."""
    return jnp.sqrt(_inputs.squared_norm(x - x_prev))


@jax.jit
@searched_whole(rows="x")
def _swept(x_prev, x, surface, mask, pairing: Pairing = NO_PAIRING):
    num_rows = x.shape[0]
    (x_prev, x), mask, pairing = _whole_vectors((x_prev, x), mask, pairing)
    x_prev, x, slave_ok = _inputs.sanitize_paths(x_prev, x, mask)
    segments = _inputs.resolve_segments(surface)
    rule, tags, segments = tag(pairing, segments, surface.body, path_lengths(x_prev, x))

    def assemble(choice):
        return crossing_from_choice(x_prev, x, segments, choice, no_overflow, slave_ok)

    no_overflow = jnp.zeros((), bool)
    kernel = ruled(first_hit_time, rule)
    crossing = _search_all(kernel, (x_prev, x, tags), segments, slave_ok, assemble)
    return _first_rows(crossing, num_rows)
