"""Orthogonal cutting of AISI 1045 that forms a chip: the source paper's simulation, in JAX.

A rigid carbide tool (rake angle ``rake``, clearance 7°, edge radius
``edge_radius``) cuts a plane-strain AISI 1045 workpiece at the cutting speed
``speed`` with the uncut chip thickness ``uncut``. Everything runs in one
``lax.scan`` of fixed shapes, on jaxcontact's public names only:
``jaxcontact.Search`` finds every contact, ``jaxcontact.forces`` turns it
into forces. Units: mm, N, tonne, s, K (stresses in MPa, forces per
mm of width in N/mm).

The model, and why:

Built from the parts of ``jaxcontact.sim``: ``materials``, ``elements.q4``,
``explicit``, ``coupling`` and ``tools``; what is cutting's own is the
mesh with its parting line, node separation and the two tool outlines
(here), the cut's numbers (``config``) and the report (``report``).

* **Material** (``Cutting.work_material``, ``materials.AISI_1045`` by default):
  J2 flow with the Johnson–Cook flow stress of Jaspers and Dautzenberg
  (2002), adiabatic heating with a Taylor–Quinney coefficient of 0.9. No
  heat conduction, no damage.
* **Elements** (``elements.q4``): updated-Lagrangian bilinear quadrilaterals,
  2x2 Gauss points, the B-bar mean dilatation against volumetric locking in
  isochoric plastic flow, the Hughes–Winget rotation of the stress for
  objectivity. Square elements of edge ``element`` (the uncut layer is
  ``uncut / element`` elements thick).
* **Chip separation** by node separation along a parting line at the depth of
  cut (Strenkowski and Carroll, 1985, *J. Eng. Ind.* 107, 349-354; Shih,
  Chandrasekar and Yang, 1990, the critical-distance form): the mesh is two
  blocks, the uncut layer above the parting line and the base below, whose
  nodes on the line are duplicated and tied in pairs (``explicit.Boundary``'s
  ``ties``: a pair moves as one node). A pair is released for good when
  the edge's front comes within ``separation`` (default a quarter element) of
  where the pair started (the material ahead is pushed along with the tool,
  so its current place would stay ahead). Each release lets go at once of
  the load the tie carried: the cutting force dips once per element of
  travel (``release_dips`` measures it). Released, the pair's two segments
  (the chip's underside and the machined surface) become part of the
  outline: they are switched on in the master's mask, from a pool allocated
  at the start (``Search.allocate(pool=...)``), so nothing recompiles. The
  workpiece's starting edge is chamfered a quarter element under the line.
* **The stagnation point.** Node separation decides that material above the
  line leaves with the chip and material below stays. A closest-point
  contact with one rounded edge cannot hold that: a node at the edge's front
  is pushed by a normal with no vertical part, and goes whichever way
  rounding says (the base's corner climbed the rake face with the chip). So
  the uncut layer's nodes meet the tool with its edge's centre a radius below
  the line (the rake face reaches down to it), and the base's nodes meet it
  with its lowest point on the line (``CHIP_SIDE``, ``BASE_SIDE``: two
  outlines, 2 edge radii apart, told apart by ``Search``'s bodies).
* **Contact**: two searches a step, because a node at the edge touches the
  tool and the workpiece at once, and a closest-point search gives each slave
  one segment. ``Search(track=True, normals=Smooth())`` finds every node's
  contact with the tool; ``forces.coulomb`` gives the penalty and the friction
  from the slip history, its reaction on the tool's nodes the cutting force.
  Friction is Coulomb's ``mu`` times the pressure, capped at ``shear_factor``
  times the steel's shear flow stress ``A / sqrt 3``, a traction (Zorev, 1963;
  Shirakashi and Usui, 1973; 160 MPa by default): each node carries it over
  its tributary length on the workpiece's outline (``coupling.tributary``), so
  that it is a stress whatever the spacing of the nodes that reach the tool.
  Without the cap, the sticking zone shears the chip's first row of elements
  into slivers. ``Pairs(self_contact=True)`` over the pool of outline segments
  finds the chip against the machined surface, the workpiece and itself;
  ``forces.penalty`` acts on both sides, frictionless. Near the
  crack tip the outline is open, and a node lies within the radius of the
  other side's segments without being inside: contacts at an open end of
  the outline, and contacts deeper than ``PENMAX`` elements (LS-DYNA's
  PENMAX), are left out and counted (``Record.dropped``).
  Penalty rather than Lagrange multipliers because an explicit step has no
  system to solve; each node's stiffness is ``stiffness * m_i / dt^2``
  (LS-DYNA's soft constraint), stable in the step whatever the node's mass.
* **Chip curl**: on the plain rake face the chip climbs straight, however
  far the tool goes (nothing in the model bends a free chip: no heat
  conduction, no strain gradient across it from one). ``breaker`` puts an
  obstruction-type chip breaker on the tool, a backwall that bends the chip
  (chip breaking by an obstruction: Nakayama, 1962, *Bull. JSME* 5(17), 142-150);
  curled, the chip lands on the uncut workpiece ahead of the tool (``ahead``
  leaves room for it), where the self-contact search holds it.
  ``Record.landed`` counts own contacts farther than ``LANDING`` uncut
  thicknesses from the edge: the chip on the workpiece or on itself.
* **Time integration**: central differences (``sim.explicit``) at
  ``safety`` (0.3) times the stable step of the smallest element, linear
  bulk viscosity (0.06, LS-DYNA's default). Mass scaling: the density times
  ``mass_scaling``, which lengthens the stable step by its square root, for
  inertia only (``materials``' ``mass_scale``): heating is the steel's. The material's
  rate follows the real motion; only inertia changes (measured against a run
  at half the scaling: the forces and the chip ratio within about 1 %).
* **Erosion**: an element whose Jacobian falls below ``erode`` of its
  original at a Gauss point is taken out (no stress, its lone nodes held
  still and out of contact), and counted. The default cut erodes none.
* **Boundary conditions**: the base's bottom is fixed, the workpiece's left
  end is held in x; the tool moves at ``-speed`` along x, its speed ramped up
  over the first ``ramp`` of the travel.

What it leaves out: heat conduction (in the workpiece and into the tool),
the tool's elasticity and wear, damage and chip segmentation (AISI 1045 at
these conditions forms a continuous chip), friction that depends on
temperature, remeshing (the Lagrangian mesh limits how far a run can go:
a sharp rake with high friction tears the machined surface into slivers),
and the stress the parting line carries before it separates beyond the tie.

Differentiable: ``mean_forces`` runs the whole cut as a function of the
rake angle and ``mu``; ``jax.grad`` goes through the plastic flow (the
return mapping's implicit gradient), the contact and the friction. Node
separation is a discrete event: which step releases a pair does not move
with the parameters, so the gradient is that of the run with its release
steps held fixed (exact between releases, blind to a release moving a step).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
import warnings
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

import jaxcontact
from jaxcontact.forces import Friction
from jaxcontact.problems.cutting.config import (
    LANDING,
    MU,
    PENMAX,
    TOOL_NODES,
    VISCOSITY,
    Cutting,
)
from jaxcontact.sim import ale, coupling, explicit, materials, tools
from jaxcontact.sim.elements import q4

__all__ = [
    "Frame",
    "Model",
    "Record",
    "Seen",
    "State",
    "Workpiece",
    "advance",
    "chunk_steps",
    "contact_share",
    "contacts",
    "friction_law",
    "held",
    "inspect_step",
    "mean_forces",
    "observe",
    "own_surface",
    "rezone",
    "run",
    "setup",
    "step",
    "sticking_limit",
    "tool_friction",
    "tool_position",
    "tool_surface",
    "tool_travel",
    "travel_at",
    "workpiece",
]


class Workpiece(NamedTuple):
    """The workpiece's mesh with everything a cutting run needs of it (static shapes)."""

    quads: q4.Quads
    partner: Array  # i32[N]  the tied node of each parting-line node (itself elsewhere)
    base_line: Array  # i32[L]  base nodes on the parting line, left to right
    chip_line: Array  # i32[L]  uncut-layer nodes on the parting line, left to right
    top: Array  # i32[L]  the uncut layer's top surface, left to right
    slaves: Array  # i32[S]  every node that can be on the outline
    segments: Array  # i32[W, 2]  every segment that can be outline, counter-clockwise
    pair: Array  # i32[W, 2]  parting-line pairs a segment needs released (-1: always real)
    fixed: Array  # bool[N, 2]  prescribed (zero) velocity components
    side: Array  # i32[N]  each node's side of the parting line: 0 the uncut layer, 1 the base
    owner: Array  # i32[W]  the element each outline segment is an edge of
    tables: ale.Tables  # the mesh's neighbours (the rezone and the remap)
    along: Array  # i32[N, 2]  a boundary node's neighbours on its boundary (-1: inside)
    pinned: Array  # bool[N]  nodes no rezone moves: the blocks' corners and the held nodes


