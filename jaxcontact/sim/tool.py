"""Deprecated: the cutting scene's tool is ``jaxcontact.sim.ploughing``'s, built by
``jaxcontact.sim.tools``."""

from jaxcontact.sim._moved import forward as _forward

_NAMES = "tool_outline tool_surface TIP_HEIGHT SCENE_TOOL".split()
__getattr__ = _forward(__name__, {name: f"jaxcontact.sim.ploughing.{name}" for name in _NAMES})
