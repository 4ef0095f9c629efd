"""Contact forces: a normal penalty and Coulomb friction, on slaves and master nodes.

Every function takes the result of a search (a ``Contact``, or a
``ContactList`` of the compact form) and returns a ``Forces``: the force on
each slave, and its reaction on the master's nodes, shared between the two
end nodes of the segment touched by the linear basis ``(1 - xi, xi)``. The
two sum to zero (action and reaction), and a deformable master gets nodal
forces to assemble. This module is the way to compute contact forces;
``jaxcontact.sim.coupling.friction_forces`` is ``coulomb`` behind the
simulation parts' friction laws (a coefficient set per node from the normal
force), a part for an explicit run built from them. Units are the caller's:
a stiffness in force per length (per unit thickness in plane strain, N/mm
per mm, say) times a gap in length.

**Normal penalty.** An active slave (``gap < 0``) is pushed out along the
contact normal with ``f_n = stiffness * (-gap)``. A node-to-segment penalty
needs the stiffness scaled with the slave's share of the contact length
(its tributary length) for a mesh-independent pressure: pass ``stiffness``
per slave (f[N]) to do so.

**Coulomb friction** (``coulomb``), by the return mapping of elasto-plastic
friction (Wriggers, *Computational Contact Mechanics*, 2nd ed., 2006,
section 5.2; Laursen, *Computational Contact and Impact Mechanics*, 2002):
the tangential force is an elastic "stick" spring of stiffness
``tangent_stiffness`` loaded by the slip since the last step
(``Search(track=True)``), capped at ``mu * f_n``:

    trial = t_last . t - tangent_stiffness * slip
    f_t   = trial                         if |trial| <= mu f_n   (stick)
            mu f_n sign(trial)            otherwise              (slip)

``t`` is the master's current unit tangent (the segment's direction, the
normal turned counter-clockwise), ``t_last`` last step's tangential force,
carried in ``Friction.traction`` in world coordinates and turned into the
current tangent by the projection. The history is zeroed only where the
slave is not in contact (``active``) now, and a contact that was not active
at the last step starts from zero (``Slip.persisted``). The scheme is
backward Euler in the slip, so it never creates energy: the work
``-f_t slip`` taken from the relative motion in a step is at least the
change of the stick spring's energy ``E = |traction|^2 / (2
tangent_stiffness)``. ``Friction.dissipated`` is what sliding dissipated,
``f_t (trial - f_t) / tangent_stiffness = mu f_n |s_p|`` with ``s_p`` the
sliding (not elastic) part of the slip: zero while a contact sticks, >= 0
always; the rest of the difference is the scheme's own numerical
dissipation and the energy of a traction turned onto a new tangent. The
tangential force on the slave opposes its slip relative to the master; the
master's nodes take its reaction.

**Two deformable bodies** searched both ways in one call (every node a
slave, every outline a master, ``Pairs(slave_body=...)``): each physical contact
is found twice, once from each side. ``two_pass=True`` weights both passes
by 1/2, the symmetric two-pass node-to-segment treatment (El-Abbasi and
Meguid, 1998; Zavarise and De Lorenzis, 2009), so each contact is counted
once and the result does not depend on which body is called the master.

What is left out: no damping, no rate-dependent or pressure-dependent
friction coefficient, no static/kinetic distinction (one ``mu``); the
penalty lets slaves penetrate by ``f_n / stiffness``.
"""

from __future__ import annotations

import functools
import inspect
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact._pipeline import inputs as _inputs
from jaxcontact._pipeline.placement import replicated
from jaxcontact._removed import listing as _listing
from jaxcontact._removed import missing as _missing
from jaxcontact._track import Slip
from jaxcontact._types import Array, Contact, ContactList, Surface

__all__ = ["Forces", "Friction", "coulomb", "penalty"]


class Forces(NamedTuple):
    """Forces of a contact step: on each slave, and on each master node (their sum is zero)."""

    on_slaves: Array  # f[N, 2]
    on_master: Array  # f[P, 2]  the reaction, shared by the segment's basis (1 - xi, xi)


