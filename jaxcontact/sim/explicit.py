"""Explicit central differences on a Q4 mesh (``elements.q4``), the external forces given.

One step of the scheme explicit crash and forming codes use (Belytschko,
Liu and Moran, *Nonlinear Finite Elements for Continua and Structures*,
2000, section 6.2): accelerations from the forces at ``x_n``, velocities at
the half step, positions at ``n + 1``, then the material updated over the
motion ``x_n -> x_{n+1}``. Stable for ``dt`` below ``stable_dt`` (the
smallest element's edge over the dilatational wave speed, times a safety
factor).

What holds the nodes is a ``Boundary``: prescribed velocity components,
and ties that make two nodes move as one (tied contact; node separation
unties them). Elements can be taken out (``alive``: erosion), and a bulk
viscosity damps the ringing of shocks. The material is any
``materials.Material``.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
from jax import Array

from jaxcontact import _removed
from jaxcontact.sim import materials
from jaxcontact.sim.elements import q4

__all__ = ["Body", "Boundary", "at_rest", "stable_dt", "step"]


class Body(NamedTuple):
    """A deforming body's state between steps."""

    x: Array  # f[N, 2]  positions (mm)
    v: Array  # f[N, 2]  velocities at the last half step (mm/s)
    points: materials.PointState  # [E, 4] Gauss points


class Boundary(NamedTuple):
    """What holds the nodes in a step; None leaves a node free of that constraint."""

    fixed: Array | None = None  # bool[N, 2]  velocity components prescribed
    velocity: Array | None = None  # f[N, 2]  their values (mm/s; zeros by default)
    ties: Array | None = None  # i32[N]  the node each moves with (itself: untied)


def at_rest(quads: q4.Quads, material: materials.Material) -> Body:
    """The mesh unstressed and at rest at the material's room temperature."""
    dtype = quads.nodes.dtype
    points = materials.PointState.at_rest((quads.quads.shape[0], 4), material, dtype)
    return Body(quads.nodes, jnp.zeros_like(quads.nodes), points)


def stable_dt(quads: q4.Quads, material: materials.Material, safety: float = 0.5) -> float:
    """A stable step (s) on the reference mesh: shortest edge / wave speed x ``safety``."""
    corners = quads.nodes[quads.quads]
    edges = jnp.linalg.norm(corners - jnp.roll(corners, 1, axis=1), axis=-1)
    return safety * float(edges.min()) / materials.wave_speed(material)


def _tied(ties: Array, forces: Array, mass: Array) -> tuple[Array, Array]:
    """Forces and masses of tied nodes summed, each pair's in one order for both nodes:
    they get the same bits, so tied nodes never drift apart."""
    index = jnp.arange(ties.shape[0])
    tied = ties != index
    low, high = jnp.minimum(index, ties), jnp.maximum(index, ties)
    forces = jnp.where(tied[:, None], forces[low] + forces[high], forces)
    return forces, jnp.where(tied, mass[low] + mass[high], mass)


def step(
    material: materials.Material,
    quads: q4.Quads,
    body: Body,
    external: Array,
    dt,
    boundary: Boundary | None = None,
    *,
    alive: Array | None = None,
    viscosity: tuple[float, float] | None = None,
    **removed,
) -> tuple[Body, Array]:
    """One explicit step under the ``external`` nodal forces (f[N, 2], N per mm).

    Args:
      material: the workpiece's ``materials.Material``.
      quads: the mesh (its masses lumped with the material's inertial density).
      body: the state at the step's start.
      external: f[N, 2], the contact and other applied forces.
      dt: the step (s).
      boundary: the prescribed velocities and the ties (None: all free).
      alive: bool[E], the elements not eroded: an eroded one carries no
        stress and keeps its state. None: all.
      viscosity: ``(linear, quadratic)`` bulk viscosity coefficients
        (``q4.bulk_viscosity``; LS-DYNA's defaults are 0.06 and 1.5). None: none.
      **removed: none taken: a keyword this function no longer takes
        (``fixed=``, ``velocity=``, ``partner=``) raises a ``TypeError`` that
        names what replaces it.

    Returns:
      The new ``Body`` and the step's plastic strain increments (f[E, 4]).
    """
    if removed:
        _removed.refuse(f"{__name__}.step", removed)
    if boundary is None:
        boundary = Boundary()
    elif not isinstance(boundary, Boundary):
        # An array here is a ``fixed`` passed where the boundary goes.
        raise TypeError(
            "explicit.step's boundary must be an explicit.Boundary (fixed, velocity, ties) "
            f"or None; got {type(boundary).__name__}"
        )
    if boundary.velocity is not None and boundary.fixed is None:
        raise ValueError(
            "explicit.Boundary.velocity prescribes the components fixed marks: "
            "got a velocity with fixed=None"
        )
    pressure = None
    if viscosity is not None:
        pressure = q4.bulk_viscosity(
            quads,
            body.x,
            body.v,
            materials.inertial_density(material),
            materials.wave_speed(material),
            *viscosity,
        )
    forces = q4.internal_forces(quads, body.x, body.points.stress, alive, pressure) + external
    mass = quads.mass
    if boundary.ties is not None:
        forces, mass = _tied(boundary.ties, forces, mass)
    v = body.v + dt * forces / mass[:, None]
    if boundary.fixed is not None:
        given = jnp.zeros_like(v) if boundary.velocity is None else boundary.velocity
        v = jnp.where(boundary.fixed, given, v)
    x = body.x + dt * v
    points, plastic = q4.step_material(material, quads, body.points, body.x, x, dt, alive)
    return Body(x, v, points), plastic
