"""Arbitrary Lagrangian-Eulerian (ALE) steps on a Q4 mesh: rezone, then remap, every k steps.

An explicit Lagrangian mesh follows the material; where the material shears
hard (a chip's root against a tool's rake face) its elements shear with it into
slivers and the run tears. The operator-split ALE of explicit codes keeps the
mesh's connectivity and, every ``every`` Lagrangian steps,

1. **rezones**: moves the nodes of a region the problem names towards a
   smoother mesh (``rezone``: Laplacian smoothing, each node to the mean of its
   edge neighbours, a node on a boundary sliding along its own boundary
   polyline), guarded so that no element's shape worsens below the region's
   worst (``quality``);
2. **remaps** the state from the old mesh to the new one on the same
   connectivity (``remap``, ``remap_points``, ``remap_velocity``).

This is the scheme of Benson's review (D. J. Benson, "Computational methods in
Lagrangian and Eulerian hydrocodes", *Comput. Methods Appl. Mech. Eng.* 99,
235-394, 1992, sections 5-6): the remap is an advection by the mesh's motion,
face by face, the volume each face sweeps carrying its donor element's state.
Abaqus/Explicit's adaptive meshing (every 10 increments by default, second-order
advection) and LS-DYNA's ALE (van Leer, ``METH=1``) do it this way.

* **Swept volumes** (Benson 1992, eq. 6.6; the flux volume of BookLeaf's
  ``getFluxVolume``): a face from ``a`` to ``b`` moving to ``a'``, ``b'``
  sweeps the signed area of the quadrilateral ``a b b' a'``. The sum of an
  element's four is exactly its change of area, so a uniform field remaps to
  itself, and each face's flux is computed once and given to one side and
  taken from the other, so mass and every ``phi * mass`` are conserved to
  round-off.
* **Second order** (van Leer, 1977, *J. Comput. Phys.* 23, 276-299, the
  harmonic limiter): the donor's value at the face is
  ``phi_D + (1 - c) delta / 2``, ``delta`` the van Leer mean of the
  differences to its neighbours across the face and across the opposite face
  (each quad has two logical directions), ``c`` the share of the donor the
  face sweeps. Monotone: a remapped value stays within its neighbours' range.
  ``order=1`` is the donor cell (first order, diffusive, bounded).
* **Element state** is remapped per unit mass, mass-weighted (BookLeaf's
  ``updateEl``): stress, plastic strain, temperature. The Gauss points keep
  their deviations from the element's mean, which is what is remapped: the
  mean is conserved, the within-element gradient the Lagrangian steps built
  is kept.
* **Velocity** is interpolated at each node's new place in the old mesh (the
  bilinear map inverted by Newton's method in the node's elements). Not
  conservative of momentum, to the order of the move: the moves are a small
  share of an element.
* **Contact history** stays with the nodes: a problem with a slip history
  re-reads it at the new positions (the cutting problem does).

Everything is a gather over the static tables ``tables`` builds once in
NumPy, and a ``jax.ops.segment_sum``: fixed shapes, ``jit``, ``vmap`` and
``grad`` (the limiter and the donor choice are piecewise smooth; the
guard's choice of a blend is held fixed, ``stop_gradient``). Units: any, as
long as consistent (the problems use mm, tonne, s).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact.sim import materials
from jaxcontact.sim.elements import q4

__all__ = [
    "GUARD_HALVINGS",
    "NEWTON",
    "Settings",
    "Tables",
    "areas",
    "cycles",
    "quality",
    "remap",
    "remap_points",
    "remap_velocity",
    "rezone",
    "swept",
    "tables",
]


class Tables(NamedTuple):
    """A Q4 mesh's neighbours, built once on the host by ``tables``."""

    faces: Array  # i32[F, 2]  each face's two nodes, counter-clockwise in ``left``
    left: Array  # i32[F]  the element the face is an edge of
    right: Array  # i32[F]  the element across it, -1 on the boundary
    left_side: Array  # i32[F]  the face's index (0-3: corners k, k+1) in ``left``
    right_side: Array  # i32[F]  its index in ``right`` (0 on the boundary)
    across: Array  # i32[E, 4]  the element across each face of an element, -1 none
    neighbours: Array  # i32[N, K]  each node's edge neighbours, -1 padding
    elements: Array  # i32[N, C]  the elements at each node, -1 padding
    corner: Array  # i32[N, C]  the node's corner (0-3) in each of them