def workpiece(cut: Cutting) -> Workpiece:
    """The two-block mesh of ``cut``: the base, then the uncut layer, each a grid."""
    nx, rows_b, rows_c = cut.columns, cut.base_rows, cut.chip_rows
    e, dtype = cut.element, jnp.dtype(cut.dtype)
    width = nx * e
    density = materials.inertial_density(cut.scaled)
    base = q4.grid_mesh(width, rows_b * e, nx, rows_b, density, dtype)
    layer = q4.grid_mesh(width, rows_c * e, nx, rows_c, density, dtype)
    nb = (nx + 1) * (rows_b + 1)
    nodes = np.concatenate(
        [np.asarray(base.nodes), np.asarray(layer.nodes) + np.array([0.0, rows_b * e])]
    )
    quads = np.concatenate([np.asarray(base.quads), np.asarray(layer.quads) + nb])
    mass = np.concatenate([np.asarray(base.mass), np.asarray(layer.mass)])
    columns = np.arange(nx + 1)
    base_line = rows_b * (nx + 1) + columns
    # The starting edge chamfered under the parting line by a quarter element:
    # the tool's edge meets the base first at the pair behind it, as it does
    # every pair of the steady cut (the corner node, on the edge's lowest
    # point, would be squeezed up the rake face with the chip).
    nodes[base_line[-1], 1] -= 0.25 * e
    chip_line = nb + columns
    top = nb + rows_c * (nx + 1) + columns
    partner = np.arange(len(nodes))
    partner[base_line], partner[chip_line] = chip_line, base_line

    def grid_b(i, j):
        return j * (nx + 1) + i

    def grid_c(i, j):
        return nb + j * (nx + 1) + i

    segments, pair = [], []

    def add(a, b, pa=-1, pb=-1):
        segments.append((a, b))
        pair.append((pa, pb))

    for j in range(rows_b):  # the base's right end, upwards
        add(grid_b(nx, j), grid_b(nx, j + 1))
    for i in range(nx, 0, -1):  # the machined surface, right to left (pool)
        add(grid_b(i, rows_b), grid_b(i - 1, rows_b), i, i - 1)
    for i in range(nx):  # the chip's underside, left to right (pool)
        add(grid_c(i, 0), grid_c(i + 1, 0), i, i + 1)
    for j in range(rows_c):  # the uncut layer's right end, upwards
        add(grid_c(nx, j), grid_c(nx, j + 1))
    for i in range(nx, 0, -1):  # the free surface, right to left
        add(grid_c(i, rows_c), grid_c(i - 1, rows_c))
    segments, pair = np.asarray(segments, np.int32), np.asarray(pair, np.int32)
    slaves = np.unique(segments)
    # The element each outline segment is an edge of (for erosion).
    edges = {}
    for element, corners in enumerate(quads):
        for a, b in zip(corners, np.roll(corners, -1), strict=True):
            edges[(int(a), int(b))] = element
    owner = np.array([edges[(int(a), int(b))] for a, b in segments], np.int32)
    fixed = np.zeros((len(nodes), 2), bool)
    fixed[nodes[:, 1] == 0] = True
    fixed[nodes[:, 0] == 0, 0] = True
    # The rezone's boundaries: each boundary node slides between its two
    # neighbours on its own line (the parting line's two sides, the free
    # surface, the blocks' right ends); the corners stay.
    along = np.full((len(nodes), 2), -1, np.int64)
    lines = [base_line, chip_line, top]
    lines.append([grid_b(nx, j) for j in range(rows_b + 1)])
    lines.append([grid_c(nx, j) for j in range(rows_c + 1)])
    corners = []
    for line in lines:
        for before, node, after in zip(line[:-2], line[1:-1], line[2:], strict=True):
            along[node] = (before, after)
        corners += [line[0], line[-1]]
    pinned = fixed.any(1)
    pinned[corners] = True
    # The chip's tail, where the cut starts, stays Lagrangian: its corner is
    # pushed up the rake face and bent over it, and a rezone sliding its
    # underside folded its first element (measured: eroded at 0.09 mm of travel).
    pinned[nodes[:, 0] > width - cut.uncut] = True
    quads_mesh = q4.Quads(jnp.asarray(nodes, dtype), jnp.asarray(quads), jnp.asarray(mass, dtype))
    return Workpiece(
        quads_mesh,
        jnp.asarray(partner, jnp.int32),
        jnp.asarray(base_line, jnp.int32),
        jnp.asarray(chip_line, jnp.int32),
        jnp.asarray(top, jnp.int32),
        jnp.asarray(slaves, jnp.int32),
        jnp.asarray(segments),
        jnp.asarray(pair),
        jnp.asarray(fixed),
        jnp.asarray((np.arange(len(nodes)) < nb).astype(np.int32)),
        jnp.asarray(owner),
        ale.tables(quads_mesh),
        jnp.asarray(along, jnp.int32),
        jnp.asarray(pinned),
    )


