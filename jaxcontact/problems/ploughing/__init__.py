"""A rigid tool ploughing an elastic workpiece: contact detection inside a JAX simulation.

The shape every problem has: ``Ploughing`` (the run's numbers, ``config``),
``setup(config) -> (mesh, controls, plan)``, ``scan`` (the run's steps, one
``lax.scan``) and ``run(config) -> Run`` (``model``); ``demo`` is
``jaxcontact demo --scene ploughing``. ``model``'s docstring describes the
model.
"""

from jaxcontact.problems.ploughing.config import (
    MASS_SCALED_STEEL,
    SCENE_TOOL,
    TIP_HEIGHT,
    Ploughing,
)
from jaxcontact.problems.ploughing.model import (
    Controls,
    Final,
    History,
    Plan,
    Run,
    mean_cutting_force,
    run,
    scan,
    setup,
    simulate,
    tool_outline,
    tool_surface,
    workpiece_mesh,
)

__all__ = [
    "MASS_SCALED_STEEL",
    "SCENE_TOOL",
    "TIP_HEIGHT",
    "Ploughing",
    "Controls",
    "Final",
    "History",
    "Plan",
    "Run",
    "mean_cutting_force",
    "run",
    "scan",
    "setup",
    "simulate",
    "tool_outline",
    "tool_surface",
    "workpiece_mesh",
]
