"""The names ``jaxcontact.sim`` no longer has, each with what replaces it.

One table: ``REMOVED`` maps a name, relative to ``jaxcontact.sim``, to
``(replacement, deprecated in, removed in)``. A plain name is a module
attribute (``__getattr__`` raises ``AttributeError``); ``"module.function(keyword=)"``
is a keyword that function no longer takes (``refuse`` raises ``TypeError``).
Both messages name the old name and its replacement.
"""

from __future__ import annotations

from collections.abc import Mapping

from jaxcontact._removed import message as _wording

_PLOUGHING = "jaxcontact.problems.ploughing"
REMOVED: dict[str, tuple[str, str, str]] = {
    # The problems and their demos and analyses, moved out of the parts.
    "cutting": ("jaxcontact.problems.cutting", "2.0", "2.0"),
    "cutting_demo": ("jaxcontact.problems.cutting.demo", "2.0", "2.0"),
    "machining": ("jaxcontact.problems.cutting.machining", "2.0", "2.0"),
    "ploughing": (f"{_PLOUGHING} (set up by {_PLOUGHING}.setup)", "2.0", "2.0"),
    "demo": ("jaxcontact.problems.ploughing.demo", "2.0", "2.0"),
    "hertz": ("jaxcontact.problems.hertz", "2.0", "2.0"),
    # The modules 1.2 replaced.
    "solid": ("jaxcontact.sim.elements.q4", "1.2", "2.0"),
    "elastic": (
        "jaxcontact.sim.elements.triangle (its Material: jaxcontact.sim.materials.Elastic)",
        "1.2",
        "2.0",
    ),
    "plasticity": (
        "jaxcontact.sim.materials (JohnsonCook, AISI_1045, PointState, von_mises)",
        "1.2",
        "2.0",
    ),
    "tool": (
        f"{_PLOUGHING}.tool_outline, tool_surface and SCENE_TOOL (built by jaxcontact.sim.tools)",
        "1.2",
        "2.0",
    ),
    # The ploughing run's 0.7.5 names, which 1.x kept on the package.
    "run": (f"{_PLOUGHING}.run (one scan: {_PLOUGHING}.scan)", "1.2", "2.0"),
    "simulate": (f"{_PLOUGHING}.simulate", "1.2", "2.0"),
    "mean_cutting_force": (f"{_PLOUGHING}.mean_cutting_force", "1.2", "2.0"),
    "Ploughing": (f"{_PLOUGHING}.Plan (what setup returns; the config: Ploughing)", "1.2", "2.0"),
    "Controls": (f"{_PLOUGHING}.Controls", "1.2", "2.0"),
    "History": (f"{_PLOUGHING}.History", "1.2", "2.0"),
    "Final": (f"{_PLOUGHING}.Final", "1.2", "2.0"),
    "MASS_SCALED_STEEL": (f"{_PLOUGHING}.MASS_SCALED_STEEL", "1.2", "2.0"),
    "workpiece_mesh": (f"{_PLOUGHING}.workpiece_mesh", "1.2", "2.0"),
    "tool_outline": (f"{_PLOUGHING}.tool_outline", "1.2", "2.0"),
    "tool_surface": (f"{_PLOUGHING}.tool_surface", "1.2", "2.0"),
    "Material": ("jaxcontact.sim.materials.Elastic", "1.2", "2.0"),
    "Mesh": ("jaxcontact.sim.elements.triangle.Mesh", "1.2", "2.0"),
    # explicit.step's 1.1 keywords (and their places, positionally).
    "explicit.step(fixed=)": (
        "explicit.step(..., boundary=explicit.Boundary(fixed=...))",
        "1.2",
        "2.0",
    ),
    "explicit.step(velocity=)": (
        "explicit.step(..., boundary=explicit.Boundary(velocity=...))",
        "1.2",
        "2.0",
    ),
    "explicit.step(partner=)": (
        "explicit.step(..., boundary=explicit.Boundary(ties=...))",
        "1.2",
        "2.0",
    ),
}


def message(name: str, package: str = "jaxcontact.sim", table: Mapping = REMOVED) -> str:
    """``jaxcontact._removed``'s wording for ``name`` of ``table`` (relative to ``package``)."""
    replacement, _, removed = table[name]
    return _wording(f"{package}.{name}", f"use {replacement}", removed)


def __getattr__(name: str):
    """The package's ``__getattr__``: an ``AttributeError`` naming the replacement."""
    if name in REMOVED:
        raise AttributeError(message(name))
    raise AttributeError(f"module 'jaxcontact.sim' has no attribute {name!r}")


def refuse(function: str, keywords: Mapping[str, object]) -> None:
    """``TypeError`` for keywords ``function`` (``"module.function"``) no longer takes."""
    for keyword in keywords:
        name = f"{function}({keyword}=)"
        if name in REMOVED:
            raise TypeError(message(name))
        raise TypeError(f"{function}() got an unexpected keyword argument {keyword!r}")
