"""The cut to run: ``Cutting``, the frozen numbers of one orthogonal cut, and its tool.

Units: mm, N, tonne, s, K; the cutting speed in m/min (``Cutting.velocity``
in mm/s). ``model`` sets a ``Cutting`` up and runs it; the tool's outline
is drawn by ``jaxcontact.sim.tools``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from jax import Array

from jaxcontact import _removed
from jaxcontact.sim import ale, materials, tools

__all__ = [
    "ARC_SEGMENTS",
    "CLEARANCE_DEG",
    "Cutting",
    "FLANK",
    "LANDING",
    "MU",
    "PENMAX",
    "TOOL_NODES",
    "VISCOSITY",
    "cutting_tool",
    "tool_outline",
]

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
      shear_factor: Zorev's sticking limit ``m`` (``coupling.Zorev``): the
        friction stress in sticking is ``m k``, ``k`` the shear flow stress
        that ``friction_limit`` names; a traction, each node carrying it over
        its tributary length (``model.contact_share``). The default, half of
        AISI 1045's ``A / sqrt 3``, is 160 MPa.
      friction_limit: which shear flow stress ``k``: ``"flow"``, the chip's
        own, ``sigma_JC(eps_p, rate, T) / sqrt 3`` of the elements at each node
        (Oxley's sticking takes ``m = 1``); ``"initial"``, the material's
        initial ``A / sqrt 3`` everywhere (a constant cap).
      ale: the chip root's rezone and remap (``sim.ale.Settings``: every how
        many steps, the smoothing, the guard, the remap's order); None: a
        Lagrangian mesh throughout.
      window: the rezoned region: nodes within this many uncut thicknesses of
        the edge's centre.
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
    friction_limit: str = "initial"
    ale: ale.Settings | None = None
    window: float = 3.0
    rake_face: float = 1.0
    breaker: tuple[float, float, float] | None = None
    ahead: float | None = None
    dtype: str = "float32"
    work_material: materials.JohnsonCook = materials.AISI_1045

    def __post_init__(self):
        if self.friction_limit not in ("flow", "initial"):
            raise ValueError(
                "Cutting.friction_limit must be 'flow' (the chip's own shear flow stress) or "
                f"'initial' (A / sqrt 3); got {self.friction_limit!r}"
            )
        if self.ale is not None and not isinstance(self.ale, ale.Settings):
            raise ValueError(
                f"Cutting.ale must be a sim.ale.Settings or None; got {type(self.ale).__name__}"
            )
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
                flank_end, wall_end, land_end = corners[-4:-1]
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

    def __getattr__(self, name: str):
        # Only for names the class does not have: a removed one says what replaces it.
        raise _removed.attribute_error("jaxcontact.problems.cutting.Cutting", name)

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
    ``ARC_SEGMENTS`` segments, each face split one arc chord from the edge
    (``tools.Tool.split_faces``: the cut's contact normals are smooth, and
    the pressure on the flat rake face makes no thrust)."""
    return tools.Tool(
        edge_radius, CLEARANCE_DEG, rake_face, FLANK, ARC_SEGMENTS, breaker, split_faces=True
    )


TOOL_NODES = ARC_SEGMENTS + 6
