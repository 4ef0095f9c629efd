"""The contact coupling of an explicit run: what a ``jaxcontact.Search`` found, as nodal forces.

Three choices every explicit contact code makes, each an option here:

* **The penalty's stiffness.** ``mass_penalty``: ``k_i = factor m_i / dt²``,
  the form of LS-DYNA's soft-constraint penalty (Hallquist, *LS-DYNA Theory
  Manual*, 2006, the contact chapter): a node's contact spring is as stiff as its
  mass allows in the explicit step, so it stays stable whatever the node's
  mass and whatever the mass scaling (``m / dt²`` scales out). Stable for a
  factor below about 1.
* **The friction law** (``Coulomb`` or ``Zorev``), turned into a coefficient
  per node (``Zorev``'s limit is a traction: each node carries it over its
  tributary length on its own outline, ``tributary``) and handed to
  ``jaxcontact.forces.coulomb`` with the slip history (``friction_forces``).
  ``forces.coulomb`` is the way to compute friction forces;
  ``friction_forces`` is the simulation parts' use of it, for a law whose
  coefficient depends on the normal force.
* **The penetration guards** of a body against its own outline
  (``guard``): a contact at an open end of the outline (a crack tip: the
  node's closest point is that end, and which side it lies on is
  rounding), and a contact deeper than ``depth`` (LS-DYNA's PENMAX: a node
  found that deep "inside" is on the inner side of a face it never went
  through), are left out and counted.

Units: forces in N per mm of thickness, lengths in mm, stresses in MPa.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
from jax import Array

from jaxcontact import Contact, Slip, Surface
from jaxcontact.forces import Forces, Friction, coulomb, penalty

__all__ = [
    "Coulomb",
    "Guarded",
    "Zorev",
    "friction_forces",
    "guard",
    "mass_penalty",
    "own_forces",
    "tributary",
]


def mass_penalty(mass: Array, dt, factor: float) -> Array:
    """f[N]: each node's penalty stiffness ``factor m_i / dt²`` (N/mm per mm of thickness)."""
    return factor * mass / dt**2


class Coulomb(NamedTuple):
    """Coulomb's law: the friction force is ``mu`` times the normal force."""

    mu: float | Array

    def coefficient(self, normal: Array) -> Array:
        """f[N]: the coefficient each node's normal force ``normal`` (N/mm) gets."""
        return jnp.broadcast_to(jnp.asarray(self.mu, normal.dtype), normal.shape)


class Zorev(NamedTuple):
    """Sticking and sliding after Zorev (1963): the friction stress is Coulomb's
    ``mu p`` where that is below ``limit`` and ``limit`` where it is not, the
    sticking zone near a cutting edge.

    Zorev, N. N. (1963), "Inter-relationship between shear processes
    occurring along tool face and shear plane in metal cutting", *Int.
    Research in Production Engineering*, ASME, 42-49. The limit is the shear
    factor times the chip's shear flow stress, ``m k`` (Shirakashi and Usui,
    1973; the form Özel, 2006, *Int. J. Mach. Tools Manuf.* 46, 518-530,
    compares with others).

    The limit is a traction: node ``i`` carries it over its tributary
    length ``share[i]``, so its friction force is capped at ``limit *
    share[i]`` (N/mm), and over a contact at the cap the friction forces sum
    to ``limit`` times the contact's length whatever the node spacing. The
    share is a length of the slave's outline, not of the master's: the
    nodes that press are the slave's (``tributary`` measures it, each step,
    since the outline stretches). One length for every node (a scalar) is a
    traction only where the nodes are that far apart: on a chip's
    underside, compressed to about half its elements' length, a share of
    one element doubles the traction.

    Attributes:
      mu: the sliding coefficient.
      limit: the friction stress in sticking (MPa), scalar or f[N].
      share: each node's tributary length on its own outline (mm), f[N]
        (``tributary``) or a scalar for all: its force limit is
        ``limit * share`` (N/mm).

    Example:
      >>> import jax.numpy as jnp
      >>> import jaxcontact
      >>> from jaxcontact.sim import coupling
      >>> line = jaxcontact.Surface(
      ...     jnp.asarray([[0.0, 0.0], [0.01, 0.0], [0.03, 0.0]]), jnp.asarray([[0, 1], [1, 2]])
      ... )
      >>> law = coupling.Zorev(mu=0.3, limit=200.0, share=coupling.tributary(line))
      >>> [round(length, 6) for length in law.share.tolist()]  # mm
      [0.005, 0.015, 0.01]
    """

    mu: float | Array
    limit: float | Array
    share: float | Array

    def coefficient(self, normal: Array) -> Array:
        cap = jnp.asarray(self.limit, normal.dtype) * jnp.asarray(self.share, normal.dtype)
        mu = jnp.asarray(self.mu, normal.dtype)
        sticking = normal * mu > cap
        return jnp.where(sticking, cap / jnp.where(normal > 0, normal, 1), mu)


