"""The names the cutting problem no longer has, each with what replaces it.

``REMOVED`` maps a name, relative to ``jaxcontact.problems.cutting``, to
``(replacement, deprecated in, removed in)``, the form of ``jaxcontact.sim``'s
table; ``"Cutting.name"`` is an attribute of the config.
"""

from __future__ import annotations

from jaxcontact.sim._removed import message

PACKAGE = "jaxcontact.problems.cutting"
REMOVED: dict[str, tuple[str, str, str]] = {
    "STEEL": ("jaxcontact.sim.materials.AISI_1045", "1.2", "2.0"),
    "Cutting.material": (
        "Cutting.scaled (mass-scaled, as Cutting.material was) or Cutting.work_material",
        "1.2",
        "2.0",
    ),
    # A benchmark's timing, not the problem's.
    "detection_share": (
        "detection_share in the repository's benchmarks/simulations.py",
        "2.0",
        "2.0",
    ),
}


def missing(name: str, owner: str = "") -> AttributeError:
    """The ``AttributeError`` for ``owner.name`` (``owner``: "" for the package, or a class)."""
    key = f"{owner}.{name}" if owner else name
    if key in REMOVED:
        return AttributeError(message(key, PACKAGE, REMOVED))
    where = f"{PACKAGE}.{owner}" if owner else PACKAGE
    return AttributeError(f"{where!r} has no attribute {name!r}")
