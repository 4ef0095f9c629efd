"""Per-row work on the few rows that need it.

Slip tracking and smooth normals concern only the slaves a search found:
a few hundred of 10^5 on a cutting scene. Done on all N rows, their gathers
cost several times the search itself (measured with the repository's
benchmarks/costs.py). Here the rows that need the work are gathered into
a static capacity ``C`` (``sort.first_true``), worked on, and
scattered back; when more rows need it than ``C`` holds, a ``cond`` does the
work on all N rows instead, so no row is ever left out. Under ``vmap`` the
``cond`` runs both branches.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.sort import first_true
from jaxcontact._types import Array

SMALLEST_CAPACITY = 1024  # at or below this many rows, every row is worked on
CAPACITY_SHARE = 16  # otherwise C = N / 16


def capacity(num_rows: int) -> int:
    """The static number of rows gathered for the work (``num_rows``: all of them)."""
    return min(num_rows, max(SMALLEST_CAPACITY, num_rows // CAPACITY_SHARE))


def on_rows(needed: Array, compute: Callable[[Array], object]):
    """``compute(rows)`` for every row where ``needed`` (bool[N]), spread over N rows.

    ``compute`` takes i32[C] row indices (``N`` marks an unused slot; gather
    with ``mode="fill"``) and returns a pytree of per-row arrays [C, ...];
    rows not needed get zeros (False). Differentiable: the indices carry no
    gradient, the gathers and the scatter do.
    """
    num_rows = needed.shape[0]
    every = jnp.arange(num_rows, dtype=jnp.int32)
    limit = capacity(num_rows)
    if limit >= num_rows:
        return _zeroed(compute(every), needed)

    def few():
        rows = first_true(needed, limit)

        def spread(values):
            empty = jnp.zeros((num_rows,) + values.shape[1:], values.dtype)
            return empty.at[rows].set(values, mode="drop")

        return jax.tree.map(spread, compute(rows))

    def all_rows():
        return _zeroed(compute(every), needed)

    return jax.lax.cond(jnp.sum(needed) <= limit, few, all_rows)


def _zeroed(result, needed: Array):
    def zero(values):
        keep = needed.reshape(needed.shape + (1,) * (values.ndim - 1))
        return jnp.where(keep, values, jnp.zeros((), values.dtype))

    return jax.tree.map(zero, result)