class State(NamedTuple):
    """What the scan carries from step to step."""

    body: explicit.Body
    tool: jaxcontact.SearchState  # the search against the tool (with slip history)
    own: jaxcontact.SearchState  # the search against the workpiece's own outline
    friction: Friction  # Coulomb's state on the rake face and the flank
    released: Array  # bool[L]  parting-line pairs separated
    alive: Array  # bool[E]  elements not eroded
    step: Array  # i32[]
    mass: Array  # f[E]  each element's mass (t per mm of width): the remap's weights
    rate: Array  # f[E]  each element's plastic strain rate over the last step (1/s)


class Record(NamedTuple):
    """What each step reports (one row per step after a scan)."""

    force: Array  # f[2]  the force on the tool (N/mm): +x resists the cut (cutting), +y thrust
    tool_depth: Array  # f[]  the deepest penetration of any node into the tool (mm)
    own_depth: Array  # f[]  the deepest penetration of any node into the workpiece's outline (mm)
    tool_contacts: Array  # i32[]  nodes pressed on the tool
    own_contacts: Array  # i32[]  nodes pressed on the workpiece's own outline
    released: Array  # i32[]  parting-line pairs separated
    eroded: Array  # i32[]  elements eroded so far
    dropped: Array  # i32[]  contacts on the own outline deeper than PENMAX, left out
    landed: Array  # i32[]  own contacts farther than LANDING uncut thicknesses from the edge
    overflow: Array  # bool[]  a search outgrew its sizes (never expected: exhaustive)


