"""Simulation parts built on jaxcontact (nothing in them names a material or a tool of a problem):

* ``materials``: the ``Material`` protocol, ``Elastic`` and J2
  ``JohnsonCook``, with cited presets (``AISI_1045``, ``AISI_4340``,
  ``OFHC_COPPER``, ``STEEL``);
* ``elements``: the plane-strain Q4 with B-bar (``elements.q4``) and the
  linear triangle (``elements.triangle``);
* ``explicit``: central differences on a Q4 mesh, with a ``Boundary``;
* ``static``: a static equilibrium by Newton's method with conjugate
  gradients, differentiable by the implicit-function theorem;
* ``coupling``: a ``Search``'s contacts to nodal forces: the mass-scaled
  penalty, the friction law (``Coulomb``, ``Zorev``), the penetration guards;
* ``tools``: a rigid wedge with a rounded edge, differentiable in the rake;
* ``ale``: arbitrary Lagrangian-Eulerian steps on a Q4 mesh: a guarded
  rezone and a conservative second-order remap every k steps.

The problems set up from them live in ``jaxcontact.problems`` (``cutting``,
``ploughing``, ``hertz``), one package each; no part imports a problem, so
``import jaxcontact.sim.materials`` loads none. A name this package no longer
has raises an ``AttributeError`` that names its replacement.
"""

from jaxcontact._removed import listing as _listing
from jaxcontact._removed import missing as _missing
from jaxcontact.sim import ale as ale
from jaxcontact.sim import coupling as coupling
from jaxcontact.sim import elements as elements
from jaxcontact.sim import explicit as explicit
from jaxcontact.sim import materials as materials
from jaxcontact.sim import static as static
from jaxcontact.sim import tools as tools

__all__ = ["ale", "coupling", "elements", "explicit", "materials", "static", "tools"]

# Old names fail naming their replacements (jaxcontact._removed); dir() lists the public ones.
__getattr__ = _missing(__name__)
__dir__ = _listing(__name__)