def tables(quads: q4.Quads) -> Tables:
    """The neighbour tables of ``quads`` (NumPy, once per mesh)."""
    elements = np.asarray(quads.quads)
    num_nodes = int(np.asarray(quads.nodes).shape[0])
    if elements.ndim != 2 or elements.shape[1] != 4:
        raise ValueError(f"quads.quads must be i32[E, 4]; got shape {elements.shape}")
    owner: dict[tuple[int, int], tuple[int, int]] = {}
    for e, corners in enumerate(elements):
        for k in range(4):
            owner[(int(corners[k]), int(corners[(k + 1) % 4]))] = (e, k)
    faces, left, right, left_side, right_side = [], [], [], [], []
    across = np.full(elements.shape, -1, np.int64)
    for (a, b), (e, k) in owner.items():
        other = owner.get((b, a))
        if other is not None:
            across[e, k] = other[0]
            if (b, a) < (a, b):
                continue  # one face, kept from its first side
        faces.append((a, b))
        left.append(e)
        left_side.append(k)
        right.append(-1 if other is None else other[0])
        right_side.append(0 if other is None else other[1])
    links: list[set[int]] = [set() for _ in range(num_nodes)]
    at: list[list[tuple[int, int]]] = [[] for _ in range(num_nodes)]
    for e, corners in enumerate(elements):
        for k in range(4):
            a, b = int(corners[k]), int(corners[(k + 1) % 4])
            links[a].add(b)
            links[b].add(a)
            at[a].append((e, k))

    def padded(rows, width):
        table = np.full((num_nodes, max(1, width)), -1, np.int64)
        for i, row in enumerate(rows):
            table[i, : len(row)] = row
        return table

    neighbours = padded([sorted(r) for r in links], max(map(len, links)))
    elements_at = padded([[e for e, _ in r] for r in at], max(map(len, at)))
    corner = padded([[k for _, k in r] for r in at], max(map(len, at)))

    def i32(values):
        return jnp.asarray(np.asarray(values, np.int32))

    return Tables(
        i32(np.reshape(faces, (-1, 2))),
        i32(left),
        i32(right),
        i32(left_side),
        i32(right_side),
        i32(across),
        i32(neighbours),
        i32(elements_at),
        i32(corner),
    )


# -- the rezone ---------------------------------------------------------------------


def quality(quads: q4.Quads, x: Array) -> Array:
    """f[E]: each element's least scaled corner Jacobian on ``x``: the cross
    product of the two edges at a corner over the product of their lengths,
    the sine of the corner's angle (Knupp, 2001, *SIAM J. Sci. Comput.* 23,
    193-218). 1 for a rectangle, towards 0 for a sliver, 0 or below for a folded
    or inside-out element."""
    corners = x[quads.quads]
    forward = jnp.roll(corners, -1, axis=1) - corners
    backward = jnp.roll(corners, 1, axis=1) - corners
    cross = forward[..., 0] * backward[..., 1] - forward[..., 1] * backward[..., 0]
    lengths = jnp.sqrt(jnp.sum(forward**2, -1) * jnp.sum(backward**2, -1))
    return jnp.min(cross / jnp.maximum(lengths, jnp.finfo(x.dtype).tiny), axis=1)


class Settings(NamedTuple):
    """How an ALE run rezones and remaps (static numbers: hashable, a ``jit`` constant).

    Attributes:
      every: the Lagrangian steps between two rezones (``cycles``).
      weight: the share of the way to its neighbours' mean a sweep moves a
        node (the relaxation of Laplacian smoothing, 0 to 1).
      sweeps: the Jacobi sweeps of one rezone.
      floor: the guard's floor (``rezone``) of an element's ``quality`` (the
        sine of a corner's angle) and of its area over its reference area.
      order: the remap's order: 2, van Leer; 1, the donor cell.
    """

    every: int = 20
    weight: float = 0.5
    sweeps: int = 2
    floor: float = 0.5
    order: int = 2


def _slide(x: Array, along: Array, mean: Array, weight) -> Array:
    """The next position of each node on a boundary: ``weight`` of its move to
    ``mean`` (its edge neighbours' mean) along the boundary's tangent, taken
    along the polyline through its two boundary neighbours (so the node stays
    on the boundary). The neighbour inside the mesh pulls it under itself: a
    boundary row sheared against the next one is straightened."""
    before, after = x[jnp.maximum(along[:, 0], 0)], x[jnp.maximum(along[:, 1], 0)]
    tiny = jnp.finfo(x.dtype).tiny

    def length(vector):
        return jnp.sqrt(jnp.maximum(jnp.sum(vector**2, -1), tiny))

    tangent = (after - before) / length(after - before)[:, None]
    shift = weight * jnp.sum((mean - x) * tangent, -1)  # + towards ``after``
    forward = shift > 0
    to = jnp.where(forward[:, None], after - x, before - x)
    # At most half way to that neighbour: the node stays on its own two segments.
    room = length(to)
    distance = jnp.minimum(jnp.abs(shift), 0.5 * room)
    return x + (distance / room)[:, None] * to


