"""Simulation parts built on jaxcontact, and three problems set up from them.

The parts (nothing in them names a material or a tool of a problem):

* ``materials``: the ``Material`` protocol, ``Elastic`` and J2
  ``JohnsonCook``, with cited presets (``AISI_1045``, ``AISI_4340``,
  ``OFHC_COPPER``, ``STEEL``);
* ``elements``: the plane-strain Q4 with B-bar (``elements.q4``) and the
  linear triangle (``elements.triangle``);
* ``explicit``: central differences on a Q4 mesh, with a ``Boundary``;
* ``coupling``: a ``Search``'s contacts to nodal forces: the mass-scaled
  penalty, the friction law (``Coulomb``, ``Zorev``), the penetration guards;
* ``tools``: a rigid wedge with a rounded edge, differentiable in the rake.

The problems, each a short set-up of the parts: ``cutting`` (orthogonal
cutting of AISI 1045 that forms a chip), ``ploughing`` (a rigid tool
ploughing an elastic workpiece) and ``hertz`` (a cylinder pressed into an
elastic block, against Hertz). ``machining`` holds the analyses a cut is
set against (Merchant, Kienzle).

The package's 0.7.5 names (the ploughing run's) still work, with a
``DeprecationWarning`` naming where each lives now.
"""

from jaxcontact.sim import coupling as coupling
from jaxcontact.sim import cutting as cutting
from jaxcontact.sim import elements as elements
from jaxcontact.sim import explicit as explicit
from jaxcontact.sim import hertz as hertz
from jaxcontact.sim import machining as machining
from jaxcontact.sim import materials as materials
from jaxcontact.sim import ploughing as ploughing
from jaxcontact.sim import tools as tools
from jaxcontact.sim._moved import forward as _forward

_PLOUGHING = (
    "MASS_SCALED_STEEL Controls Final History Ploughing mean_cutting_force run simulate "
    "tool_outline tool_surface workpiece_mesh"
).split()
__getattr__ = _forward(
    __name__,
    {name: f"jaxcontact.sim.ploughing.{name}" for name in _PLOUGHING}
    | {
        "Material": "jaxcontact.sim.materials.Elastic",
        "Mesh": "jaxcontact.sim.elements.triangle.Mesh",
    },
)
