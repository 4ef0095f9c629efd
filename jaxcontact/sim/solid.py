"""Deprecated: the Q4 element moved to ``jaxcontact.sim.elements.q4``."""

from jaxcontact.sim._moved import forward as _forward

_NAMES = (
    "GAUSS CORNERS DSHAPE Quads grid_mesh distortion strain_and_spin rotate "
    "bulk_viscosity internal_forces step_material"
).split()
__getattr__ = _forward(__name__, {name: f"jaxcontact.sim.elements.q4.{name}" for name in _NAMES})