def _smoothed(tables: Tables, x: Array, movable: Array, along: Array, settings: Settings):
    """``settings.sweeps`` Jacobi sweeps of Laplacian smoothing with boundary sliding."""
    real = tables.neighbours >= 0
    count = jnp.maximum(real.sum(1), 1)
    sliding = along[:, 0] >= 0

    def sweep(_, x):
        around = jnp.where(real[..., None], x[jnp.maximum(tables.neighbours, 0)], 0)
        mean = around.sum(1) / count[:, None]
        inside = x + settings.weight * (mean - x)
        moved = jnp.where(sliding[:, None], _slide(x, along, mean, settings.weight), inside)
        return jnp.where(movable[:, None], moved, x)

    return jax.lax.fori_loop(0, settings.sweeps, sweep, x)


GUARD_HALVINGS = 4  # blends 1, 1/2, 1/4, 1/8, then 0


def rezone(
    tables: Tables,
    quads: q4.Quads,
    x: Array,
    movable: Array,
    along: Array,
    settings: Settings | None = None,
) -> Array:
    """f[N, 2]: the nodes ``x`` smoothed where ``movable``, guarded.

    Args:
      tables: ``tables(quads)``.
      quads: the mesh.
      x: f[N, 2], the nodes now.
      movable: bool[N], the nodes the rezone may move (the problem's region,
        without its pinned nodes: corners, tied pairs, crack tips).
      along: i32[N, 2], for a node on a boundary, its neighbours before and
        after it on its own boundary polyline, along whose two segments it
        slides; -1 -1 for a node inside the mesh.
      settings: the weight, the sweeps and the guard's floor (None: ``Settings()``).

    The smoothing: each sweep moves a node inside the mesh ``weight`` of the way
    to its edge neighbours' mean, and a node on a boundary ``weight`` of that
    move's part along the boundary, along the polyline through its two boundary
    neighbours, so that the boundary keeps its shape.

    The guard: no element the rezone touches ends below the smaller of its own
    ``quality`` and ``settings.floor``, nor below the smaller of its own area
    over its area on the reference mesh (``quads.nodes``) and ``settings.floor``:
    a rezone neither makes a sliver nor squeezes an element towards erosion.
    Each node moves a blend ``1, 1/2, 1/4, 1/8`` or ``0`` of the way to its
    smoothed place, the largest for which its elements pass. The nodes of an
    element that still fails are held (blend 0), and again until no element
    fails: holding a node can make a neighbouring element fail, whose nodes are
    then held in turn, so one bad element holds only the nodes around it and
    every other node still moves. It ends, as each pass holds at least one more
    node and an element of held nodes does not fail. So a folded element is never
    made, and the least quality never falls. The blends are chosen on values
    without gradient: a gradient through a rezone is that of the chosen blends.
    """
    settings = Settings() if settings is None else settings
    target = _smoothed(tables, x, movable, along, settings)
    start, goal = jax.lax.stop_gradient(x), jax.lax.stop_gradient(target)
    reference = areas(quads, quads.nodes)

    def measures(x):
        return quality(quads, x), areas(quads, x) / reference

    touched = movable[quads.quads].any(1)
    floors = [jnp.minimum(before, settings.floor) for before in measures(start)]

    def failing(blend):
        # An element whose nodes are all held does not fail: its measures, taken
        # again in another program, may differ from its floors in the last bit,
        # and the holding below must end.
        moved = (blend[quads.quads] > 0).any(1)
        after = measures(start + blend[:, None] * (goal - start))
        worse = [now < floor for now, floor in zip(after, floors, strict=True)]
        return touched & moved & (worse[0] | worse[1])

    def mark(fail):
        """bool[N]: nodes of a failing element."""
        flagged = jnp.zeros(x.shape[0], jnp.int32)
        return flagged.at[quads.quads].add(fail[:, None].astype(jnp.int32)) > 0

    def halve(_, blend):
        return jnp.where(mark(failing(blend)), 0.5 * blend, blend)

    def hold(blend):
        return jnp.where(mark(failing(blend)), 0, blend)

    blend = jax.lax.fori_loop(0, GUARD_HALVINGS, halve, jnp.ones(x.shape[0], x.dtype))
    blend = jax.lax.while_loop(lambda blend: jnp.any(failing(blend)), hold, blend)
    blend = jax.lax.stop_gradient(blend)
    return x + blend[:, None] * (target - x)


