"""Deprecated: the triangle moved to ``jaxcontact.sim.elements.triangle``, the
elastic material to ``jaxcontact.sim.materials.Elastic``."""

from jaxcontact.sim._moved import forward as _forward

_TRIANGLE = "Mesh triangle_mesh smallest_altitude stresses internal_forces strain_energy von_mises"
__getattr__ = _forward(
    __name__,
    {name: f"jaxcontact.sim.elements.triangle.{name}" for name in _TRIANGLE.split()}
    | {
        "Material": "jaxcontact.sim.materials.Elastic",
        "workpiece_mesh": "jaxcontact.sim.ploughing.workpiece_mesh",
    },
)
