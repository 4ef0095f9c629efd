"""The names 2.0 removed from ``jaxcontact``, each with what replaces it.

One table for the package: an entry is ``old name -> (replacement, deprecated in,
removed in)``; ``None`` for "deprecated in" where 2.0 removed a name with no
deprecation first (a major version may). A module's ``__getattr__`` (``missing``)
turns an old attribute into an ``AttributeError`` that names its replacement, so
code written for 1.x fails at the line that needs changing, with the change in
the message. Removed keywords fail as Python fails them (``TypeError: ...
unexpected keyword argument``); CHANGELOG.md lists each with its replacement.
"""

from __future__ import annotations

from collections.abc import Callable

REMOVED: dict[str, tuple[str, str | None, str]] = {
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
    "jaxcontact.contact_forces": (
        "use jaxcontact.forces.penalty(contact, surface, stiffness)",
        "1.0",
        "2.0",
    ),
    "jaxcontact.forces.contact_forces": (
        "use jaxcontact.forces.penalty(contact, surface, stiffness)",
        "1.0",
        "2.0",
    ),
}


def message(old: str, replacement: str, removed_in: str) -> str:
    """The one wording of a removal, for every package's table: the old name, the
    version that removed it, and what to do instead."""
    return f"{old} was removed in {removed_in}: {replacement}"


def missing(module: str) -> Callable[[str], object]:
    """A module ``__getattr__`` for ``module``: an ``AttributeError`` for every
    name, naming the replacement of a removed one."""

    def __getattr__(name: str):
        entry = REMOVED.get(f"{module}.{name}")
        if entry is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        replacement, _, removed_in = entry
        raise AttributeError(message(f"{module}.{name}", replacement, removed_in))

    return __getattr__
