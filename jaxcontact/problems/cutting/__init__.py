"""Orthogonal cutting of AISI 1045 that forms a chip: the source paper's simulation, in JAX.

The shape every problem has: ``Cutting`` (the cut's numbers, ``config``),
``setup(cut) -> (model, state)``, ``step(model, state, rake, mu)`` and
``run(cut, rake_deg, mu) -> (model, state, record, frames, seconds)``
(``model``); ``summary`` and the measures behind it (``report``) set a run
beside Merchant's and Kienzle's analyses (``machining``); ``demo`` is
``jaxcontact demo --scene cutting``. ``model``'s docstring describes the
model and why it is so. A name the cut no longer has raises an
``AttributeError`` that names its replacement.
"""

from jaxcontact import _removed
from jaxcontact.problems.cutting.config import (
    ARC_SEGMENTS,
    CLEARANCE_DEG,
    FLANK,
    LANDING,
    MU,
    PENMAX,
    TOOL_NODES,
    VISCOSITY,
    Cutting,
    cutting_tool,
    tool_outline,
)
from jaxcontact.problems.cutting.model import (
    BASE_SIDE,
    CHIP_SIDE,
    Frame,
    Model,
    Record,
    Seen,
    State,
    Workpiece,
    advance,
    chunk_steps,
    contact_share,
    contacts,
    friction_law,
    held,
    inspect_step,
    mean_forces,
    observe,
    own_surface,
    rezone,
    run,
    setup,
    step,
    sticking_limit,
    tool_friction,
    tool_position,
    tool_surface,
    tool_travel,
    travel_at,
    workpiece,
)
from jaxcontact.problems.cutting.report import (
    LAST,
    SMALL_FLOOR,
    STEADY_DRIFT,
    Dips,
    Window,
    chip_thickness,
    deepest_in_tool,
    release_dips,
    steady_window,
    summary,
)

# Old names fail naming their replacements (jaxcontact._removed).
__getattr__ = _removed.missing(__name__)


__all__ = [
    "ARC_SEGMENTS",
    "CLEARANCE_DEG",
    "FLANK",
    "LANDING",
    "MU",
    "PENMAX",
    "TOOL_NODES",
    "VISCOSITY",
    "Cutting",
    "cutting_tool",
    "tool_outline",
    "BASE_SIDE",
    "CHIP_SIDE",
    "Frame",
    "Model",
    "Record",
    "Seen",
    "State",
    "Workpiece",
    "advance",
    "chunk_steps",
    "contact_share",
    "contacts",
    "friction_law",
    "held",
    "inspect_step",
    "mean_forces",
    "observe",
    "own_surface",
    "rezone",
    "run",
    "setup",
    "step",
    "sticking_limit",
    "tool_friction",
    "tool_position",
    "tool_surface",
    "tool_travel",
    "travel_at",
    "workpiece",
    "LAST",
    "SMALL_FLOOR",
    "STEADY_DRIFT",
    "Dips",
    "Window",
    "chip_thickness",
    "deepest_in_tool",
    "release_dips",
    "steady_window",
    "summary",
]