# -- the remap ----------------------------------------------------------------------


def areas(quads: q4.Quads, x: Array) -> Array:
    """f[E]: each element's area on ``x`` (the shoelace formula)."""
    c = x[quads.quads]
    nxt = jnp.roll(c, -1, axis=1)
    return 0.5 * jnp.sum(c[..., 0] * nxt[..., 1] - nxt[..., 0] * c[..., 1], axis=1)


def swept(tables: Tables, x_old: Array, x_new: Array) -> Array:
    """f[F]: the area each face sweeps from ``x_old`` to ``x_new``, positive
    where it moves into its ``left`` element (which shrinks by as much)."""
    a0, b0 = x_old[tables.faces[:, 0]], x_old[tables.faces[:, 1]]
    a1, b1 = x_new[tables.faces[:, 0]], x_new[tables.faces[:, 1]]
    # The shoelace formula of a0 b0 b1 a1 by its diagonals: half the cross
    # product of (b1 - a0) and (a1 - b0).
    d1, d2 = b1 - a0, a1 - b0
    return 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def _van_leer(below: Array, above: Array) -> Array:
    """The van Leer (harmonic) limited difference: 0 unless both agree in sign."""
    product = below * above
    total = jnp.abs(below) + jnp.abs(above)
    agree = product > 0
    return jnp.where(agree, 2 * product / jnp.where(agree, total, 1), 0)


def _differences(tables: Tables, value: Array) -> Array:
    """f[E, 4, ...]: each element's van Leer limited difference through each of
    its faces, from the element across the opposite face to the one across it
    (0 where either is missing)."""
    across = tables.across
    present = (across >= 0) & (jnp.roll(across, 2, axis=1) >= 0)
    mine = value[:, None]
    ahead = value[jnp.maximum(across, 0)]
    behind = value[jnp.maximum(jnp.roll(across, 2, axis=1), 0)]
    shape = present.shape + (1,) * (value.ndim - 1)
    return jnp.where(present.reshape(shape), _van_leer(mine - behind, ahead - mine), 0)


def remap(
    tables: Tables,
    quads: q4.Quads,
    x_old: Array,
    x_new: Array,
    mass: Array,
    fields,
    *,
    order: int = 2,
):
    """The element state carried from the mesh on ``x_old`` to the mesh on ``x_new``.

    Args:
      tables: ``tables(quads)``.
      quads: the mesh (its connectivity).
      x_old: f[N, 2], the nodes before the rezone.
      x_new: f[N, 2], the nodes after it.
      mass: f[E], each element's mass (any unit).
      fields: a pytree of f[E, ...], values per unit mass (specific: a stress,
        a plastic strain, a temperature), one per element.
      order: 2, van Leer; 1, the donor cell.

    Returns:
      ``(mass, fields)`` on the new mesh: the mass and each ``field * mass``
      conserved (to round-off) over the mesh.
    """
    if order not in (1, 2):
        raise ValueError(f"remap's order must be 1 (donor cell) or 2 (van Leer); got {order!r}")
    num = mass.shape[0]
    old_area = areas(quads, x_old)
    density = mass / old_area
    sweep = swept(tables, x_old, x_new)
    inner = tables.right >= 0
    # Flux from left into right (positive: left is the donor).
    flux = jnp.where(inner, sweep, 0)
    donor_left = flux > 0
    donor = jnp.where(donor_left, tables.left, jnp.maximum(tables.right, 0))
    side = jnp.where(donor_left, tables.left_side, tables.right_side)
    share = jnp.abs(flux) / jnp.abs(old_area[donor])

    def at_face(value):
        """The donor's value on each face: its own, plus (order 2) half its
        limited difference through that face, less the share it sweeps."""
        face = value[donor]
        if order == 1:
            return face
        difference = _differences(tables, value)[donor, side]
        weight = (0.5 * (1 - jnp.minimum(share, 1))).reshape((-1,) + (1,) * (value.ndim - 1))
        return face + weight * difference

    def exchange(per_face):
        """f[E, ...]: what each element gains from the faces' transfers."""
        into_right = jax.ops.segment_sum(per_face, jnp.maximum(tables.right, 0), num)
        out_of_left = jax.ops.segment_sum(per_face, tables.left, num)
        return into_right - out_of_left

    moved_mass = at_face(density) * flux
    new_mass = mass + exchange(moved_mass)

    def carry(value):
        shape = (-1,) + (1,) * (value.ndim - 1)
        gained = exchange(at_face(value) * moved_mass.reshape(shape))
        return (value * mass.reshape(shape) + gained) / new_mass.reshape(shape)

    return new_mass, jax.tree.map(carry, fields)