def tributary(outline: Surface) -> Array:
    """f[P]: each node's tributary length on ``outline`` (mm): half the summed lengths of
    the real segments at it (half the distance to each of its neighbours along the
    outline), ``0`` for a node on none.

    ``Zorev``'s ``share``: pass the slave body's own outline, as it is now
    (its nodes are the slaves' rows), so that ``Zorev.limit`` is a
    traction. An open end's node gets half its one segment. Differentiable
    in the node positions; a segment of zero length adds zero (and a zero
    gradient).

    Args:
      outline: the slave body's outline (``nodes`` f[P, 2], its segments;
        masked segments add nothing).
    """
    nodes, segments = outline.nodes, jnp.maximum(outline.segments, 0)
    squared = jnp.sum((nodes[segments[:, 1]] - nodes[segments[:, 0]]) ** 2, -1)
    real = squared > 0
    if outline.mask is not None:
        real = real & outline.mask
    half = jnp.where(real, 0.5 * jnp.sqrt(jnp.where(real, squared, 1)), 0)
    share = jnp.zeros(nodes.shape[0], nodes.dtype).at[segments[:, 0]].add(half)
    return share.at[segments[:, 1]].add(half)


def friction_forces(
    contact: Contact,
    slip: Slip,
    friction: Friction,
    surface: Surface,
    stiffness: Array,
    law: Coulomb | Zorev,
) -> tuple[Forces, Friction]:
    """The penalty and the friction of ``law`` on a tracked contact, for an explicit run
    built from these parts.

    A part for one job: a friction law whose coefficient depends on each
    node's normal force (``Zorev``'s sticking limit), with the stick spring
    as stiff as the normal one (the mass penalty's ``stiffness``, so both
    stay within the explicit step's stability). It is
    ``jaxcontact.forces.coulomb(contact, slip, friction, surface,
    stiffness=stiffness, tangent_stiffness=stiffness, mu=law.coefficient(f_n))``
    with ``f_n = stiffness * -gap`` on active rows. For Coulomb friction with
    a fixed coefficient, or a stick stiffness of your own, call
    ``forces.coulomb``, the documented way (docs/guides/friction.md).

    Args:
      contact: this step's ``Contact`` (N rows), from a ``Search(track=True)``.
      slip: ``state.slip`` of that search's state.
      friction: the last step's ``Friction`` (``Friction.zeros(N)`` at the start).
      surface: the master now.
      stiffness: the normal and stick stiffness, f[N] (``mass_penalty``) or a scalar.
      law: ``Coulomb`` or ``Zorev``.

    Returns:
      ``(forces, friction)``, as ``forces.coulomb`` returns them.
    """
    normal = jnp.where(contact.active, stiffness * -contact.gap, 0)
    mu = law.coefficient(normal)
    return coulomb(
        contact, slip, friction, surface, stiffness=stiffness, tangent_stiffness=stiffness, mu=mu
    )


class Guarded(NamedTuple):
    """A contact with the guards applied, and what they left out."""

    contact: Contact  # its ``active`` without the open ends and the deep contacts
    open_end: Array  # bool[N]  closest to an open end of the outline
    deep: Array  # bool[N]  deeper than the depth limit


def guard(contact: Contact, surface: Surface, depth: float | None = None) -> Guarded:
    """Leaves out a body's contacts on its own outline that are not contacts.

    ``depth`` (mm; None: no limit) is the deepest a real contact can be.
    An open end is a vertex of one real segment of ``surface``.
    """
    nodes = surface.nodes.shape[0]
    mask = jnp.ones(surface.segments.shape[0], bool) if surface.mask is None else surface.mask
    ends = jnp.zeros(nodes, jnp.int32).at[surface.segments].add(mask[:, None].astype(jnp.int32))
    open_end = (contact.vertex >= 0) & (ends[jnp.maximum(contact.vertex, 0)] == 1)
    if depth is None:
        deep = jnp.zeros_like(contact.active)
    else:
        deep = contact.active & (-contact.gap > depth)
    active = contact.active & ~open_end & ~deep
    return Guarded(contact._replace(active=active), open_end, deep)


def own_forces(contact: Contact, surface: Surface, stiffness: Array, slaves: Array) -> Array:
    """f[N, 2]: the frictionless penalty (``forces.penalty``, ``stiffness`` scalar or
    f[S]) of a body on its own outline, both sides summed onto its N nodes: the
    outline's nodes are the body's, and the contact's rows are the nodes ``slaves``
    (i32[S])."""
    forces = penalty(contact, surface, stiffness)
    return forces.on_master.at[slaves].add(forces.on_slaves)
