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
import sys
import types
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact import Search, Sizes, Surface
from jaxcontact.forces import penalty
from jaxcontact.scenes import grid
from jaxcontact.sim import tools
from jaxcontact.sim._moved import deprecated as _deprecated
from jaxcontact.sim._moved import forward as _forward
from jaxcontact.sim.elements.triangle import Mesh, internal_forces, smallest_altitude, triangle_mesh
from jaxcontact.sim.materials import STEEL, Elastic, inertial_density

# Steel with its density scaled by 10^4: the default workpiece (see the module docstring).
MASS_SCALED_STEEL = STEEL._replace(mass_scale=1e4)

# The cutting scene's tool (docs/scenes.md): a 7° clearance, faces 3 mm from
# the tip, an edge of radius 0.05 drawn by 16 segments, the tip at height 4
# (a depth of cut of 1 in a workpiece 5 high).
SCENE_TOOL = tools.Tool(edge_radius=0.05, clearance=7.0, rake_face=3.0, flank=3.0, arc_segments=16)
TIP_HEIGHT = 4.0


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
class Ploughing:
    """The static set-up of a run (hashable; a change compiles anew).

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
    sizes: Sizes
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


def setup(
    num_nodes: int = 10_000,
    *,
    travel: float = 0.4,
    speed: float = 3_000.0,
    material: Elastic = MASS_SCALED_STEEL,
    stiffness_factor: float = 10.0,
    safety: float = 0.5,
    damping_ratio: float = 0.3,
    skin_factor: float = 0.5,
    slack: float = 2.0,
    rake_degrees: float = 10.0,
    slaves: str = "surface",
    dtype=jnp.float32,
) -> tuple[Mesh, Controls, Ploughing]:
    """Sets up a run on the host: the mesh, the nominal controls and the static set-up.

    Args:
      num_nodes: about this many workpiece nodes (the cutting scene's sizing).
      travel: how far the tool moves (mm), starting 0.02 clear of the workpiece.
      speed: tool speed (mm/s).
      material: the workpiece; by default steel with its density scaled by 10⁴.
      stiffness_factor: penalty stiffness per node, in units of E × 1 mm.
      safety: the time step as a fraction of the stable one,
        ``2 / sqrt((2 c / h)² + k / m_min)`` with ``c`` the dilatational wave
        speed and ``h`` the smallest element altitude (CFL with the penalty
        spring on the lightest node).
      damping_ratio: mass-proportional damping as a fraction of critical for
        the workpiece's lowest shear mode (``ω₁ ≈ π c_s / 2H``).
      skin_factor: the skin as a fraction of the search radius (one grid spacing).
      slack: the search sizes' slack.
      rake_degrees: the nominal rake angle.
      slaves: ``"surface"``: the nodes of the free outline (``mesh.boundary``),
        which meet the tool before any interior node can; ``"all"``: every
        node, as in the cutting scene (detection then costs O(N) a step).
      dtype: float32 or float64.

    Returns:
      ``(mesh, controls, config)`` for ``run``.

    Example:
      >>> mesh, controls, config = setup(300, travel=0.1)
      >>> mesh.nodes.shape, config.sizes.num_slaves, config.steps
      ((297, 2), 47, 24)
    """
    if num_nodes < 4:
        raise ValueError(f"num_nodes must be at least 4; got {num_nodes}")
    if not (travel > 0 and speed > 0):
        raise ValueError(f"travel and speed must be > 0; got travel={travel}, speed={speed}")
    if slaves not in ("surface", "all"):
        raise ValueError(f'slaves must be "surface" or "all"; got {slaves!r}')
    mesh = workpiece_mesh(num_nodes, material, dtype=dtype)
    nodes = np.asarray(mesh.nodes, np.float64)
    spacing = max(float(np.ptp(values) / (len(np.unique(values)) - 1)) for values in nodes.T)
    stiffness = stiffness_factor * material.young * 1.0
    lightest = float(np.asarray(mesh.mass).min())
    elastic = 2 * material.wave_speed / smallest_altitude(mesh)
    omega = math.sqrt(elastic**2 + stiffness / lightest)
    dt = safety * 2 / omega
    _, mu = material.lame
    shear_speed = math.sqrt(mu / inertial_density(material))
    damping = 2 * damping_ratio * math.pi * shear_speed / (2 * float(np.ptp(nodes[:, 1])))
    radius, x_tip_start = spacing, 20.02
    steps = max(1, math.ceil(travel / (speed * dt)))
    rake = math.radians(rake_degrees)
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
    slave_nodes = nodes if slaves == "all" else nodes[np.asarray(mesh.boundary)]
    search = Search(radius=radius, skin=skin_factor * radius, slack=slack)
    sizes = search.allocate(jnp.asarray(slave_nodes, dtype), both).sizes
    all_slaves = slaves == "all"
    config = Ploughing(steps, dt, speed, x_tip_start, damping, material, search, sizes, all_slaves)
    controls = Controls(jnp.asarray(rake, dtype), jnp.asarray(stiffness, dtype))
    return mesh, controls, config


@functools.partial(jax.jit, static_argnames=("config", "detect"))
def run(
    mesh: Mesh, controls: Controls, config: Ploughing, detect: bool = True
) -> tuple[Final, History]:
    """Runs the simulation: one ``lax.scan`` of ``config.steps`` steps.

    Args:
      mesh: the workpiece ``Mesh``.
      controls: rake angle and penalty stiffness (traced, differentiable).
      config: the static ``Ploughing`` set-up (a new one compiles anew).
      detect: False replaces detection by the contact found at step 0 (no
        contact), to time what a step costs without it.

    Returns:
      ``(Final, History)``. Check ``final.overflow`` on the host: when True a
      contact may have been missed; ``simulate`` allocates larger sizes and
      runs again (its example calls this).
    """
    material, search, dt = config.material, config.search, config.dt
    dtype = mesh.nodes.dtype
    rake = controls.rake.astype(dtype)
    inverse_mass = jnp.where(mesh.free, 1 / mesh.mass, 0)[:, None]
    decay = (1 - config.damping * dt / 2) / (1 + config.damping * dt / 2)
    kick = dt / (1 + config.damping * dt / 2)

    def slaves_of(u):
        x = mesh.nodes + u
        return x if config.all_slaves else x[mesh.boundary]

    def on_nodes(on_slaves):
        return on_slaves if config.all_slaves else zero.at[mesh.boundary].add(on_slaves)

    zero = jnp.zeros_like(mesh.nodes)
    start = tool_surface(config.x_tip_start, rake)
    state = search.init(slaves_of(zero), start, sizes=config.sizes)
    at_rest, _ = search.closest(state, slaves_of(zero), start)

    def step(carry, index):
        u, v, state = carry
        x_tip = config.x_tip_start - config.speed * dt * index.astype(dtype)
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
    (u, v, state), history = jax.lax.scan(step, begin, jnp.arange(config.steps))
    return Final(u, v, state.overflow, state.rebuilds), history


def mean_cutting_force(mesh: Mesh, controls: Controls, config: Ploughing) -> Array:
    """f[]: the cutting force on the tool (its x part), averaged over the run.

    Differentiate it with ``jax.grad(mean_cutting_force, argnums=1)``: the
    gradient runs back through the scan (the repository's
    tests/sim/test_simulate.py checks it against central differences).

    Example:
      >>> mesh, controls, config = setup(300, travel=0.1)
      >>> round(float(mean_cutting_force(mesh, controls, config)), -1)
      1720.0
    """
    _, history = run(mesh, controls, config)
    return jnp.mean(history.force[:, 0])


def simulate(
    mesh: Mesh, controls: Controls, config: Ploughing, *, tries: int = 3
) -> tuple[Final, History, Ploughing]:
    """``run``, with the overflow flag checked after it: on overflow, allocate
    larger sizes (never smaller than the last) and run again.

    Returns:
      ``(final, history, config)``, ``config`` holding the sizes that held.

    Example:
      >>> mesh, controls, config = setup(300, travel=0.1)
      >>> final, history, config = simulate(mesh, controls, config)
      >>> config.steps, int(history.active.max()), bool(history.force[:, 0].mean() > 0)
      (24, 1, True)
    """
    for _ in range(tries):
        final, history = run(mesh, controls, config)
        if not bool(final.overflow):
            return final, history, config
        x = mesh.nodes + final.displacement
        x = x if config.all_slaves else x[mesh.boundary]
        surface = tool_surface(float(history.x_tip[-1]), controls.rake)
        search = dataclasses.replace(config.search, slack=3.0)
        bigger = search.allocate(x, surface, at_least=config.sizes).sizes
        config = dataclasses.replace(config, sizes=bigger)
    raise RuntimeError(f"the search sizes still overflowed after {tries} runs: {config.sizes}")


class _Callable(types.ModuleType):
    """This module, callable as the 0.7.5 set-up function ``jaxcontact.sim.ploughing``
    was (the package exported the function under the module's name)."""

    def __call__(self, *args, **kwargs):
        return _ploughing(*args, **kwargs)


# Called as a module: the caller is three frames up (call, __call__, the caller).
_ploughing = _deprecated(
    "jaxcontact.sim.ploughing", "jaxcontact.sim.ploughing.setup", setup, stacklevel=3
)
__getattr__ = _forward(
    __name__,
    {
        "ploughing": "jaxcontact.sim.ploughing.setup",
        "Material": "jaxcontact.sim.materials.Elastic",
    },
)
sys.modules[__name__].__class__ = _Callable