class Friction(NamedTuple):
    """What Coulomb friction carries from step to step (a pytree for ``lax.scan``).

    Start with ``Friction.zeros(N)``. ``traction`` is the state;
    ``stuck`` and ``dissipated`` describe the step that produced it.
    ``coulomb`` returns it in the wider of its own float dtype and the
    slaves', so a ``lax.scan`` carries one dtype from ``Friction.zeros(N)``
    (JAX's default float) or from ``Friction.zeros(N, x.dtype)``.
    """

    traction: Array  # f[N, 2]  tangential force on each slave at the last step, world coordinates
    stuck: Array  # bool[N]  in contact and sticking (not slipping)
    dissipated: Array  # f[N]  energy dissipated by sliding in the step: mu f_n |s_p| >= 0

    @staticmethod
    def zeros(num_slaves: int, dtype=None) -> Friction:
        """No history: nothing in contact yet.

        ``dtype`` None is JAX's default float (float64 with ``jax_enable_x64``).
        A narrower one than the slaves' (float32 for float64 slaves) makes
        ``coulomb`` return a wider state than it was given, which a
        ``lax.scan`` carry refuses: leave it None, or pass ``x.dtype``.
        """
        return Friction(
            jnp.zeros((num_slaves, 2), dtype),
            jnp.zeros((num_slaves,), bool),
            jnp.zeros((num_slaves,), dtype),
        )


class _Entries(NamedTuple):
    """A ``Contact`` or ``ContactList`` seen as K entries of slave rows."""

    row: Array  # i32[K]  the slave of each entry; N where none
    gap: Array
    xi: Array
    segment: Array
    normal: Array
    active: Array
    dense: bool  # the entries are the N rows of a Contact, in order


def _entries(contact, num_slaves: int | None) -> tuple[_Entries, int]:
    if isinstance(contact, ContactList):
        if num_slaves is None:
            raise ValueError("num_slaves= is needed with a ContactList (the N of its slaves)")
        row = contact.node
    elif isinstance(contact, Contact):
        num_slaves = contact.gap.shape[0]
        row = jnp.arange(num_slaves, dtype=jnp.int32)
    else:
        raise ValueError(f"contact must be a Contact or ContactList; got {type(contact).__name__}")
    _inputs.check_2d_result("contact", contact)
    active = contact.active & (contact.segment >= 0)
    entries = _Entries(
        row,
        contact.gap,
        contact.xi,
        contact.segment,
        contact.normal,
        active,
        isinstance(contact, Contact),
    )
    return entries, num_slaves


def _per_entry(name: str, values, entries: _Entries, num_slaves: int, dtype) -> Array:
    """A scalar or f[N] (one per slave) read at each entry's slave."""
    values = jnp.asarray(values, dtype)
    if values.ndim == 0:
        return jnp.broadcast_to(values, entries.row.shape)
    if values.shape != (num_slaves,):
        raise ValueError(
            f"{name} must be a scalar or have shape ({num_slaves},) (one per slave); "
            f"got shape {values.shape}"
        )
    return values.at[entries.row].get(mode="fill", fill_value=0)


def _assemble(entries: _Entries, force: Array, surface: Surface, num_slaves: int) -> Forces:
    """Entry forces on the slaves, and their reaction on the master's nodes."""
    force = jnp.where(entries.active[:, None], force, 0)
    if entries.dense:  # one entry per slave, in order: no scatter
        on_slaves = force
    else:
        on_slaves = jnp.zeros((num_slaves, 2), force.dtype).at[entries.row].add(force, mode="drop")
    num_nodes = surface.nodes.shape[0]
    if surface.segments.shape[0] == 0:
        return Forces(on_slaves, jnp.zeros((num_nodes, 2), force.dtype))
    ends = surface.segments[jnp.clip(entries.segment, 0, surface.segments.shape[0] - 1)]
    ends = jnp.where(entries.active[:, None], ends, num_nodes)  # dropped by the scatter
    xi = entries.xi[:, None]
    on_master = jnp.zeros((num_nodes, 2), force.dtype)
    on_master = on_master.at[ends[:, 0]].add(-(1 - xi) * force, mode="drop")
    on_master = on_master.at[ends[:, 1]].add(-xi * force, mode="drop")
    return Forces(on_slaves, on_master)


def _weight(two_pass: bool) -> float:
    if not isinstance(two_pass, bool):
        raise ValueError(f"two_pass must be a bool; got {two_pass!r}")
    return 0.5 if two_pass else 1.0


def _non_negative(name: str, value, strictly: bool = False):
    """A ``ValueError`` naming it when ``value`` is concrete and negative (zero, ``strictly``)."""
    if any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(value)):
        return
    values = np.asarray(value)
    bad = values <= 0 if strictly else values < 0
    if values.size and bool(np.any(bad | ~np.isfinite(values))):
        bound = "> 0" if strictly else ">= 0"
        raise ValueError(f"{name} must be finite and {bound}; got {value!r}")


