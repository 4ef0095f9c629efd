"""The ploughing run to make: ``Ploughing``, its frozen numbers, and the scene's tool.

Units mm, N, t, s. ``model.setup`` turns a ``Ploughing`` into the mesh, the
traced controls and the static ``Plan`` of the run.
"""

from __future__ import annotations

import dataclasses

from jaxcontact.sim import tools
from jaxcontact.sim.materials import STEEL, Elastic

__all__ = ["MASS_SCALED_STEEL", "Ploughing", "SCENE_TOOL", "TIP_HEIGHT"]

MASS_SCALED_STEEL = STEEL._replace(mass_scale=1e4)
"""Steel with its density scaled by 10^4: the default workpiece (``model``'s docstring says why)."""

SCENE_TOOL = tools.Tool(edge_radius=0.05, clearance=7.0, rake_face=3.0, flank=3.0, arc_segments=16)
"""The cutting scene's tool (docs/scenes.md): a 7° clearance, faces 3 mm from the tip, an edge
of radius 0.05 drawn by 16 segments, the tip at ``TIP_HEIGHT`` = 4 (a depth of cut of 1 in a
workpiece 5 high)."""
TIP_HEIGHT = 4.0


@dataclasses.dataclass(frozen=True)
class Ploughing:
    """A ploughing run's numbers (hashable), which ``setup`` turns into a run.

    Attributes:
      num_nodes: about this many workpiece nodes (the cutting scene's sizing), >= 4.
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
      dtype: ``"float32"`` or ``"float64"``.
    """

    num_nodes: int = 10_000
    travel: float = 0.4
    speed: float = 3_000.0
    material: Elastic = MASS_SCALED_STEEL
    stiffness_factor: float = 10.0
    safety: float = 0.5
    damping_ratio: float = 0.3
    skin_factor: float = 0.5
    slack: float = 2.0
    rake_degrees: float = 10.0
    slaves: str = "surface"
    dtype: str = "float32"

    def __post_init__(self):
        if self.num_nodes < 4:
            raise ValueError(f"num_nodes must be at least 4; got {self.num_nodes}")
        if not (self.travel > 0 and self.speed > 0):
            raise ValueError(
                f"travel and speed must be > 0; got travel={self.travel}, speed={self.speed}"
            )
        if self.slaves not in ("surface", "all"):
            raise ValueError(f'slaves must be "surface" or "all"; got {self.slaves!r}')
