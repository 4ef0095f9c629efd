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
mesh with its parting line, node separation, the two tool outlines and the
report.

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
  tool and the workpiece at once, and a closest-point search gives each
  slave one segment. ``Search(track=True, normals="smooth")`` finds every
  node's contact with the tool; ``forces.coulomb`` gives the penalty and the
  friction from the slip history, its reaction on the tool's nodes the
  cutting force. Friction is Coulomb's ``mu`` times the pressure, capped at
  ``shear_factor`` times the steel's shear flow stress ``A / sqrt 3`` over a
  node's share of the face (Zorev, 1963; Shirakashi and Usui, 1973):
  without the cap, the sticking zone shears the chip's first row of elements
  into slivers. ``Pairs(self_contact=True)`` over the pool of outline
  segments finds the chip against the machined surface, the workpiece and
  itself; ``forces.penalty`` acts on both sides, frictionless. Near the
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
from jaxcontact.sim import coupling, explicit, machining, materials, tools
from jaxcontact.sim._moved import forward as _forward
from jaxcontact.sim.elements import q4

CLEARANCE_DEG = 7.0
MU = 0.3  # Coulomb's coefficient on the tool by default
# Bulk viscosity (linear, quadratic): LS-DYNA's default linear coefficient;
# no quadratic term, whose damping grows with the rate and would outrun the
# fixed step.
VISCOSITY = (0.06, 0.0)
PENMAX = 0.25  # own contacts deeper than this many elements are not contacts
# An own contact farther than this many uncut thicknesses from the edge's
# lowest point is the chip landing on the workpiece or on itself (nearer, it
# is the chip's root on the machined surface at the crack tip).
LANDING = 2.0
ARC_SEGMENTS = 8
FLANK = 0.3  # the flank's length (mm)