@functools.partial(
    jax.tree_util.register_dataclass,
    data_fields=["mesh"],
    meta_fields=["cut", "tool_search", "own_search", "start_x"],
)
@dataclasses.dataclass(frozen=True)
class Model:
    """A cut set up to run: the mesh (arrays), the cut and the searches (static)."""

    cut: Cutting
    mesh: Workpiece
    tool_search: jaxcontact.Search
    own_search: jaxcontact.Search
    start_x: float  # the tool's lowest point at step 0 (x, mm)


def tool_position(cut: Cutting, start_x: float, step) -> Array:
    """The x of the tool's lowest point at ``step`` (the speed ramps up linearly)."""
    k = jnp.asarray(step, jnp.dtype(cut.dtype))
    ramp = cut.ramp_steps
    moved = jnp.where(k < ramp, 0.5 * k * k / ramp, k - 0.5 * ramp)
    return start_x - cut.velocity * cut.dt * moved


def tool_travel(cut: Cutting, step) -> np.ndarray:
    """f64[...]: how far the tool has moved at ``step`` (an int or i[...]; mm, on the host).

    ``tool_position``'s ramp in float64: the labels, the averaging window and
    the summary read the travel from here, so that step 0 is 0 mm (not the
    float32 rounding of ``start_x`` minus itself) and the run's last step is
    ``Cutting.travel`` to within a step's motion."""
    k = np.asarray(step, np.float64)
    ramp = cut.ramp_steps
    moved = np.where(k < ramp, 0.5 * k * k / ramp, k - 0.5 * ramp)
    return cut.velocity * cut.dt * moved


def travel_at(model: Model, step) -> float:
    """How far the tool has cut at ``step`` (mm, on the host; ``tool_travel``)."""
    return float(tool_travel(model.cut, step))


# The edge's centre above the parting line, in edge radii, as the uncut
# layer's nodes meet it (a radius below: the rake face reaches down to the
# line) and as the base's nodes meet it (a radius above: the edge's lowest
# point is on the line, which passes under the edge).
CHIP_SIDE, BASE_SIDE = -1.0, 1.0


def tool_surface(cut: Cutting, centre_x, rake) -> jaxcontact.Surface:
    """The tool as two closed outlines, its edge's centre at ``centre_x``:
    body 1 as the uncut layer meets it, body 0 as the base meets it
    (``CHIP_SIDE``, ``BASE_SIDE``)."""
    dtype = jnp.dtype(cut.dtype)
    outlines = []
    for side in (BASE_SIDE, CHIP_SIDE):
        lowest_y = cut.parting_y + (side - 1) * cut.edge_radius
        lowest = jnp.stack([jnp.asarray(centre_x, dtype), jnp.asarray(lowest_y, dtype)])
        outlines.append(tools.outline(cut.tool, rake, lowest=lowest, dtype=dtype))
    return jaxcontact.Surface(
        jnp.concatenate(outlines),
        jnp.asarray(tools.rings(TOOL_NODES, 2)),
        body=jnp.asarray(np.repeat(np.arange(2, dtype=np.int32), TOOL_NODES)),
    )


def own_surface(mesh: Workpiece, x: Array, released: Array, alive: Array) -> jaxcontact.Surface:
    """The workpiece's outline now: every segment that can be outline, those
    on the parting line real once both their pairs are released, none of an
    eroded element."""
    first, second = mesh.pair[:, 0], mesh.pair[:, 1]
    real = (first < 0) | (released[jnp.maximum(first, 0)] & released[jnp.maximum(second, 0)])
    return jaxcontact.Surface(x, mesh.segments, mask=real & alive[mesh.owner])


def _at_nodes(mesh: Workpiece, flags: Array) -> Array:
    """i32[N]: how many of each node's elements ``flags`` (bool[E]) marks."""
    count = jnp.zeros(mesh.quads.nodes.shape[0], jnp.int32)
    return count.at[mesh.quads.quads].add(flags[:, None].astype(jnp.int32))


def held(mesh: Workpiece, alive: Array) -> Array:
    """bool[N]: nodes of at least one element not eroded (the others are debris)."""
    return _at_nodes(mesh, alive) > 0


def setup(cut: Cutting) -> tuple[Model, State]:
    """The mesh, the searches and the state at rest, the tool just clear of the workpiece."""
    mesh = workpiece(cut)
    # Two searches, because a node at the edge touches the tool and the
    # workpiece at once (the chip's underside meets the machined surface
    # there), and a closest-point search gives each slave its one closest
    # segment: one search per master gives each node its contact with each.
    tool_search = jaxcontact.Search(
        radius=cut.radius, method="exhaustive", track=True, normals=jaxcontact.Smooth()
    )
    own_search = jaxcontact.Search(radius=cut.radius, method="exhaustive")
    start_x = float(mesh.quads.nodes[:, 0].max()) + cut.edge_radius + 0.5 * cut.element
    model = Model(cut, mesh, tool_search, own_search, start_x)
    released = jnp.zeros(mesh.base_line.shape, bool).at[-2:].set(True)  # the chamfer
    x = mesh.quads.nodes
    slaves = x[mesh.slaves]
    tool = tool_search.allocate(
        x, tool_surface(cut, start_x, 0.0), pairs=jaxcontact.Pairs(slave_body=mesh.side)
    )
    own = own_search.allocate(
        slaves,
        own_surface(mesh, x, released, jnp.ones(mesh.quads.quads.shape[0], bool)),
        pool=mesh.pair[:, 0] >= 0,
        pairs=jaxcontact.Pairs(slave_node=mesh.slaves, self_contact=True),
    )
    body = explicit.at_rest(mesh.quads, cut.scaled)
    friction = Friction.zeros(x.shape[0], x.dtype)
    alive = jnp.ones(mesh.quads.quads.shape[0], bool)
    mass = materials.inertial_density(cut.scaled) * ale.areas(mesh.quads, x)
    rate = jnp.zeros_like(mass)
    start = State(body, tool, own, friction, released, alive, jnp.zeros((), jnp.int32), mass, rate)
    return model, start


