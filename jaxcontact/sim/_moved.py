"""Names ``jaxcontact.sim`` replaced: each keeps working, with a ``DeprecationWarning``
that names its replacement (the 1.x promise to a 0.7.5 user)."""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable


def forward(old: str, moved: dict[str, str]) -> Callable[[str], object]:
    """A module ``__getattr__`` for ``old``: ``moved`` maps each replaced name to
    its replacement's dotted path (``"package.module.name"``)."""

    def __getattr__(name: str):
        if name not in moved:
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        target = moved[name]
        warnings.warn(f"{old}.{name} is deprecated: use {target}", DeprecationWarning, stacklevel=2)
        module, _, attribute = target.rpartition(".")
        return getattr(importlib.import_module(module), attribute)

    return __getattr__


def deprecated(old: str, target: str, function: Callable, stacklevel: int = 2) -> Callable:
    """``function`` under its old name ``old``, warning that ``target`` replaces it
    (``stacklevel``: the frames up to the caller the warning names)."""

    def call(*args, **kwargs):
        warnings.warn(
            f"{old} is deprecated: use {target}", DeprecationWarning, stacklevel=stacklevel
        )
        return function(*args, **kwargs)

    call.__name__ = old.rpartition(".")[2]
    call.__doc__ = f"Deprecated: ``{target}``."
    return call
