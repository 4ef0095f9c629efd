"""A rigid tool ploughing an elastic workpiece: contact detection inside a JAX simulation.

The cutting scene of docs/scenes.md set in motion. The workpiece (``[0, 20] x [0, 5]``,
the scene's grid cut into linear triangles, plane strain, linear elastic
steel: E = 210,000 MPa, ν = 0.3, ρ = 7.85e-9 t/mm³; units mm, N, t, s) is
fixed along its bottom edge. The rigid tool (the scene's outline, its rake
angle a parameter) moves in ``-x`` at constant speed with its tip at height 4,
a depth of cut of 1. Every step:

1. the tool's outline at its current place (``tool_outline``, jnp, so the
   run is differentiable in the rake angle);
2. contact by ``Search.closest`` for the slaves (by default the nodes of the
   workpiece's free outline, which meet the tool before any interior node
   can; ``slaves="all"`` takes every node, as the cutting scene does),
   which reuses the candidates found within ``radius + skin`` and finds
   them again, inside the step, only when the nodes and the tool together
   moved more than the skin, as the paper recomputes ``d_max`` only every
   n-th step;
3. a penalty force ``k (-g) n`` on every active slave (``forces.penalty``) and
   the opposite, summed, on the tool: its x part is the cutting force, its y
   part the thrust force;
4. central differences with lumped masses and a little mass-proportional
   damping: ``v += dt a``, ``u += dt v``.

The whole run is one ``lax.scan`` under ``jit``; the search state's overflow
flag is OR-ed over the steps and checked on the host after the run.

What it is not: there is no material separation (no chip forms: the tool
ploughs and deforms the surface), no plasticity, no friction, no heat, and the
small-strain model is linear, so it is right only while the deformation stays
small. By default the density is scaled by 10⁴ (mass scaling): the waves run
100 times slower, a stable step is 100 times longer, and a run of a
realistic cutting speed (3 m/s = 180 m/min) takes a few hundred steps.
Because the tool then moves at 5 % of the (scaled) wave speed, the run is
dynamic, not quasi-static: the forces ring.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact import QuerySizes, Search, Surface
from jaxcontact.forces import penalty
from jaxcontact.problems.ploughing.config import SCENE_TOOL, TIP_HEIGHT, Ploughing
from jaxcontact.scenes import grid
from jaxcontact.sim import tools
from jaxcontact.sim.elements.triangle import Mesh, internal_forces, smallest_altitude, triangle_mesh
from jaxcontact.sim.materials import Elastic, inertial_density

__all__ = [
    "Controls",
    "Final",
    "History",
    "Plan",
    "Run",
    "mean_cutting_force",
    "run",
    "scan",
    "setup",
    "simulate",
    "tool_outline",
    "tool_surface",
    "workpiece_mesh",
]


@jax.jit
def tool_outline(x_tip, rake) -> Array:
    """f[20, 2]: the cutting scene's tool outline, its tip at ``(x_tip, 4)``, in jnp.

    ``tools.outline`` of ``SCENE_TOOL``: the geometry of
    ``scenes.cutting_tool_outline`` (which it equals at ``rake = 10°``),
    differentiable in ``x_tip`` and ``rake`` (radians).

    Example:
      >>> import math
      >>> from jaxcontact.scenes import cutting_tool_outline
      >>> outline = tool_outline(18.0, math.radians(10))
      >>> bool(abs(outline - cutting_tool_outline(18.0)).max() < 1e-5)
      True
    """
    dtype = jnp.result_type(rake, float)
    tip = jnp.stack([jnp.asarray(x_tip, dtype), jnp.asarray(TIP_HEIGHT, dtype)])
    return tools.outline(SCENE_TOOL, rake, tip=tip, dtype=dtype)


def tool_surface(x_tip, rake) -> Surface:
    """The closed ``Surface`` of ``tool_outline(x_tip, rake)``."""
    return Surface(tool_outline(x_tip, rake), jnp.asarray(tools.rings(SCENE_TOOL.nodes)))


def workpiece_mesh(num_nodes: int, material: Elastic, *, dtype=jnp.float32) -> Mesh:
    """The cutting scene's workpiece grid split into linear triangles.

    The grid is ``scenes.cutting_scene``'s (``[0, 20] x [0, 5]``, ``nx / ny ~ 4``,
    numbered row by row), so the slaves of a simulation are that scene's
    slaves. Each grid cell becomes two counter-clockwise triangles; each
    triangle gives a third of its mass to each of its nodes. Nodes on
    ``y = 0`` are fixed; ``boundary`` lists the others on the outline, in
    order along it, so that consecutive rows are close in space (as
    ``bucket_sort``'s culling in blocks of rows wants).

    Example:
      >>> from jaxcontact.sim.materials import STEEL
      >>> mesh = workpiece_mesh(2_000, STEEL)
      >>> mesh.nodes.shape, mesh.triangles.shape
      ((2002, 2), (3780, 3))
    """
    ny = max(2, round(math.sqrt(num_nodes / 4)))
    nx = max(2, round(num_nodes / ny))
    nodes = grid((0.0, 20.0), (0.0, 5.0), nx, ny)
    corner = (np.arange(ny - 1)[:, None] * nx + np.arange(nx - 1)[None, :]).ravel()
    lower = np.stack([corner, corner + 1, corner + nx + 1], axis=-1)
    upper = np.stack([corner, corner + nx + 1, corner + nx], axis=-1)
    triangles = np.concatenate([lower, upper]).astype(np.int32)

    rows = np.arange(ny)[:, None] * nx + np.arange(nx)[None, :]
    boundary = np.concatenate([rows[1:, 0], rows[-1, 1:], rows[-2:0:-1, -1]])
    return triangle_mesh(nodes, triangles, nodes[:, 1] > 0, boundary, material, dtype=dtype)


class Controls(NamedTuple):
    """The traced parameters of a run: differentiate with respect to these.

    The time step is part of the static set-up, chosen for the nominal
    stiffness: a much stiffer penalty needs a new ``setup``.
    """

    rake: Array  # f[]  rake angle (radians)
    stiffness: Array  # f[]  penalty stiffness k (N/mm per mm of thickness)


@dataclasses.dataclass(frozen=True)
class Plan:
    """The static plan of a run, what ``setup`` makes of a ``Ploughing`` (hashable;
    a change compiles anew).

    Attributes:
      steps: time steps in the run.
      dt: time step (s), stable for the mesh, material and nominal stiffness.
      speed: tool speed in ``-x`` (mm/s).
      x_tip_start: the tool tip's x at step 0.
      radius: contact search radius (mm); it must exceed every penetration.
      damping: mass-proportional damping coefficient (1/s).
      material: the workpiece's ``materials.Elastic``.
      search: the contact ``Search`` (its radius and skin: the search radius
        and the candidates' extra reach, mm).
      sizes: its sizes, allocated on the host for the tool anywhere along
        its travel.
      all_slaves: every node is a slave (as in the cutting scene); otherwise
        only ``mesh.boundary``'s nodes are.
    """

    steps: int
    dt: float
    speed: float
    x_tip_start: float
    damping: float
    material: Elastic
    search: Search
    sizes: QuerySizes
    all_slaves: bool = False


class History(NamedTuple):
    """One row per step (T steps)."""

    x_tip: Array  # f[T]  tool tip x
    force: Array  # f[T, 2]  contact force on the tool: (cutting, thrust), N per mm
    active: Array  # i32[T]  active slaves
    penetration: Array  # f[T]  deepest penetration -min(gap) of active slaves (mm)
    signature: Array  # i32[T]  sum over active slaves of (segment + 1): the contact set's print
    rebuilt: Array  # bool[T]  the candidates were found again at this step
    energy: Array  # f[T]  kinetic + strain energy of the workpiece at the step (N mm per mm)


class Final(NamedTuple):
    """The state after the run."""

    displacement: Array  # f[N, 2]
    velocity: Array  # f[N, 2]
    overflow: Array  # bool[]  the sizes were too small at some step: a contact may be missing
    rebuilds: Array  # i32[]  how often the candidates were found again


def setup(config: Ploughing) -> tuple[Mesh, Controls, Plan]:
    """Sets up a run on the host: the mesh, the nominal controls and the static plan.

    Args:
      config: the run's numbers (``Ploughing``).

    Returns:
      ``(mesh, controls, plan)`` for ``scan`` and ``simulate``.

    Example:
      >>> mesh, controls, plan = setup(Ploughing(300, travel=0.1))
      >>> mesh.nodes.shape, plan.sizes["closest"].num_slaves, plan.steps
      ((297, 2), 47, 24)
    """
    num_nodes, travel, speed, material = (
        config.num_nodes,
        config.travel,
        config.speed,
        config.material,
    )
    dtype = jnp.dtype(config.dtype)
    mesh = workpiece_mesh(num_nodes, material, dtype=dtype)
    nodes = np.asarray(mesh.nodes, np.float64)
    spacing = max(float(np.ptp(values) / (len(np.unique(values)) - 1)) for values in nodes.T)
    stiffness = config.stiffness_factor * material.young * 1.0
    lightest = float(np.asarray(mesh.mass).min())
    elastic = 2 * material.wave_speed / smallest_altitude(mesh)
    omega = math.sqrt(elastic**2 + stiffness / lightest)
    dt = config.safety * 2 / omega
    _, mu = material.lame
    shear_speed = math.sqrt(mu / inertial_density(material))
    damping = 2 * config.damping_ratio * math.pi * shear_speed / (2 * float(np.ptp(nodes[:, 1])))
    radius, x_tip_start = spacing, 20.02
    steps = max(1, math.ceil(travel / (speed * dt)))
    rake = math.radians(config.rake_degrees)
    x_tip_end = x_tip_start - speed * dt * steps
    # Sizes for the tool anywhere along its travel: allocated against the
    # outlines at both ends together, whose inflated box holds the tool's
    # at every step, so they keep every block any step keeps.
    ends = [np.asarray(tool_outline(x_tip, rake)) for x_tip in (x_tip_start, x_tip_end)]
    count = len(ends[0])
    starts = np.arange(2 * count)
    both = Surface(
        jnp.asarray(np.concatenate(ends), dtype),
        jnp.asarray(np.stack([starts, starts // count * count + (starts + 1) % count], axis=-1)),
    )
    slave_nodes = nodes if config.slaves == "all" else nodes[np.asarray(mesh.boundary)]
    search = Search(radius=radius, skin=config.skin_factor * radius, slack=config.slack)
    sizes = search.allocate(jnp.asarray(slave_nodes, dtype), both).sizes
    all_slaves = config.slaves == "all"
    plan = Plan(steps, dt, speed, x_tip_start, damping, material, search, sizes, all_slaves)
    controls = Controls(jnp.asarray(rake, dtype), jnp.asarray(stiffness, dtype))
    return mesh, controls, plan


@functools.partial(jax.jit, static_argnames=("plan", "detect"))
def scan(mesh: Mesh, controls: Controls, plan: Plan, detect: bool = True) -> tuple[Final, History]:
    """Runs the simulation: one ``lax.scan`` of ``plan.steps`` steps.

    Args:
      mesh: the workpiece ``Mesh``.
      controls: rake angle and penalty stiffness (traced, differentiable).
      plan: the static ``Plan`` (a new one compiles anew).
      detect: False replaces detection by the contact found at step 0 (no
        contact), to time what a step costs without it.

    Returns:
      ``(Final, History)``. Check ``final.overflow`` on the host: when True a
      contact may have been missed; ``simulate`` allocates larger sizes and
      runs again (its example calls this).
    """
    material, search, dt = plan.material, plan.search, plan.dt
    dtype = mesh.nodes.dtype
    rake = controls.rake.astype(dtype)
    inverse_mass = jnp.where(mesh.free, 1 / mesh.mass, 0)[:, None]
    decay = (1 - plan.damping * dt / 2) / (1 + plan.damping * dt / 2)
    kick = dt / (1 + plan.damping * dt / 2)

    def slaves_of(u):
        x = mesh.nodes + u
        return x if plan.all_slaves else x[mesh.boundary]

    def on_nodes(on_slaves):
        return on_slaves if plan.all_slaves else zero.at[mesh.boundary].add(on_slaves)

    zero = jnp.zeros_like(mesh.nodes)
    start = tool_surface(plan.x_tip_start, rake)
    state = search.init(slaves_of(zero), start, sizes=plan.sizes)
    at_rest, _ = search.closest(state, slaves_of(zero), start)

    def step(carry, index):
        u, v, state = carry
        x_tip = plan.x_tip_start - plan.speed * dt * index.astype(dtype)
        surface = tool_surface(x_tip, rake)
        x = slaves_of(u)
        if detect:
            rebuilds = state.rebuilds
            contact, state = search.closest(state, x, surface)
            rebuilt = state.rebuilds > rebuilds
        else:
            rebuilt, contact = jnp.zeros((), bool), at_rest
        on_slaves = penalty(contact, surface, controls.stiffness).on_slaves
        on_tool = -jnp.sum(on_slaves, axis=0)
        elastic = internal_forces(mesh, u, material)
        force = elastic + on_nodes(on_slaves)
        v_before, v = v, decay * v + kick * inverse_mass * force
        # Leapfrog's own energy: the kinetic part from the velocities either
        # side of the step (the one central differences conserve, undamped).
        energy = (jnp.sum(mesh.mass[:, None] * v_before * v) - jnp.sum(u * elastic)) / 2
        u = u + dt * v
        depth = jnp.where(contact.active, -contact.gap, 0)
        row = History(
            x_tip,
            on_tool,
            jnp.sum(contact.active, dtype=jnp.int32),
            jnp.max(depth, initial=0),
            jnp.sum(jnp.where(contact.active, contact.segment + 1, 0), dtype=jnp.int32),
            rebuilt,
            energy,
        )
        return (u, v, state), row

    begin = (zero, zero, state)
    # Rematerialised under differentiation: the backward pass keeps only each
    # step's carry, not every element's intermediates (O(steps x N) either
    # way, but some twenty times less).
    step = jax.checkpoint(step, prevent_cse=False)
    (u, v, state), history = jax.lax.scan(step, begin, jnp.arange(plan.steps))
    return Final(u, v, state.overflow, state.rebuilds), history


def mean_cutting_force(mesh: Mesh, controls: Controls, plan: Plan) -> Array:
    """f[]: the cutting force on the tool (its x part), averaged over the run.

    Differentiate it with ``jax.grad(mean_cutting_force, argnums=1)``: the
    gradient runs back through the scan (the repository's
    tests/problems/test_ploughing.py checks it against central differences).

    Example:
      >>> mesh, controls, plan = setup(Ploughing(300, travel=0.1))
      >>> round(float(mean_cutting_force(mesh, controls, plan)), -1)
      1720.0
    """
    _, history = scan(mesh, controls, plan)
    return jnp.mean(history.force[:, 0])


def simulate(
    mesh: Mesh, controls: Controls, plan: Plan, *, tries: int = 3
) -> tuple[Final, History, Ploughing]:
    """``scan``, with the overflow flag checked after it: on overflow, allocate
    larger sizes (never smaller than the last) and run again.

    Returns:
      ``(final, history, plan)``, ``plan`` holding the sizes that held.

    Example:
      >>> mesh, controls, plan = setup(Ploughing(300, travel=0.1))
      >>> final, history, plan = simulate(mesh, controls, plan)
      >>> plan.steps, int(history.active.max()), bool(history.force[:, 0].mean() > 0)
      (24, 1, True)
    """
    for _ in range(tries):
        final, history = scan(mesh, controls, plan)
        if not bool(final.overflow):
            return final, history, plan
        x = mesh.nodes + final.displacement
        x = x if plan.all_slaves else x[mesh.boundary]
        surface = tool_surface(float(history.x_tip[-1]), controls.rake)
        search = dataclasses.replace(plan.search, slack=3.0)
        bigger = search.allocate(x, surface, at_least=plan.sizes).sizes
        plan = dataclasses.replace(plan, sizes=bigger)
    raise RuntimeError(f"the search sizes still overflowed after {tries} runs: {plan.sizes}")


class Run(NamedTuple):
    """A whole run (``run``): what was set up and what came of it."""

    mesh: Mesh
    controls: Controls
    plan: Plan  # with the sizes that held
    final: Final
    history: History


def run(config: Ploughing) -> Run:
    """Sets up ``config`` and runs it (``setup``, then ``simulate``).

    Example:
      >>> done = run(Ploughing(300, travel=0.1))
      >>> done.plan.steps, int(done.history.active.max())
      (24, 1)
    """
    mesh, controls, plan = setup(config)
    final, history, plan = simulate(mesh, controls, plan)
    return Run(mesh, controls, plan, final, history)