def _signed(**strictly: bool):
    """Wraps a jitted force function: before the call, each argument named in
    ``strictly`` is checked by ``_non_negative`` (> 0 where True, >= 0 where
    False). Outside ``jit``: a traced value has no sign to check."""

    def wrap(jitted):
        signature = inspect.signature(jitted)

        @functools.wraps(jitted)
        def checked(*args, **kwargs):
            arguments = signature.bind(*args, **kwargs).arguments
            for name, strict in strictly.items():
                _non_negative(name, arguments[name], strict)
            return jitted(*args, **kwargs)

        return checked

    return wrap


@_signed(stiffness=False)
@functools.partial(jax.jit, static_argnames=("num_slaves", "two_pass", "axis_name"))
def penalty(
    contact: Contact | ContactList,
    surface: Surface,
    stiffness,
    *,
    num_slaves: int | None = None,
    two_pass: bool = False,
    axis_name: str | None = None,
) -> Forces:
    """The normal penalty force on each active slave and its reaction on the master's nodes.

    Args:
      contact: a ``Contact``, or a ``ContactList`` with ``num_slaves``.
      surface: the master the contact was found on (its node indices place the reaction).
      stiffness: force per unit penetration, a scalar or f[N] per slave,
        finite and >= 0 (a negative one would pull the slaves in). A
        ``ValueError`` names it when it is concrete; a traced value (under
        the caller's ``jit``, ``grad`` or ``vmap``) cannot be checked.
      num_slaves: N, for a ``ContactList``.
      two_pass: weight each force by 1/2 (both bodies searched as slaves
        and masters in one call; see the module's notes).
      axis_name: inside ``jax.shard_map`` with the slaves split over this
        mesh axis, the master's reaction is summed over the devices (a
        ``psum``). Under ``jit`` with sharded inputs XLA inserts that
        collective itself.

    Returns:
      ``Forces``: ``on_slaves`` f[N, 2] is ``stiffness * (-gap) * normal``
      on active rows; ``on_master`` f[P, 2] their reaction, summing to
      minus their total.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, all_to_all
      >>> from jaxcontact.forces import penalty
      >>> floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]]), jnp.array([[0, 1]]))
      >>> contact = all_to_all(jnp.array([[0.25, -0.5]]), floor, radius=1.0)
      >>> forces = penalty(contact, floor, 10.0)
      >>> (forces.on_slaves + 0.0).tolist(), (forces.on_master + 0.0).tolist()  # no -0.0
      ([[0.0, 5.0]], [[0.0, -1.25], [0.0, -3.75]])
    """
    # A result split over explicit mesh axes (arrays sharded with jax.sharding)
    # is gathered: the reaction's scatter onto the master's nodes has no rule
    # for split rows.
    contact, surface, stiffness = replicated((contact, surface, stiffness))
    entries, num_slaves = _entries(contact, num_slaves)
    dtype = entries.gap.dtype
    stiffness = _per_entry("stiffness", stiffness, entries, num_slaves, dtype)
    depth = jnp.where(entries.active, -entries.gap, 0)
    force = (_weight(two_pass) * stiffness * depth)[:, None] * entries.normal
    forces = _assemble(entries, force, surface, num_slaves)
    if axis_name is not None:
        forces = forces._replace(on_master=jax.lax.psum(forces.on_master, axis_name))
    return forces


def _check_history(contact, slip, friction) -> None:
    """``coulomb``'s slip and friction: of their types, and of the contact's slaves."""
    if slip is None:
        raise ValueError(
            "slip is None: coulomb needs the slip history, state.slip of a "
            "jaxcontact.Search(track=True) (a Search without track=True keeps none), "
            "or jaxcontact.track(last, contact, surface)"
        )
    if not isinstance(slip, Slip):
        raise ValueError(
            "slip must be a jaxcontact.Slip (state.slip of a Search(track=True)); "
            f"got {type(slip).__name__}"
        )
    if not isinstance(friction, Friction):
        raise ValueError(
            "friction must be a jaxcontact.forces.Friction (Friction.zeros(N) at the start); "
            f"got {type(friction).__name__}"
        )
    num_slaves = slip.slip.shape[0]
    if isinstance(contact, Contact) and contact.gap.shape[0] != num_slaves:
        raise ValueError(
            f"contact has {contact.gap.shape[0]} rows; slip has {num_slaves}: "
            "they must be of the same slaves"
        )