def remap_points(
    tables: Tables,
    quads: q4.Quads,
    x_old: Array,
    x_new: Array,
    mass: Array,
    points: materials.PointState,
    *,
    order: int = 2,
) -> tuple[Array, materials.PointState]:
    """``remap`` of the Gauss points' state (``PointState`` of f[E, 4, ...]):
    each element's mean over its points is remapped, and each point keeps its
    deviation from the mean."""
    mean = jax.tree.map(lambda value: value.mean(axis=1), points)
    new_mass, new_mean = remap(tables, quads, x_old, x_new, mass, mean, order=order)
    moved = jax.tree.map(
        lambda value, was, now: value + jnp.expand_dims(now - was, 1), points, mean, new_mean
    )
    return new_mass, moved


NEWTON = 4  # iterations inverting the bilinear map: the moves are a small share of an element


def remap_velocity(tables: Tables, quads: q4.Quads, x_old: Array, x_new: Array, v: Array) -> Array:
    """f[N, 2]: the velocity field of the mesh on ``x_old`` (bilinear in each
    element) at the nodes' new places ``x_new``: in each of the node's elements
    the local coordinates are found by Newton's method from the node's own corner,
    and the element the new place is least outside of gives the value."""
    element = jnp.maximum(tables.elements, 0)  # [N, C]
    corners = x_old[quads.quads][element]  # [N, C, 4, 2]
    speeds = v[quads.quads][element]
    signs = jnp.asarray(q4.CORNERS, x_old.dtype)  # [4, 2]
    start = signs[tables.corner.clip(0)]  # [N, C, 2]
    sign_s, sign_t = signs[None, None, :, 0], signs[None, None, :, 1]  # [1, 1, 4]
    target = x_new[:, None, :]

    def shape(xi):
        s, t = xi[..., 0:1], xi[..., 1:2]
        return 0.25 * (1 + s * sign_s) * (1 + t * sign_t)  # [N, C, 4]

    def newton(_, xi):
        s, t = xi[..., 0:1], xi[..., 1:2]
        d_s = 0.25 * sign_s * (1 + t * sign_t)
        d_t = 0.25 * sign_t * (1 + s * sign_s)
        at = jnp.einsum("...a,...ar->...r", shape(xi), corners)
        j_s = jnp.einsum("...a,...ar->...r", d_s, corners)  # dx/ds
        j_t = jnp.einsum("...a,...ar->...r", d_t, corners)
        det = j_s[..., 0] * j_t[..., 1] - j_s[..., 1] * j_t[..., 0]
        det = jnp.where(jnp.abs(det) > 0, det, 1)
        r = target - at
        ds = (j_t[..., 1] * r[..., 0] - j_t[..., 0] * r[..., 1]) / det
        dt = (-j_s[..., 1] * r[..., 0] + j_s[..., 0] * r[..., 1]) / det
        return xi + jnp.stack([ds, dt], -1)

    xi = jax.lax.fori_loop(0, NEWTON, newton, start)
    outside = jnp.max(jnp.abs(xi), -1) - 1
    outside = jnp.where(tables.elements >= 0, outside, jnp.inf)
    best = jnp.argmin(jax.lax.stop_gradient(outside), axis=1)
    value = jnp.einsum("nca,ncar->ncr", shape(xi), speeds)
    return jnp.take_along_axis(value, best[:, None, None], axis=1)[:, 0]


# -- the schedule -------------------------------------------------------------------


def cycles(
    step: Callable, adapt: Callable, carry, *, length: int, every: int
) -> tuple[object, object]:
    """``length`` steps of ``step`` (``carry -> (carry, record)``), ``adapt``
    (``carry -> carry``: a rezone and remap) after every ``every`` of them:
    a ``lax.scan`` of ``length / every`` cycles, each a ``lax.scan`` of
    ``every`` steps then ``adapt``. Returns ``(carry, records)``, one record
    row per step, as ``lax.scan`` of ``step`` alone would."""
    if every < 1 or length % every:
        raise ValueError(
            f"cycles' length must be a multiple of every (>= 1); got length={length}, every={every}"
        )

    def cycle(carry, _):
        carry, records = jax.lax.scan(lambda c, _: step(c), carry, None, length=every)
        return adapt(carry), records

    carry, records = jax.lax.scan(cycle, carry, None, length=length // every)
    return carry, jax.tree.map(lambda r: r.reshape((length,) + r.shape[2:]), records)
