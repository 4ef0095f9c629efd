"""Deprecated: the cutting scene's tool is ``jaxcontact.sim.ploughing``'s
(``tool_outline``, ``tool_surface``, ``SCENE_TOOL``), built by ``jaxcontact.sim.tools``."""

import math
import warnings

from jaxcontact.sim._moved import forward as _forward

_forwarded = _forward(
    __name__,
    {name: f"jaxcontact.sim.ploughing.{name}" for name in ("tool_outline", "tool_surface")}
    | {"TIP_HEIGHT": "jaxcontact.sim.ploughing.TIP_HEIGHT"},
)
# 1.1's constants of the scene's tool, now fields of ``ploughing.SCENE_TOOL``.
_CONSTANTS = {
    "CLEARANCE": (math.radians(7.0), "SCENE_TOOL.clearance (degrees)"),
    "FACE": (3.0, "SCENE_TOOL.rake_face and .flank"),
    "EDGE_RADIUS": (0.05, "SCENE_TOOL.edge_radius"),
    "ARC_SEGMENTS": (16, "SCENE_TOOL.arc_segments"),
}


def __getattr__(name: str):
    if name in _CONSTANTS:
        value, replacement = _CONSTANTS[name]
        warnings.warn(
            f"{__name__}.{name} is deprecated: use jaxcontact.sim.ploughing.{replacement}",
            DeprecationWarning,
            stacklevel=2,
        )
        return value
    return _forwarded(name)
