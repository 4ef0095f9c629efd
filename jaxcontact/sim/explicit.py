"""Explicit central differences for the Q4 workpiece (``solid``), contact forces given.

One step of the scheme explicit crash and cutting codes use (Belytschko,
Liu and Moran, *Nonlinear Finite Elements for Continua and Structures*,
2000, section 6.2): accelerations from the forces at ``x_n``, velocities at
the half step, positions at ``n + 1``, then the material updated over the
motion ``x_n -> x_{n+1}``. Stable for ``dt`` below ``stable_dt`` (the
smallest element's edge over the dilatational wave speed, times a safety
factor). Boundary conditions: prescribed velocity components
(``fixed``, with their values) replace the computed ones.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
from jax import Array

from jaxcontact.sim import plasticity, solid


class Body(NamedTuple):
    """The workpiece's state between steps."""

    x: Array  # f[N, 2]  positions (mm)
    v: Array  # f[N, 2]  velocities at the last half step (mm/s)
    points: plasticity.PointState  # [E, 4] Gauss points


def at_rest(quads: solid.Quads, material: plasticity.JohnsonCook) -> Body:
    """The mesh unstressed and at rest at room temperature."""
    dtype = quads.nodes.dtype
    points = plasticity.PointState.at_rest((quads.quads.shape[0], 4), material, dtype)
    return Body(quads.nodes, jnp.zeros_like(quads.nodes), points)


def stable_dt(quads: solid.Quads, material: plasticity.JohnsonCook, safety: float = 0.5) -> float:
    """A stable step (s) on the reference mesh: shortest edge / wave speed x ``safety``."""
    corners = quads.nodes[quads.quads]
    edges = jnp.linalg.norm(corners - jnp.roll(corners, 1, axis=1), axis=-1)
    modulus = material.bulk_modulus + 4 * material.shear_modulus / 3
    return safety * float(edges.min()) / math.sqrt(modulus / material.density)


def step(
    material,
    quads: solid.Quads,
    body: Body,
    external: Array,
    dt,
    fixed: Array | None = None,
    velocity: Array | None = None,
    partner: Array | None = None,
    alive: Array | None = None,
    viscosity: tuple[float, float] | None = None,
) -> tuple[Body, Array]:
    """One explicit step under the ``external`` nodal forces (f[N, 2], N per mm).

    ``fixed`` (bool[N, 2]) marks velocity components prescribed to
    ``velocity`` (f[N, 2], zeros by default). ``partner`` (i32[N]) ties
    nodes in pairs: node ``i`` and ``partner[i]`` (``i`` itself for an
    untied node) move as one node, their forces and masses summed, so two
    coincident nodes stay together until the tie is dropped (the node
    separation of a cutting run). ``alive`` (bool[E]) marks the elements
    not eroded: an eroded one carries no stress and keeps its state.
    ``viscosity`` ``(linear, quadratic)`` adds ``solid.bulk_viscosity``
    (LS-DYNA's defaults are 0.06 and 1.5). Returns
    the new ``Body`` and the step's plastic strain increments (f[E, 4]).
    """
    pressure = None
    if viscosity is not None:
        modulus = material.bulk_modulus + 4 * material.shear_modulus / 3
        wave = (modulus / material.density) ** 0.5
        pressure = solid.bulk_viscosity(quads, body.x, body.v, material.density, wave, *viscosity)
    forces = solid.internal_forces(quads, body.x, body.points.stress, alive, pressure) + external
    mass = quads.mass
    if partner is not None:
        # Summed in the same order for both nodes of a pair: they get the
        # same bits, so tied nodes never drift apart.
        tied = partner != jnp.arange(partner.shape[0])
        low = jnp.minimum(jnp.arange(partner.shape[0]), partner)
        high = jnp.maximum(jnp.arange(partner.shape[0]), partner)
        forces = jnp.where(tied[:, None], forces[low] + forces[high], forces)
        mass = jnp.where(tied, mass[low] + mass[high], mass)
    v = body.v + dt * forces / mass[:, None]
    if fixed is not None:
        given = jnp.zeros_like(v) if velocity is None else velocity
        v = jnp.where(fixed, given, v)
    x = body.x + dt * v
    points, plastic = solid.step_material(material, quads, body.points, body.x, x, dt, alive)
    return Body(x, v, points), plastic