@_signed(stiffness=False, tangent_stiffness=True, mu=False)
@functools.partial(jax.jit, static_argnames="two_pass")
def coulomb(
    contact: Contact | ContactList,
    slip: Slip,
    friction: Friction,
    surface: Surface,
    *,
    stiffness,
    tangent_stiffness,
    mu,
    two_pass: bool = False,
) -> tuple[Forces, Friction]:
    """Normal penalty and Coulomb friction forces of one step, and the friction state after it.

    The way to compute contact forces with friction. (The simulation parts'
    ``jaxcontact.sim.coupling.friction_forces`` is this function behind a
    friction law, Coulomb's or Zorev's, that sets ``mu`` per node from the
    normal force.) A ``ValueError`` names a coefficient out of range when it
    is concrete; a traced value (under the caller's ``jit``, ``grad`` or
    ``vmap``) cannot be checked.

    Args:
      contact: this step's ``Contact`` or ``ContactList`` (from a
        ``Search(track=True)``, or any detector and ``jaxcontact.track``).
      slip: the ``Slip`` of this step: ``state.slip`` of the state that
        ``Search(track=True).closest`` returned with ``contact``, or
        ``jaxcontact.track(last, contact, surface)`` after a detector. A
        ``Search`` without ``track=True`` keeps no slip (``state.slip`` is
        None): a ``ValueError`` says so.
      friction: the ``Friction`` of the last step (``Friction.zeros(N)`` at the start).
      surface: the master now.
      stiffness: normal penalty stiffness, scalar or f[N] (finite, >= 0).
      tangent_stiffness: the stick spring's stiffness, scalar or f[N] (finite, > 0).
      mu: the Coulomb coefficient, scalar or f[N] (finite, >= 0).
      two_pass: weight both forces by 1/2 (see the module's notes). The
        friction state holds the unweighted traction.

    Returns:
      ``(forces, friction)``: normal plus tangential ``Forces``, and the
      ``Friction`` to pass to the next step.
    """
    _check_history(contact, slip, friction)
    num_slaves = slip.slip.shape[0]
    if friction.traction.shape[:1] != (num_slaves,):
        raise ValueError(
            f"friction must hold {num_slaves} rows (one per slave, as slip); "
            f"got traction of shape {friction.traction.shape}"
        )
    entries, num_slaves = _entries(contact, num_slaves)
    dtype = entries.gap.dtype
    per_entry = {
        name: _per_entry(name, value, entries, num_slaves, dtype)
        for name, value in (
            ("stiffness", stiffness),
            ("tangent_stiffness", tangent_stiffness),
            ("mu", mu),
        )
    }
    k_n, k_t, mu = per_entry["stiffness"], per_entry["tangent_stiffness"], per_entry["mu"]
    row = entries.row
    active = entries.active
    normal = entries.normal
    tangent = jnp.stack([-normal[:, 1], normal[:, 0]], axis=-1)  # the segment's direction
    f_n = jnp.where(active, k_n * -entries.gap, 0)

    def read(values, fill):
        return values.at[row].get(mode="fill", fill_value=fill)

    persisted = read(slip.persisted, False) & active
    last = jnp.where(persisted[:, None], read(friction.traction, 0).astype(dtype), 0)
    slipped = jnp.where(persisted, read(slip.slip, 0).astype(dtype), 0)
    trial = jnp.sum(last * tangent, axis=-1) - k_t * slipped
    cap = mu * f_n
    stuck = jnp.abs(trial) <= cap
    f_t = jnp.where(stuck, trial, cap * jnp.sign(trial))
    f_t = jnp.where(active, f_t, 0)
    traction = f_t[:, None] * tangent
    # Energy dissipated by sliding this step: the force times the plastic
    # (sliding) part of the slip, s_p = (f_t - trial) / k_t, which is zero
    # while the contact sticks: mu f_n |s_p| = f_t (trial - f_t) / k_t >= 0.
    safe_k_t = jnp.where(k_t > 0, k_t, 1)
    dissipated = jnp.where(active, f_t * (trial - f_t) / safe_k_t, 0)

    weight = _weight(two_pass)
    force = weight * (f_n[:, None] * normal + traction)
    forces = _assemble(entries, force, surface, num_slaves)

    def spread(values, empty):
        base = jnp.full((num_slaves,) + values.shape[1:], empty, values.dtype)
        return base.at[row].set(values, mode="drop")

    # The state keeps the wider of its own float and the slaves': a scan's
    # carry keeps its dtype whether it started from Friction.zeros(N) (JAX's
    # default float) or in the slaves' dtype, and no precision is dropped.
    kept = jnp.promote_types(dtype, friction.traction.dtype)
    after = Friction(
        traction=spread(jnp.where(active[:, None], traction, 0).astype(kept), 0),
        stuck=spread(active & stuck, False),
        dissipated=spread(dissipated.astype(kept), 0),
    )
    return forces, after


# Old names fail naming their replacements (jaxcontact._removed); dir() lists the public ones.
__getattr__ = _missing(__name__)
__dir__ = _listing(__name__)