def _on_tool(model: Model, tool_state, x, tool: jaxcontact.Surface, kept):
    """Every node's contact with the tool, each side of the parting line on its own
    outline (``CHIP_SIDE``, ``BASE_SIDE``): ``(contact, tool_state)``."""
    pairs = jaxcontact.Pairs(slave_body=model.mesh.side)
    return model.tool_search.closest(tool_state, x, tool, mask=kept, pairs=pairs)


def contacts(model: Model, tool_state, own_state, x, lowest_x, rake, released, alive, kept):
    """A step's contact detection, the two searches: ``(tool, on_tool,
    tool_state, slip, own, on_own, own_state)``, the surfaces with what each
    search found and its state. ``step`` runs it, and a benchmark can time it alone
    (benchmarks/simulations.py's ``detection_share``)."""
    mesh = model.mesh
    tool = tool_surface(model.cut, lowest_x, rake)
    on_tool, tool_state = _on_tool(model, tool_state, x, tool, kept)
    slip = tool_state.slip
    own = own_surface(mesh, x, released, alive)
    on_own, own_state = model.own_search.closest(
        own_state,
        x[mesh.slaves],
        own,
        mask=kept[mesh.slaves],
        pairs=jaxcontact.Pairs(slave_node=mesh.slaves, self_contact=True),
    )
    return tool, on_tool, tool_state, slip, own, on_own, own_state


def friction_law(cut: Cutting, mu, share=None) -> coupling.Zorev:
    """The tool's friction with a constant cap: Coulomb's ``mu``, up to Zorev's
    sticking limit of ``shear_factor`` times the material's initial shear flow
    stress ``A / sqrt 3``, a traction (``Cutting(friction_limit="initial")``;
    ``sticking_limit`` is the other).

    ``share``: each node's tributary length (mm, f[N]: ``contact_share``).
    Left out, it is one element for every node, as before 2.2, with a
    ``DeprecationWarning``: the chip's underside reaches the tool with its
    nodes about half an element apart, so that cap is about twice the
    traction it names."""
    if share is None:
        warnings.warn(
            "cutting.friction_law(cut, mu) without share= takes one element as every "
            "node's share, which makes the cap about twice the traction it names; pass "
            "share=cutting.contact_share(model, x, alive) (deprecated in 2.2, the "
            "argument becomes required in 3.0)",
            DeprecationWarning,
            stacklevel=2,
        )
        share = cut.element
    return coupling.Zorev(mu, cut.shear_factor * cut.work_material.shear_yield, share)


def contact_share(model: Model, x: Array, alive: Array) -> Array:
    """f[N]: each node's tributary length (mm) on the workpiece's outline, the
    share over which it carries Zorev's limit (``coupling.tributary``).

    Every segment that can be outline counts, released or not (a tied node on
    the parting line reaches the tool's edge with its two neighbours on the
    line), none of an eroded element. Nodes inside the workpiece get 0: they
    do not reach the tool."""
    mesh = model.mesh
    outline = jaxcontact.Surface(x, mesh.segments, mask=alive[mesh.owner])
    return coupling.tributary(outline)


def sticking_limit(model: Model, state: State) -> Array:
    """f[N]: Zorev's sticking limit at each node (MPa), ``m k``, ``k`` the chip's own
    shear flow stress ``sigma_JC(eps_p, rate, T) / sqrt 3`` (von Mises) averaged over
    the node's elements not eroded, each at its mean plastic strain and temperature and
    its plastic strain rate of the last step.

    Oxley's analysis of the tool-chip interface takes the friction stress in
    sticking equal to the chip's shear flow stress there, ``m = 1`` (Oxley,
    *The Mechanics of Machining*, 1989, chapter 4; Zorev, 1963); a constant cap
    at the initial ``A / sqrt 3`` is 2-3 times lower than that of a hot,
    strained chip."""
    cut, mesh = model.cut, model.mesh
    points = state.body.points
    flow = cut.work_material.flow_stress(
        points.plastic_strain.mean(1), state.rate, points.temperature.mean(1)
    )
    k = jnp.where(state.alive, flow / math.sqrt(3), 0)
    at = mesh.tables.elements
    real = (at >= 0) & state.alive[jnp.maximum(at, 0)]
    total = jnp.where(real, k[jnp.maximum(at, 0)], 0).sum(1)
    return cut.shear_factor * total / jnp.maximum(real.sum(1), 1)


