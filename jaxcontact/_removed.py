"""The names jaxcontact no longer has, each with what replaces it: one table, one lookup.

``REMOVED`` maps an old name, written in full, to ``(replacement, deprecated
in, removed in)``; ``None`` for "deprecated in" where 2.0 removed a name with
no deprecation first (a major version may). The replacement is the message's
advice as it reads after the colon. An old name is one of

* a module's attribute (``"jaxcontact.sim.cutting"``): the module's
  ``__getattr__`` (``missing``) raises an ``AttributeError``;
* a class's attribute (``"jaxcontact.problems.cutting.Cutting.material"``):
  the class's ``__getattr__`` raises ``attribute_error``;
* a keyword a function no longer takes (``"...explicit.step(fixed=)"``):
  ``refuse`` raises a ``TypeError``;
* a value an argument no longer takes (``'jaxcontact.Search(method="dense")'``):
  its function raises a ``ValueError`` with ``message``.

Every one fails at the line that needs changing, with the change in the
message. Removed keywords not in the table fail as Python fails them
(``TypeError: ... unexpected keyword argument``); CHANGELOG.md lists each
with its replacement.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping

_PLOUGHING = "jaxcontact.problems.ploughing"
_PENALTY = "use jaxcontact.forces.penalty(contact, surface, stiffness)"

REMOVED: dict[str, tuple[str, str | None, str]] = {
    # -- jaxcontact ------------------------------------------------------------------
    "jaxcontact.clear_sizes": (
        "bucket_sort and bucket_swept keep no sizes between calls, so there is "
        "nothing to clear; a jaxcontact.Search keeps its sizes in its state",
        None,
        "2.0",
    ),
    "jaxcontact.sharded": (
        "use jax.shard_map over any detector or Search step, or pass arrays "
        "sharded with jax.sharding straight in (docs/guides/devices.md)",
        None,
        "2.0",
    ),
    'jaxcontact.Search(method="dense")': ('use method="unbinned"', "1.0", "2.0"),
    "jaxcontact.contact_forces": (_PENALTY, "1.0", "2.0"),
    "jaxcontact.forces.contact_forces": (_PENALTY, "1.0", "2.0"),
    # -- jaxcontact.sim: the problems and their demos and analyses, moved out of the parts
    "jaxcontact.sim.cutting": ("use jaxcontact.problems.cutting", "2.0", "2.0"),
    "jaxcontact.sim.cutting_demo": ("use jaxcontact.problems.cutting.demo", "2.0", "2.0"),
    "jaxcontact.sim.machining": ("use jaxcontact.problems.cutting.machining", "2.0", "2.0"),
    "jaxcontact.sim.ploughing": (f"use {_PLOUGHING} (set up by {_PLOUGHING}.setup)", "2.0", "2.0"),
    "jaxcontact.sim.demo": ("use jaxcontact.problems.ploughing.demo", "2.0", "2.0"),
    "jaxcontact.sim.hertz": ("use jaxcontact.problems.hertz", "2.0", "2.0"),
    # the modules 1.2 replaced
    "jaxcontact.sim.solid": ("use jaxcontact.sim.elements.q4", "1.2", "2.0"),
    "jaxcontact.sim.elastic": (
        "use jaxcontact.sim.elements.triangle (its Material: jaxcontact.sim.materials.Elastic)",
        "1.2",
        "2.0",
    ),
    "jaxcontact.sim.plasticity": (
        "use jaxcontact.sim.materials (JohnsonCook, AISI_1045, PointState, von_mises)",
        "1.2",
        "2.0",
    ),
    "jaxcontact.sim.tool": (
        f"use {_PLOUGHING}.tool_outline, tool_surface and SCENE_TOOL "
        "(built by jaxcontact.sim.tools)",
        "1.2",
        "2.0",
    ),
    # the ploughing run's 0.7.5 names, which 1.x kept on the package
    "jaxcontact.sim.run": (f"use {_PLOUGHING}.run (one scan: {_PLOUGHING}.scan)", "1.2", "2.0"),
    "jaxcontact.sim.simulate": (f"use {_PLOUGHING}.simulate", "1.2", "2.0"),
    "jaxcontact.sim.mean_cutting_force": (f"use {_PLOUGHING}.mean_cutting_force", "1.2", "2.0"),
    "jaxcontact.sim.Ploughing": (
        f"use {_PLOUGHING}.Plan (what setup returns; the config: Ploughing)",
        "1.2",
        "2.0",
    ),
    "jaxcontact.sim.Controls": (f"use {_PLOUGHING}.Controls", "1.2", "2.0"),
    "jaxcontact.sim.History": (f"use {_PLOUGHING}.History", "1.2", "2.0"),
    "jaxcontact.sim.Final": (f"use {_PLOUGHING}.Final", "1.2", "2.0"),
    "jaxcontact.sim.MASS_SCALED_STEEL": (f"use {_PLOUGHING}.MASS_SCALED_STEEL", "1.2", "2.0"),
    "jaxcontact.sim.workpiece_mesh": (f"use {_PLOUGHING}.workpiece_mesh", "1.2", "2.0"),
    "jaxcontact.sim.tool_outline": (f"use {_PLOUGHING}.tool_outline", "1.2", "2.0"),
    "jaxcontact.sim.tool_surface": (f"use {_PLOUGHING}.tool_surface", "1.2", "2.0"),
    "jaxcontact.sim.Material": ("use jaxcontact.sim.materials.Elastic", "1.2", "2.0"),
    "jaxcontact.sim.Mesh": ("use jaxcontact.sim.elements.triangle.Mesh", "1.2", "2.0"),
    # explicit.step's 1.1 keywords (and their places, positionally)
    "jaxcontact.sim.explicit.step(fixed=)": (
        "use explicit.step(..., boundary=explicit.Boundary(fixed=...))",
        "1.2",
        "2.0",
    ),
    "jaxcontact.sim.explicit.step(velocity=)": (
        "use explicit.step(..., boundary=explicit.Boundary(velocity=...))",
        "1.2",
        "2.0",
    ),
    "jaxcontact.sim.explicit.step(partner=)": (
        "use explicit.step(..., boundary=explicit.Boundary(ties=...))",
        "1.2",
        "2.0",
    ),
    # -- jaxcontact.problems.cutting ----------------------------------------------------
    "jaxcontact.problems.cutting.STEEL": ("use jaxcontact.sim.materials.AISI_1045", "1.2", "2.0"),
    "jaxcontact.problems.cutting.Cutting.material": (
        "use Cutting.scaled (mass-scaled, as Cutting.material was) or Cutting.work_material",
        "1.2",
        "2.0",
    ),
    # a benchmark's timing, not the problem's
    "jaxcontact.problems.cutting.detection_share": (
        "use detection_share in the repository's benchmarks/simulations.py",
        "2.0",
        "2.0",
    ),
}


def message(old: str, replacement: str, removed_in: str) -> str:
    """The one wording of a removal: the old name, the version that removed it,
    and what to do instead."""
    return f"{old} was removed in {removed_in}: {replacement}"


def explain(old: str) -> str | None:
    """The lookup: ``message`` for ``old`` (a key of ``REMOVED``), or None where it is not one."""
    entry = REMOVED.get(old)
    if entry is None:
        return None
    replacement, _, removed_in = entry
    return message(old, replacement, removed_in)


def attribute_error(owner: str, name: str) -> AttributeError:
    """The ``AttributeError`` for ``owner.name`` (``owner``: a module's or a class's
    full name): naming the replacement of a removed name, else Python's own wording."""
    removed = explain(f"{owner}.{name}")
    if removed is not None:
        return AttributeError(removed)
    if owner in sys.modules:
        return AttributeError(f"module {owner!r} has no attribute {name!r}")
    return AttributeError(f"{owner.rpartition('.')[2]!r} object has no attribute {name!r}")


def missing(module: str) -> Callable[[str], object]:
    """A module's ``__getattr__``: an ``attribute_error`` for every name it is asked for
    (Python asks only for names the module does not have)."""

    def __getattr__(name: str):
        raise attribute_error(module, name)

    return __getattr__


def listing(module: str) -> Callable[[], list[str]]:
    """A module's ``__dir__``: its ``__all__``, so ``dir`` shows the public names only."""

    def __dir__() -> list[str]:
        return sorted(sys.modules[module].__all__)

    return __dir__


def refuse(function: str, keywords: Mapping[str, object]) -> None:
    """A ``TypeError`` for the keywords ``function`` (its full name) was given and does
    not take: naming the replacement of a removed one, else Python's own wording."""
    for keyword in keywords:
        removed = explain(f"{function}({keyword}=)")
        if removed is not None:
            raise TypeError(removed)
        short = function.rpartition(".")[2]
        raise TypeError(f"{short}() got an unexpected keyword argument {keyword!r}")
