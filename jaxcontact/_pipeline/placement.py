"""Arrays sharded with ``jax.sharding``, passed straight in: each program searches them whole.

An array sharded over *explicit* mesh axes (``jax.sharding.AxisType.Explicit``,
what ``jax.make_mesh`` makes by default) carries its sharding in its type
into every operation, and the detectors' reshapes into blocks, their ``vmap``s
over rows and their gathers have no sharding rule for rows split over
devices. So every jitted program of the detectors is wrapped in
``searched_whole``: its array arguments are replicated at the top
(``jax.reshard``, an all-gather), and the per-slave rows of the ``Contact`` or
``Crossing`` it returns are split at the bottom as the slaves' rows came in
(each device keeps its slice of what it holds: no communication). Arguments
that are not split over explicit axes (one device, auto axes, replicated)
pass through untouched, so the program is the one they always compiled to.

Arrays on *auto* axes carry no sharding in their types: the compiler
partitions the unchanged program and places its results itself.

The other way is the caller's: ``jax.shard_map`` over a detector or a
``Search`` step splits the search itself, each device searching its own
slaves' rows against the whole master (docs/guides/devices.md), and
``forces.penalty(axis_name=...)`` sums the master's reaction over the
devices there.
"""

from __future__ import annotations

import functools
import inspect

import jax
from jax.sharding import NamedSharding
from jax.sharding import PartitionSpec as P

from jaxcontact._types import Contact, Crossing


def _explicit_sharding(leaf) -> NamedSharding | None:
    """The sharding in ``leaf``'s type if it splits ``leaf`` over explicit mesh axes."""
    if not hasattr(leaf, "shape"):  # None, static settings
        return None
    # Only explicit axes appear in a type's spec: auto axes read as None.
    sharding = getattr(jax.typeof(leaf), "sharding", None)
    if not isinstance(sharding, NamedSharding) or all(axes is None for axes in sharding.spec):
        return None
    return sharding


def replicated(tree):
    """``tree`` with every array split over explicit mesh axes replicated."""

    def whole(leaf):
        sharding = _explicit_sharding(leaf)
        return leaf if sharding is None else jax.reshard(leaf, NamedSharding(sharding.mesh, P()))

    return jax.tree.map(whole, tree)


def split_rows(result, rows: NamedSharding | None):
    """Every ``Contact`` and ``Crossing`` in ``result`` with its per-slave rows
    split as ``rows`` splits the slaves' first axis (``overflow`` stays whole)."""
    if rows is None or rows.spec[0] is None:
        return result
    by_rows = NamedSharding(rows.mesh, P(rows.spec[0]))

    def split(found):
        if not isinstance(found, Contact | Crossing):
            return found
        fields = {
            name: jax.reshard(value, by_rows)
            for name, value in found._asdict().items()
            if name != "overflow"
        }
        return found._replace(**fields)

    return jax.tree.map(split, result, is_leaf=lambda node: isinstance(node, Contact | Crossing))


def searched_whole(rows: str):
    """Wraps a jitted program's body: arguments replicated at the top, the
    result's rows split like argument ``rows`` (the slaves) at the bottom.

    Goes under ``@jax.jit`` (so that the reshards are part of the program),
    as ``@searched_whole(rows="x")`` over ``def program(x, surface, ...)``; an
    argument that is a tuple of row arrays (a query's points) is split like
    its last.
    """

    def wrap(program):
        signature = inspect.signature(program)

        @functools.wraps(program)
        def whole(*args, **kwargs):
            slaves = signature.bind(*args, **kwargs).arguments[rows]
            if isinstance(slaves, tuple):
                slaves = slaves[-1]
            split = _explicit_sharding(slaves)
            result = program(*replicated(args), **replicated(kwargs))
            return split_rows(result, split)

        return whole

    return wrap