def tool_friction(model: Model, state: State, mu) -> coupling.Zorev:
    """The tool's friction law of the cut's ``friction_limit``."""
    cut = model.cut
    share = contact_share(model, state.body.x, state.alive)
    if cut.friction_limit == "initial":
        return friction_law(cut, mu, share)
    return coupling.Zorev(mu, sticking_limit(model, state), share)


class Seen(NamedTuple):
    """What one step saw at the tool, node by node (``inspect_step``, ``observe``):
    the raw material of a rake-face diagnosis (benchmarks/simulations.py's
    ``--diagnostics``)."""

    x: Array  # f[N, 2]  the nodes where the step found their contacts
    lowest_x: Array  # f[]  the x of the tool's lowest point
    contact: jaxcontact.Contact  # each node's contact with the tool (N rows; smooth normals)
    force: Array  # f[N, 2]  the tool's force on each node, penalty and friction (N/mm)
    cap: Array  # f[N]  each node's friction force limit: Zorev's limit times its share (N/mm)
    at_cap: Array  # bool[N]  pressed nodes whose friction force is at ``cap``
    distortion: Array  # f[E]  each element's smallest det J ratio after the step (erosion's test)
    rezoned: Array  # f[]  the largest node move of a rezone just before the step (mm; NaN: none)


# A friction force within this share of its cap is at the cap (float32 rounding of f_t).
AT_CAP = 1e-3


def step(model: Model, state: State, rake, mu) -> tuple[State, Record]:
    """One explicit step of the cut (``rake`` in radians, ``mu`` the friction coefficient)."""
    after, record, _ = inspect_step(model, state, rake, mu)
    return after, record


def inspect_step(model: Model, state: State, rake, mu) -> tuple[State, Record, Seen]:
    """``step``, and what it saw at the tool (``Seen``): the same computation,
    whose extra outputs cost nothing where they are not used (under ``jit``)."""
    cut, mesh = model.cut, model.mesh
    dtype = jnp.dtype(cut.dtype)
    x = state.body.x
    lowest_x = tool_position(cut, model.start_x, state.step)
    # Node separation: a pair lets go when the edge's front (on the parting
    # line, an edge radius ahead of the lowest point) comes within the critical
    # distance of where the pair started: the material ahead is pushed along
    # with the tool, so its current place would keep ahead of the edge.
    ahead = lowest_x - cut.edge_radius - mesh.quads.nodes[mesh.base_line, 0]
    released = state.released | (ahead < cut.critical_distance)
    # The penalty as stiff as each node's mass allows in the step: about E
    # per mm, independent of the mass scaling (``coupling.mass_penalty``).
    k = coupling.mass_penalty(mesh.quads.mass, cut.dt, cut.stiffness)
    kept = held(mesh, state.alive)
    tool, on_tool, tool_state, slip, own, on_own, own_state = contacts(
        model, state.tool, state.own, x, lowest_x, rake, released, state.alive, kept
    )
    # The tool: penalty, and Zorev's sticking and sliding from the slip
    # history, each node's limit over its tributary length.
    law = tool_friction(model, state, mu)
    tool_forces, friction = coupling.friction_forces(on_tool, slip, state.friction, tool, k, law)
    # The workpiece against its own outline (the chip on the machined surface
    # and on itself): frictionless penalty on both sides. Near the crack tip
    # the outline is open: a node past its end, or a node of the base under
    # the chip's root found more than PENMAX elements "inside" the chip's
    # underside, is not in contact (``coupling.guard``); the deep ones are counted.
    guarded = coupling.guard(on_own, own, PENMAX * cut.element)
    on_own = guarded.contact
    # The chip landed (on the workpiece ahead of the tool, or on itself): an
    # own contact away from the edge, where the crack's faces meet.
    edge = jnp.stack([lowest_x, jnp.asarray(cut.parting_y, dtype)])
    away = jnp.sum((x[mesh.slaves] - edge[None, :]) ** 2, -1) > (LANDING * cut.uncut) ** 2
    landed = jax.lax.stop_gradient(on_own.active & away).sum()
    external = tool_forces.on_slaves + coupling.own_forces(on_own, own, k[mesh.slaves], mesh.slaves)
    tied = ~released
    ties = mesh.partner.at[mesh.base_line].set(jnp.where(tied, mesh.chip_line, mesh.base_line))
    ties = ties.at[mesh.chip_line].set(jnp.where(tied, mesh.base_line, mesh.chip_line))
    body, plastic = explicit.step(
        cut.scaled,
        mesh.quads,
        state.body,
        external,
        jnp.asarray(cut.dt, dtype),
        # Debris (the nodes of eroded elements only) stops where it is.
        explicit.Boundary(fixed=mesh.fixed | ~kept[:, None], ties=ties),
        alive=state.alive,
        viscosity=VISCOSITY,
    )
    # Erosion: an element squeezed at a Gauss point to ``erode`` of its area
    # is folding (it would turn inside out next): it is taken out, and counted.
    distortion = q4.distortion(mesh.quads, body.x)
    alive = state.alive & (distortion > cut.erode)
    record = Record(
        force=tool_forces.on_master.sum(0),
        tool_depth=jnp.max(jnp.where(on_tool.active, -on_tool.gap, 0)),
        own_depth=jnp.max(jnp.where(on_own.active, -on_own.gap, 0)),
        tool_contacts=on_tool.active.sum(),
        own_contacts=on_own.active.sum(),
        released=released.sum(),
        eroded=(~alive).sum(),
        dropped=guarded.deep.sum(),
        landed=landed,
        overflow=tool_state.overflow | own_state.overflow,
    )
    rate = plastic.mean(1) / cut.dt
    after = State(
        body, tool_state, own_state, friction, released, alive, state.step + 1, state.mass, rate
    )
    pressed = jnp.where(on_tool.active, k * -on_tool.gap, 0)
    cap = jnp.asarray(law.limit, dtype) * jnp.asarray(law.share, dtype) * jnp.ones_like(pressed)
    tangent = jnp.stack([-on_tool.normal[:, 1], on_tool.normal[:, 0]], -1)
    sliding = jnp.abs(jnp.sum(tool_forces.on_slaves * tangent, -1))
    zorev = pressed * jnp.asarray(mu, dtype) > cap
    at_cap = on_tool.active & zorev & (sliding >= (1 - AT_CAP) * cap)
    seen = Seen(
        x,
        lowest_x,
        on_tool,
        tool_forces.on_slaves,
        cap,
        at_cap,
        distortion,
        jnp.asarray(jnp.nan, dtype),
    )
    return after, record, seen