@dataclasses.dataclass(frozen=True)
class Cutting:
    """The cut and its mesh: static (hashable) numbers; the rake angle and
    ``mu`` are traced arguments of ``run`` and ``mean_forces``.

    Attributes:
      speed: cutting speed (m/min).
      uncut: uncut chip thickness ``h`` (mm).
      travel: how far the tool cuts (mm).
      element: edge of the square elements (mm).
      depth: the base's height below the parting line (mm).
      edge_radius: the tool's cutting-edge radius (mm).
      mass_scaling: the density's factor (1: none).
      safety: the time step over the smallest element's stable step.
      separation: the critical distance of node separation (mm; default a quarter element).
      stiffness: the penalty and stick stiffness of node ``i``, in units of
        ``m_i / dt^2`` (N/mm per mm of width, per mm of penetration): stable
        in the explicit step below about 1 (about 0.5 E at the default on an
        edge node).
      ramp: share of the travel over which the tool's speed ramps up.
      erode: the Jacobian ratio below which an element is eroded.
      shear_factor: Zorev's sticking limit, in units of the material's initial
        shear flow stress ``A / sqrt 3`` (``coupling.Zorev``).
      rake_face: the rake face's length (mm): a chip longer than it climbs
        over the tool's top.
      breaker: ``(land, angle, length)``: a chip breaker's backwall, the
        rake face ``land`` mm long, then a wall ``length`` mm long turned
        ``angle`` degrees from the rake face towards the chip (the chip is
        bent away from the face); None: a plain rake face of ``rake_face``.
      ahead: the uncut length left ahead of the tool at the end (mm;
        default three uncut thicknesses): room for a curled chip to land.
      dtype: the float dtype of the run.
      work_material: the workpiece's ``materials.JohnsonCook`` (AISI 1045
        after Jaspers and Dautzenberg, 2002, by default). Its ``mass_scale`` is
        replaced by ``mass_scaling`` (``scaled``).
    """

    speed: float = 100.0
    uncut: float = 0.10
    travel: float = 0.8
    element: float = 0.025
    depth: float = 0.2
    edge_radius: float = 0.02
    mass_scaling: float = 400.0
    safety: float = 0.3
    separation: float | None = None
    stiffness: float = 0.2
    ramp: float = 0.05
    erode: float = 0.1
    shear_factor: float = 0.5
    rake_face: float = 1.0
    breaker: tuple[float, float, float] | None = None
    ahead: float | None = None
    dtype: str = "float32"
    work_material: materials.JohnsonCook = materials.AISI_1045

    def __post_init__(self):
        if not isinstance(self.work_material, materials.JohnsonCook):
            raise ValueError(
                "Cutting.work_material must be a materials.JohnsonCook (the friction limit "
                f"reads its A); got {type(self.work_material).__name__}"
            )
        if not self.rake_face > 0:
            raise ValueError(f"Cutting.rake_face must be > 0 mm; got {self.rake_face!r}")
        if self.ahead is not None and not self.ahead >= 0:
            raise ValueError(f"Cutting.ahead must be >= 0 mm or None; got {self.ahead!r}")
        if self.breaker is not None:
            try:
                # The tool checks the breaker's form (three numbers, an angle in (0, 90)).
                breaker = self.tool.breaker
            except ValueError as error:
                raise ValueError(f"Cutting.breaker: {error}") from None
            object.__setattr__(self, "breaker", breaker)
            # The land is measured from the sharp tip: it must reach past the
            # edge's tangent point on the rake face, r / tan(wedge / 2) from the
            # tip, farthest at the sharpest wedge the demo takes (rake +30°).
            wedge = math.radians(90.0 - 30.0 - CLEARANCE_DEG)
            tangent = self.edge_radius / math.tan(wedge / 2)
            if not breaker[0] > tangent:
                raise ValueError(
                    f"Cutting.breaker's land needs land > the edge's tangent point "
                    f"({tangent:.3g} mm from the tip at a rake of 30°); got {self.breaker!r}"
                )
            # The outline stays one simple polygon at every rake the demo takes
            # (±30°): the land's end left of the line from the flank's end to
            # the wall's end (a short, steep wall would fold the outline).
            for rake in (-30.0, 0.0, 30.0):
                corners = np.asarray(
                    tool_outline(
                        np.zeros(2), math.radians(rake), self.edge_radius, np.float32,
                        breaker=self.breaker,
                    )
                )  # fmt: skip
                flank_end, wall_end, land_end = corners[-3:]
                a, b = wall_end - flank_end, land_end - flank_end
                if a[0] * b[1] - a[1] * b[0] <= 0:
                    raise ValueError(
                        f"Cutting.breaker {self.breaker!r} folds the tool's outline at a "
                        f"rake of {rake:g}°: the wall must reach past the line from the "
                        "flank's end to the land's end (a longer wall or a smaller angle)"
                    )

    # -- derived numbers -----------------------------------------------------

    @property
    def velocity(self) -> float:
        """The tool's speed in mm/s."""
        return self.speed * 1000.0 / 60.0

    @property
    def scaled(self) -> materials.JohnsonCook:
        """``work_material`` with its inertia scaled by ``mass_scaling``
        (``materials``: heating keeps the true density)."""
        return self.work_material._replace(mass_scale=self.mass_scaling)

    @property
    def material(self) -> materials.JohnsonCook:
        """Deprecated: ``scaled`` (1.1's ``material`` was the mass-scaled steel)."""
        warnings.warn(
            "Cutting.material is deprecated: use Cutting.scaled (mass-scaled, as "
            "Cutting.material was) or Cutting.work_material",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.scaled

    @property
    def tool(self) -> tools.Tool:
        """The tool's static geometry."""
        return cutting_tool(self.edge_radius, self.rake_face, self.breaker)

    @property
    def columns(self) -> int:
        """Elements along the workpiece: the travel and ``ahead`` (three uncut thicknesses) more."""
        ahead = 3 * self.uncut if self.ahead is None else self.ahead
        return max(4, round((self.travel + ahead + 2 * self.element) / self.element))

    @property
    def chip_rows(self) -> int:
        return max(1, round(self.uncut / self.element))

    @property
    def base_rows(self) -> int:
        return max(1, round(self.depth / self.element))

    @property
    def dt(self) -> float:
        """The time step (s): ``safety`` times the smallest element's stable step."""
        return self.safety * self.element / materials.wave_speed(self.scaled)

    @property
    def steps(self) -> int:
        """Steps to cut ``travel`` with the ramp (the tool moves ``travel`` in all)."""
        return math.ceil(self.travel / (self.velocity * self.dt) + self.ramp_steps / 2)

    @property
    def ramp_steps(self) -> int:
        return max(1, round(self.ramp * self.travel / (self.velocity * self.dt)))

    @property
    def element_steps(self) -> int:
        """The steps one element's travel takes at full speed (at least 1): node
        separation releases a pair once per element, so the force cycles over this."""
        return max(1, round(self.element / (self.velocity * self.dt)))

    @property
    def critical_distance(self) -> float:
        return 0.25 * self.element if self.separation is None else self.separation

    @property
    def parting_y(self) -> float:
        """The parting line's height above the workpiece's bottom (mm)."""
        return self.base_rows * self.element

    @property
    def radius(self) -> float:
        """The contact search radius (mm): half an element, beyond any penetration."""
        return 0.5 * self.element


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
    return Workpiece(
        q4.Quads(jnp.asarray(nodes, dtype), jnp.asarray(quads), jnp.asarray(mass, dtype)),
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
    )


def tool_outline(
    lowest: Array, rake, edge_radius: float, dtype, rake_face: float = 0.6, breaker=None
) -> Array:
    """f[TOOL_NODES, 2]: the cut's tool (``tools.outline``), its edge's lowest point at
    ``lowest`` (f[2]), ``rake`` in radians (traced): a 7° clearance, a flank
    0.3 mm and a rake face ``rake_face`` mm from the sharp tip, the edge drawn
    by ``ARC_SEGMENTS`` segments, an optional ``breaker``."""
    tool = cutting_tool(edge_radius, rake_face, breaker)
    return tools.outline(tool, rake, lowest=lowest, dtype=dtype)


def cutting_tool(edge_radius: float, rake_face: float, breaker=None) -> tools.Tool:
    """The cut's ``tools.Tool``: a 7° clearance, a flank of 0.3 mm, the edge drawn by
    ``ARC_SEGMENTS`` segments."""
    return tools.Tool(edge_radius, CLEARANCE_DEG, rake_face, FLANK, ARC_SEGMENTS, breaker)


TOOL_NODES = ARC_SEGMENTS + 4


class State(NamedTuple):
    """What the scan carries from step to step."""

    body: explicit.Body
    tool: jaxcontact.SearchState  # the search against the tool (with slip history)
    own: jaxcontact.SearchState  # the search against the workpiece's own outline
    friction: Friction  # Coulomb's state on the rake face and the flank
    released: Array  # bool[L]  parting-line pairs separated
    alive: Array  # bool[E]  elements not eroded
    step: Array  # i32[]


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


def held(mesh: Workpiece, alive: Array) -> Array:
    """bool[N]: nodes of at least one element not eroded (the others are debris)."""
    count = jnp.zeros(mesh.quads.nodes.shape[0], jnp.int32)
    return count.at[mesh.quads.quads].add(alive[:, None].astype(jnp.int32)) > 0


def setup(cut: Cutting) -> tuple[Model, State]:
    """The mesh, the searches and the state at rest, the tool just clear of the workpiece."""
    mesh = workpiece(cut)
    # Two searches, because a node at the edge touches the tool and the
    # workpiece at once (the chip's underside meets the machined surface
    # there), and a closest-point search gives each slave its one closest
    # segment: one search per master gives each node its contact with each.
    tool_search = jaxcontact.Search(
        radius=cut.radius, method="exhaustive", track=True, normals="smooth"
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
    start = State(body, tool, own, friction, released, alive, jnp.zeros((), jnp.int32))
    return model, start


def _contacts(model: Model, tool_state, own_state, x, lowest_x, rake, released, alive, kept):
    """A step's contact detection, the two searches: ``(tool, on_tool,
    tool_state, slip, own, on_own, own_state)``, the surfaces with what each
    search found and its state. ``step`` and ``detection_share`` both run this."""
    mesh = model.mesh
    tool = tool_surface(model.cut, lowest_x, rake)
    on_tool, tool_state, slip = model.tool_search.closest(
        tool_state, x, tool, mask=kept, pairs=jaxcontact.Pairs(slave_body=mesh.side)
    )
    own = own_surface(mesh, x, released, alive)
    on_own, own_state = model.own_search.closest(
        own_state,
        x[mesh.slaves],
        own,
        mask=kept[mesh.slaves],
        pairs=jaxcontact.Pairs(slave_node=mesh.slaves, self_contact=True),
    )
    return tool, on_tool, tool_state, slip, own, on_own, own_state


def friction_law(cut: Cutting, mu) -> coupling.Zorev:
    """The tool's friction: Coulomb's ``mu``, up to Zorev's sticking limit of
    ``shear_factor`` times the material's initial shear flow stress, each
    node's share of the face an element's length."""
    return coupling.Zorev(mu, cut.shear_factor * cut.work_material.shear_yield, cut.element)


def step(model: Model, state: State, rake, mu) -> tuple[State, Record]:
    """One explicit step of the cut (``rake`` in radians, ``mu`` the friction coefficient)."""
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
    tool, on_tool, tool_state, slip, own, on_own, own_state = _contacts(
        model, state.tool, state.own, x, lowest_x, rake, released, state.alive, kept
    )
    # The tool: penalty, and Zorev's sticking and sliding from the slip
    # history, each node's share of the face an element.
    tool_forces, friction = coupling.friction_forces(
        on_tool, slip, state.friction, tool, k, friction_law(cut, mu)
    )
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
    body, _ = explicit.step(
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
    alive = state.alive & (q4.distortion(mesh.quads, body.x) > cut.erode)
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
    after = State(body, tool_state, own_state, friction, released, alive, state.step + 1)
    return after, record


def _scan(model: Model, state: State, rake, mu, steps: int, until=None):
    def body(state, _):
        after, record = step(model, state, rake, mu)
        if until is not None:
            # From step ``until`` on, a step is worked out and dropped: the
            # state stands still (and its rows of the record are no steps).
            go = state.step < until
            after = jax.tree.map(lambda new, old: jnp.where(go, new, old), after, state)
        return after, record

    return jax.lax.scan(body, state, None, length=steps)


_advance = jax.jit(_scan, static_argnums=4)
_NEVER = np.iinfo(np.int32).max


def advance(model: Model, state: State, rake, mu, steps: int, until=None):
    """``steps`` steps from ``state``: ``(state, Record of each step)`` (jitted).

    ``until`` (a step number; None: never): the state stands still once
    ``state.step`` reaches it, and the rows from there on are no steps. A
    traced number, so chunks of a run with a shorter last one, and
    ``detection_share``'s scan of a chunk's length, are one compiled program.
    """
    until = jnp.asarray(_NEVER if until is None else until, jnp.int32)
    return _advance(model, state, rake, mu, steps, until)


def mean_forces(model: Model, state: State, rake, mu, steps: int | None = None, last: float = 0.4):
    """The mean force on the tool (f[2], N/mm) over the ``last`` share of a run of
    ``steps`` steps (the whole cut by default) from ``state``: differentiable in
    ``rake`` (radians) and ``mu``."""
    steps = model.cut.steps if steps is None else steps
    _, record = _scan(model, state, rake, mu, steps)
    window = max(1, round(last * steps))
    return record.force[-window:].mean(0)


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
    per = math.ceil(total / chunks)
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
    for done in range(per, per * chunks + 1, per):
        state, record = advance(model, state, rake, mu, per, until=total)
        records.append(jax.device_get(record))
        frames.append(frame(state))
        if progress is not None:
            progress(min(done, total), total)
    seconds = time.perf_counter() - started
    record = jax.tree.map(lambda *parts: np.concatenate(parts)[:total], *records)
    return model, state, record, frames, seconds


# -- what a run measured ----------------------------------------------------

# The steady state of the forces: a criterion defined here, not taken from a
# source. A window of the run's last steps is steady when the least-squares
# line through each force component (raw, every step) changes across the
# window by at most STEADY_DRIFT of that component's mean. A component whose
# mean is under SMALL_FLOOR of the mean resultant is judged against that
# floor instead (a thrust near 0 N/mm has no meaningful percentage).
STEADY_DRIFT = 0.05
SMALL_FLOOR = 0.1
# The shortest window, and the one the means fall back on when none is
# steady: the last 40 % of the steps (the convention of the summary's forces
# before the criterion, kept so that their meaning stays where no steady
# state shows).
LAST = 0.4


class Window(NamedTuple):
    """Where a run's forces are averaged, and how far they drift there (plain numbers)."""

    start: int  # the window's first row of the record (it runs to the last)
    steady: bool  # the criterion held from ``start`` on (False: the fallback, the last LAST)
    mean: np.ndarray  # f[2]  the mean force over the window (N/mm): cutting, thrust
    drift: np.ndarray  # f[2]  the line's change across the window, % of the judged mean


def _drift(travel: np.ndarray, force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mean (f[2]) and the least-squares line's change across the window
    in % of the judged mean (f[2]) of ``force`` (f[T, 2]) against ``travel`` (f[T])."""
    mean = force.mean(axis=0)
    s = travel - travel.mean()
    spread = float(np.sum(s * s))
    # No travel across the window (one row): no line, and no steady state.
    slope = (s @ (force - mean)) / spread if spread > 0 else np.full(2, np.nan)
    judged = np.maximum(np.abs(mean), SMALL_FLOOR * np.hypot(*mean))
    with np.errstate(divide="ignore", invalid="ignore"):
        drift = 100 * slope * (travel[-1] - travel[0]) / judged
    return mean, drift


def steady_window(
    travel, force, spacing: float, tolerance: float = STEADY_DRIFT, last: float = LAST
) -> Window:
    """The window the forces are averaged over: from the earliest start, on a
    grid of ``spacing`` mm of travel back from the start of the last ``last``
    of the rows, such that the window from it and every later start on the
    grid drifts by at most ``tolerance`` (``STEADY_DRIFT``); when even the
    last ``last`` drifts more, that window, not steady.

    ``travel`` (f[T], mm, not decreasing) and ``force`` (f[T, 2], N/mm) are
    a run's rows. ``spacing`` is the element's edge in a cut: a window then
    holds whole cycles of the dip each pair release causes (``release_dips``),
    which would otherwise tilt the line. Every window ends at the run's end:
    a steady state lasts once reached."""
    travel = np.asarray(travel, np.float64)
    force = np.asarray(force, np.float64)
    rows = len(force)
    if rows == 0 or force.shape != (rows, 2) or travel.shape != (rows,):
        raise ValueError(
            f"steady_window needs travel f[T] and force f[T, 2] with T >= 1; "
            f"got {travel.shape} and {force.shape}"
        )
    if not spacing > 0:
        raise ValueError(f"steady_window's spacing must be > 0 mm; got {spacing!r}")
    if not (tolerance > 0 and 0 < last <= 1):
        raise ValueError(
            f"steady_window needs tolerance > 0 and 0 < last <= 1; got {tolerance!r} and {last!r}"
        )
    shortest = rows - max(1, round(last * rows))
    starts = [shortest]
    while True:
        row = int(np.searchsorted(travel, travel[starts[-1]] - spacing, side="left"))
        if row >= starts[-1] or travel[starts[-1]] - spacing < travel[0]:
            break
        starts.append(row)
    found = None
    for start in starts:  # the shortest window first, then ever longer
        _, drift = _drift(travel[start:], force[start:])
        if not np.all(np.abs(drift) <= 100 * tolerance):
            break
        found = start
    start = shortest if found is None else found
    mean, drift = _drift(travel[start:], force[start:])
    return Window(start, found is not None, mean, drift)


class Dips(NamedTuple):
    """How the cutting force falls at the release of the parting line's pairs (node
    separation), one entry per release with a whole element's cycle of rows around it."""

    releases: np.ndarray  # i[R]  every row at which a pair (or more) was released
    lag: np.ndarray  # i[C]  rows from a release to F_c's lowest in the cycle around it
    depth: np.ndarray  # f[C]  that lowest below the cycle's mean F_c (N/mm)


def release_dips(record: Record, cycle: int) -> Dips:
    """The dips in F_c against the release steps of the tied pairs.

    ``cycle``: the rows one element's travel takes (the releases come once
    per element). For each release with a whole cycle around it (half before,
    half after), the row of F_c's lowest value in that cycle, counted from the
    release, and how far it lies below the cycle's mean. Were the dips not
    the releases' doing, the lags would spread over the cycle."""
    released = np.asarray(record.released)
    force = np.asarray(record.force, np.float64)[:, 0]
    releases = np.flatnonzero(np.diff(released) > 0) + 1
    half = max(1, cycle // 2)
    lag, depth = [], []
    for row in releases:
        if row - half < 0 or row + half > len(force):
            continue
        around = force[row - half : row + half]
        lowest = int(np.argmin(around))
        lag.append(lowest - half)
        depth.append(float(around.mean() - around[lowest]))
    return Dips(releases, np.asarray(lag, np.int64), np.asarray(depth, np.float64))


def _inside(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """bool[K]: points strictly inside a closed polygon (even-odd rule, on the host)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    px, py = points[:, None, 0], points[:, None, 1]
    crosses = (a[None, :, 1] > py) != (b[None, :, 1] > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = a[None, :, 0] + (py - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (
            b[None, :, 1] - a[None, :, 1]
        )
    return (crosses & (px < at)).sum(axis=1) % 2 == 1


def chip_thickness(model: Model, state: State) -> float:
    """The steady chip's thickness (mm): the median distance from its free
    surface's nodes to its underside (the released nodes of the parting line),
    for the material cut in the later half of the run, more than two uncut
    thicknesses behind the edge."""
    cut, mesh = model.cut, model.mesh
    x = np.asarray(state.body.x, np.float64)
    reference = np.asarray(mesh.quads.nodes, np.float64)
    kept = np.asarray(held(mesh, state.alive))
    front = float(tool_position(cut, model.start_x, state.step)) - cut.edge_radius
    underside = np.asarray(mesh.chip_line)[np.asarray(state.released)]
    underside = underside[kept[underside]]
    top = np.asarray(mesh.top)
    start = front + 2 * cut.uncut
    cut_at = reference[top, 0]
    steady = top[(cut_at > start) & (cut_at < start + 0.5 * cut.travel) & kept[top]]
    if len(steady) == 0 or len(underside) < 2:
        return float("nan")
    return float(np.median(_distance_to(x[steady], x[underside], closed=False)))


def _distance_to(points: np.ndarray, polygon: np.ndarray, closed: bool = True) -> np.ndarray:
    """f[K]: each point's distance to a polygon's boundary (a closed one, or an
    open polyline with ``closed=False``)."""
    if closed:
        a, b = polygon, np.roll(polygon, -1, axis=0)
    else:
        a, b = polygon[:-1], polygon[1:]
    p = points[:, None, :]
    t = np.sum((p - a) * (b - a), -1) / np.maximum(np.sum((b - a) ** 2, -1), 1e-30)
    closest = a + np.clip(t, 0, 1)[..., None] * (b - a)
    return np.linalg.norm(p - closest, axis=-1).min(axis=1)


def deepest_in_tool(model: Model, rake_deg: float, frames) -> float:
    """The deepest any workpiece node lies inside the tool (mm) over the
    frames, by point-in-polygon on the host: the check that owes nothing to
    the contact search. Each node is tested against the tool as its side
    meets it (``CHIP_SIDE``, ``BASE_SIDE``)."""
    cut, mesh = model.cut, model.mesh
    side = np.asarray(mesh.side)
    deepest = 0.0
    for frame in frames:
        surface = tool_surface(
            cut, tool_position(cut, model.start_x, frame.step), math.radians(rake_deg)
        )
        nodes = np.asarray(surface.nodes, np.float64)
        x = np.asarray(frame.x, np.float64)
        kept = np.asarray(held(mesh, jnp.asarray(frame.alive)))
        for label in (0, 1):
            # Side 0 (the uncut layer) meets body 1's outline, side 1 body 0's.
            outline = nodes[(1 - label) * TOOL_NODES : (2 - label) * TOOL_NODES]
            points = x[kept & (side == label)]
            inside = _inside(points, outline)
            if inside.any():
                deepest = max(deepest, float(_distance_to(points[inside], outline).max()))
    return deepest


def _steady_elements(model: Model, state: State) -> np.ndarray:
    """bool[E]: the uncut layer's live elements cut in the steady part of the
    run (the chip of the later half, more than two uncut thicknesses behind
    the edge)."""
    cut, mesh = model.cut, model.mesh
    reference = np.asarray(mesh.quads.nodes, np.float64)[np.asarray(mesh.quads.quads)]
    centre = reference.mean(axis=1)
    front = float(tool_position(cut, model.start_x, state.step)) - cut.edge_radius
    start = front + 2 * cut.uncut
    layer = centre[:, 1] > cut.parting_y
    window = (centre[:, 0] > start) & (centre[:, 0] < start + 0.5 * cut.travel)
    return layer & window & np.asarray(state.alive)


def _material_name(material: materials.JohnsonCook) -> str:
    if material == materials.AISI_1045:
        return "AISI 1045 (Johnson-Cook, Jaspers and Dautzenberg 2002)"
    fit = ", ".join(f"{name}={getattr(material, name):g}" for name in "ABnCm")
    return f"Johnson-Cook ({fit})"


def summary(model: Model, state: State, record: Record, frames, seconds: float, rake_deg, mu):
    """What the run measured, and the analyses set beside it (plain numbers;
    docs/simulation.md's "The demo's summary.json" lists every key).

    Forces are the means (N per mm of width) over ``steady_window``'s
    window: from where the forces are steady to the end, or, when they are
    not steady in the run, the last 40 % of the steps, with the drift there
    (``forces_steady``, ``force_window_mm``, ``*_drift_percent``); the
    dips of F_c at the pair releases, by ``release_dips``. The chip's
    thickness, strain and temperature are those of the steady chip
    (``_steady_elements``); Merchant's shear stress is the Johnson–Cook flow
    stress over sqrt 3 at the steady chip's median plastic strain and
    temperature and the 90th percentile of the uncut layer's plastic strain
    rate over the last frame (the primary shear zone's).
    """
    cut = model.cut
    rows = len(record.force)
    # Row k of the record is the step from k to k + 1.
    travel = tool_travel(cut, np.arange(1, rows + 1))
    window = steady_window(travel, record.force, cut.element)
    cutting_force, thrust = (float(v) for v in window.mean)
    cycle = cut.element_steps
    dips = release_dips(record, cycle)
    # A dip is the release's when F_c's lowest in the cycle comes within a
    # tenth of the cycle after it.
    after = (dips.lag >= 0) & (dips.lag <= cycle // 10)
    thickness = chip_thickness(model, state)
    ratio = cut.uncut / thickness
    phi = machining.shear_angle_from_chip(ratio, rake_deg)
    beta = machining.friction_angle_from_forces(cutting_force, thrust, rake_deg)
    steady = _steady_elements(model, state)
    strain = np.asarray(state.body.points.plastic_strain, np.float64)[steady]
    temperature = np.asarray(state.body.points.temperature, np.float64)[steady]
    last, before = frames[-1], frames[-2]
    elapsed = (last.step - before.step) * cut.dt
    rates = (last.plastic_strain - before.plastic_strain).mean(axis=1) / elapsed
    layer = np.asarray(model.mesh.quads.nodes)[np.asarray(model.mesh.quads.quads)].mean(1)[:, 1]
    flowing = rates[(layer > cut.parting_y) & last.alive & (rates > 0)]
    rate = float(np.percentile(flowing, 90)) if flowing.size else 1.0
    eps, hot = float(np.median(strain)), float(np.median(temperature))
    flow = float(cut.work_material.flow_stress(eps, rate, hot))
    tau = flow / math.sqrt(3)
    merchant_fc, merchant_ft = machining.merchant_forces(tau, cut.uncut, 1.0, rake_deg, beta)
    depth = max(
        float(np.max(record.tool_depth)),
        float(np.max(record.own_depth)),
        deepest_in_tool(model, rake_deg, frames),
    )
    k_c11, m_c = machining.KIENZLE_CK45
    landed = np.flatnonzero(np.asarray(record.landed) > 0)
    lands_at = travel_at(model, int(landed[0])) if landed.size else None
    return {
        "material": _material_name(cut.work_material),
        "cutting_speed_m_per_min": cut.speed,
        "uncut_chip_thickness_mm": cut.uncut,
        "rake_deg": float(rake_deg),
        "friction": float(mu),
        "friction_shear_factor": cut.shear_factor,
        "cutting_force_N_per_mm": cutting_force,
        "thrust_force_N_per_mm": thrust,
        "forces_steady": window.steady,
        "force_window_mm": [float(travel[window.start]), float(travel[-1])],
        "cutting_force_drift_percent": float(window.drift[0]),
        "thrust_force_drift_percent": float(window.drift[1]),
        "pair_releases": int(len(dips.releases)),
        "release_dip_cycles": int(len(dips.lag)),
        "release_dips_after_release": int(np.sum(after)),
        "release_dip_lag_steps": float(np.median(dips.lag)) if len(after) else float("nan"),
        "release_dip_N_per_mm": float(np.median(dips.depth)) if len(after) else float("nan"),
        "chip_thickness_mm": thickness,
        "chip_thickness_ratio": thickness / cut.uncut,
        "shear_angle_deg": phi,
        "friction_angle_deg": beta,
        "max_penetration_over_element": depth / cut.element,
        "nodes": int(model.mesh.quads.nodes.shape[0]),
        "elements": int(model.mesh.quads.quads.shape[0]),
        "eroded_elements": int(np.sum(~np.asarray(state.alive))),
        # The travel (mm) at which the chip first touched the workpiece or
        # itself away from the edge (None: it did not), and how many nodes at most.
        "chip_lands_at_travel_mm": lands_at,
        "chip_landing_contacts_max": int(np.max(record.landed, initial=0)),
        "steps": int(state.step),
        "time_step_s": cut.dt,
        "mass_scaling": cut.mass_scaling,
        "steps_per_second": int(state.step) / seconds,
        "chip_plastic_strain": eps,
        "chip_temperature_C": hot - 273.15,
        "shear_zone_strain_rate_per_s": rate,
        "merchant_shear_stress_MPa": tau,
        "merchant_shear_angle_deg": machining.merchant_shear_angle(rake_deg, beta),
        "merchant_cutting_force_N_per_mm": merchant_fc,
        "merchant_thrust_force_N_per_mm": merchant_ft,
        "kienzle_cutting_force_N_per_mm": machining.kienzle_force(cut.uncut),
        "kienzle_band_N_per_mm": [
            machining.kienzle_force(cut.uncut, constants=(1500.0, m_c)),
            machining.kienzle_force(cut.uncut, constants=(k_c11, m_c)),
        ],
        "overflow": bool(np.any(record.overflow)),
    }


def _detect(model: Model, state: State, rake, steps: int):
    """The step's two searches alone, ``steps`` times on ``state``'s
    configuration nudged each time (so that no search is hoisted out of the loop)."""
    x0 = state.body.x
    kept = held(model.mesh, state.alive)
    lowest_x = tool_position(model.cut, model.start_x, state.step)

    def body(carry, k):
        x = x0 + (k * 1e-9).astype(x0.dtype)
        _, on_tool, tool_state, _, _, on_own, own_state = _contacts(
            model, *carry, x, lowest_x, rake, state.released, state.alive, kept
        )
        return (tool_state, own_state), on_tool.gap.sum() + on_own.gap.sum()

    ks = jnp.arange(steps, dtype=x0.dtype)
    return jax.lax.scan(body, (state.tool, state.own), ks)


_detect_jit = jax.jit(_detect, static_argnums=3)


def detection_share(
    model: Model, state: State, rake_deg: float, mu: float, steps: int = 400, repeats: int = 3
) -> float:
    """The share of a step spent in contact detection: the time of the two
    searches alone over the time of whole steps, each ``steps`` long from
    ``state`` (compiled first, then the median of ``repeats`` alternated runs)."""
    dtype = jnp.dtype(model.cut.dtype)
    rake = jnp.asarray(math.radians(rake_deg), dtype)
    mu = jnp.asarray(mu, dtype)
    jax.block_until_ready(advance(model, state, rake, mu, steps))
    jax.block_until_ready(_detect_jit(model, state, rake, steps))
    ratios = []
    for _ in range(repeats):
        started = time.perf_counter()
        jax.block_until_ready(advance(model, state, rake, mu, steps))
        whole = time.perf_counter() - started
        started = time.perf_counter()
        jax.block_until_ready(_detect_jit(model, state, rake, steps))
        ratios.append((time.perf_counter() - started) / whole)
    return float(np.median(ratios))


__getattr__ = _forward(__name__, {"STEEL": "jaxcontact.sim.materials.AISI_1045"})