def rezone(model: Model, state: State, rake) -> State:
    """The chip root rezoned and the state remapped (``sim.ale``): the nodes within
    ``window`` uncut thicknesses of the edge smoothed, those on a boundary sliding
    along it, so that the chip's underside on the rake face moves with the chip
    above it (the sticking layer would shear its first row of elements into
    slivers), then the elements' state, the masses and the velocities carried
    over. Pinned: the blocks' corners, the held nodes, the parting line's tied
    pairs and the crack tip (the first released pair), and the nodes of an
    eroded element.

    The tool's slip history is read again at the moved nodes, placed where their
    material was a step ago (``x - dt v``, exact for central differences), so that
    the next step's slip is the material's, not the rezone's. The friction's
    tangential force stays with each node."""
    cut, mesh = model.cut, model.mesh
    settings = cut.ale
    x, body = state.body.x, state.body
    lowest_x = tool_position(cut, model.start_x, state.step)
    centre = jnp.stack([lowest_x, jnp.asarray(cut.parting_y, x.dtype)])
    near = jnp.sum((x - centre[None, :]) ** 2, -1) < (cut.window * cut.uncut) ** 2
    # The crack tip: the released pair next to a tied one (the line runs left to right).
    tip = state.released & ~jnp.concatenate([jnp.ones(1, bool), state.released[:-1]])
    held_line = ~state.released | tip
    line = jnp.zeros(x.shape[0], bool).at[mesh.base_line].set(held_line)
    line = line.at[mesh.chip_line].set(held_line)
    whole = _at_nodes(mesh, ~state.alive) == 0
    movable = near & ~mesh.pinned & ~line & whole
    moved = ale.rezone(mesh.tables, mesh.quads, x, movable, mesh.along, settings)
    mass, points = ale.remap_points(
        mesh.tables, mesh.quads, x, moved, state.mass, body.points, order=settings.order
    )
    v = ale.remap_velocity(mesh.tables, mesh.quads, x, moved, body.v)
    before = tool_surface(cut, tool_position(cut, model.start_x, state.step - 1), rake)
    _, tool_state = _on_tool(model, state.tool, moved - cut.dt * v, before, held(mesh, state.alive))
    body = body._replace(x=moved, v=v, points=points)
    return state._replace(body=body, tool=tool_state, mass=mass)


def _scan(model: Model, state: State, rake, mu, steps: int, until=None, probe=None):
    """``steps`` steps: ``(state, record)``; with ``probe``, ``(state, (record, probed))``."""

    def hold(state, after):
        if until is None:
            return after
        # From step ``until`` on, a step is worked out and dropped: the state
        # stands still (and its rows of the record are no steps).
        go = state.step < until
        return jax.tree.map(lambda new, old: jnp.where(go, new, old), after, state)

    if probe is None:

        def one(state):
            after, record = step(model, state, rake, mu)
            return hold(state, after), record

        def adapt(state):
            return hold(state, rezone(model, state, rake))

    else:
        # The carry holds the last rezone's largest move until the next step reports it.
        def one(carry):
            state, moved = carry
            after, record, seen = inspect_step(model, state, rake, mu)
            probed = probe(model, state, after, seen._replace(rezoned=moved))
            return (hold(state, after), jnp.full_like(moved, jnp.nan)), (record, probed)

        def adapt(carry):
            state, _ = carry
            after = hold(state, rezone(model, state, rake))
            return after, jnp.max(jnp.abs(after.body.x - state.body.x))

        nothing = jnp.asarray(jnp.nan, jnp.dtype(model.cut.dtype))
        state, outputs = _scan_steps(model, one, adapt, (state, nothing), steps)
        return state[0], outputs
    return _scan_steps(model, one, adapt, state, steps)


def _scan_steps(model: Model, one, adapt, carry, steps: int):
    if model.cut.ale is None:
        return jax.lax.scan(lambda carry, _: one(carry), carry, None, length=steps)
    return ale.cycles(one, adapt, carry, length=steps, every=model.cut.ale.every)


def chunk_steps(cut: Cutting, steps: int) -> int:
    """``steps`` rounded up to whole ALE cycles (``Cutting.ale.every``): a scan's length."""
    every = 1 if cut.ale is None else cut.ale.every
    return every * math.ceil(steps / every)


_advance = jax.jit(_scan, static_argnums=(4, 6))
_NEVER = np.iinfo(np.int32).max


def advance(model: Model, state: State, rake, mu, steps: int, until=None):
    """``steps`` steps from ``state``: ``(state, Record of each step)`` (jitted).

    ``until`` (a step number; None: never): the state stands still once
    ``state.step`` reaches it, and the rows from there on are no steps. A
    traced number, so chunks of a run with a shorter last one, and any other scan
    of a chunk's length (a benchmark's), are one compiled program.
    """
    if steps != chunk_steps(model.cut, steps):
        raise ValueError(
            f"advance's steps must be whole ALE cycles of {model.cut.ale.every} steps "
            f"(cutting.chunk_steps); got {steps}"
        )
    until = jnp.asarray(_NEVER if until is None else until, jnp.int32)
    return _advance(model, state, rake, mu, steps, until)


def observe(model: Model, state: State, rake, mu, steps: int, probe, until=None):
    """``advance`` with a look at every step: ``(state, record, probed)``, the
    rows of ``probe(model, before, after, seen)`` (a pytree of fixed shapes
    from the ``State`` before and after the step and its ``Seen``) stacked
    one per step. ``probe`` is a static argument (a new function recompiles):
    it reduces what a step saw to what a diagnosis keeps (a profile, a few
    numbers), so that thousands of steps of it fit in memory."""
    if steps != chunk_steps(model.cut, steps):
        raise ValueError(
            f"observe's steps must be whole ALE cycles of {model.cut.ale.every} steps "
            f"(cutting.chunk_steps); got {steps}"
        )
    if not callable(probe):
        raise ValueError(f"observe's probe must be a function; got {type(probe).__name__}")
    until = jnp.asarray(_NEVER if until is None else until, jnp.int32)
    state, (record, probed) = _advance(model, state, rake, mu, steps, until, probe)
    return state, record, probed


def mean_forces(model: Model, state: State, rake, mu, steps: int | None = None, last: float = 0.4):
    """The mean force on the tool (f[2], N/mm) over the ``last`` share of a run of
    ``steps`` steps (the whole cut by default) from ``state``: differentiable in
    ``rake`` (radians) and ``mu``."""
    steps = model.cut.steps if steps is None else steps
    length = chunk_steps(model.cut, steps)
    # Held still past ``steps`` only where whole ALE cycles run longer.
    until = None if length == steps else state.step + steps
    _, record = _scan(model, state, rake, mu, length, until)
    window = max(1, round(last * steps))
    return record.force[steps - window : steps].mean(0)


class Frame(NamedTuple):
    """A snapshot of the run on the host (for pictures and checks)."""

    step: int
    x: np.ndarray  # f[N, 2]
    plastic_strain: np.ndarray  # f[E, 4]
    temperature: np.ndarray  # f[E, 4]  (K)
    alive: np.ndarray  # bool[E]


def run(cut: Cutting, rake_deg: float = 0.0, mu: float = MU, chunks: int = 40, progress=None):
    """The whole cut, ``cut.steps`` steps, in ``chunks`` calls of one compiled
    program; ``progress(done, total)`` is called after each. Returns
    ``(model, state, record, frames, seconds)``: the ``Record`` of every
    step (NumPy, ``cut.steps`` rows), a ``Frame`` at the start and after each
    chunk, and the seconds the chunks took (compilation included in the first).

    The chunks are ``ceil(steps / chunks)`` steps long; the last one's steps
    past ``cut.steps`` are dropped (``advance``'s ``until``), so that the run
    ends where ``cut.steps`` says and the tool has moved ``cut.travel``
    (to within one step's motion), whatever the number of chunks."""
    model, state = setup(cut)
    total = cut.steps
    per = chunk_steps(cut, math.ceil(total / chunks))
    rake = jnp.asarray(math.radians(rake_deg), jnp.dtype(cut.dtype))
    mu = jnp.asarray(mu, jnp.dtype(cut.dtype))

    def frame(state):
        points = state.body.points
        return Frame(
            int(state.step),
            *jax.device_get((state.body.x, points.plastic_strain, points.temperature, state.alive)),
        )

    records, frames = [], [frame(state)]
    started = time.perf_counter()
    for done in range(per, total + per, per):
        state, record = advance(model, state, rake, mu, per, until=total)
        records.append(jax.device_get(record))
        frames.append(frame(state))
        if progress is not None:
            progress(min(done, total), total)
    seconds = time.perf_counter() - started
    record = jax.tree.map(lambda *parts: np.concatenate(parts)[:total], *records)
    return model, state, record, frames, seconds
