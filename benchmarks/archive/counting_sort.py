"""Issue 25's "counting sorts where the keys are few", measured before building it.

``_narrow.search_listed`` orders the kept slaves by the length of their
candidate lists, longest first: a stable sort of ``capacity - length``, keys
in ``[0, capacity]`` (``_sort.stable_order``: one sort of ``key * E + row``).
With so few distinct keys a counting sort needs no comparison sort: count
each key, an exclusive sum of the counts gives each key's first place, and a
prefix count of the equal keys before a row gives its place among them.
This times three ways of computing that prefix count against the sort, on
the CPU, each checked to give the sort's order exactly:

- ``one-hot cumsum``: an (E, K) table of one-hot rows, ``jnp.cumsum`` down it;
- ``masked cumsums``: one 1-D ``jnp.cumsum`` per key;
- ``one-hot scan``: the (E, K) table summed by ``lax.associative_scan``.

Keys: 80 % of the rows have the empty list (key = capacity), the rest a
length uniform in ``[0, capacity]``, an assumed mix (on the rough die at
10^5 x 10^4, ``benchmarks/stages.py``, 81,920 slaves are kept and 8,568
rows find a segment); the sizes bracket that scene's 81,920 rows.

    python benchmarks/counting_sort.py            # both cores
    taskset -c 0 python benchmarks/counting_sort.py

Each form is timed over 50 calls, the forms interleaved
(``benchmarks.harness.timing.time_interleaved``); medians.
"""

from __future__ import annotations

import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import _run
from benchmarks.harness.internals import stable_order
from benchmarks.harness.timing import time_interleaved


def _place(keys, prefix, counts):
    """The order from each row's place: its key's first place plus ``prefix``."""
    first = jnp.cumsum(counts) - counts
    place = first[keys] + prefix
    rows = jnp.arange(keys.shape[0], dtype=jnp.int32)
    return jnp.zeros_like(rows).at[place].set(rows, unique_indices=True)


def _one_hot(keys, num_keys):
    """i32[E, K]: row i is 1 in column ``keys[i]``."""
    return (keys[:, None] == jnp.arange(num_keys, dtype=jnp.int32)).astype(jnp.int32)


def one_hot_cumsum(keys, num_keys):
    one_hot = _one_hot(keys, num_keys)
    before = jnp.cumsum(one_hot, axis=0) - one_hot
    prefix = jnp.take_along_axis(before, keys[:, None], axis=1)[:, 0]
    return _place(keys, prefix, one_hot.sum(axis=0))


def masked_cumsums(keys, num_keys):
    prefix = jnp.zeros_like(keys)
    counts = []
    for key in range(num_keys):
        equal = keys == key
        running = jnp.cumsum(equal.astype(jnp.int32))
        prefix = jnp.where(equal, running - 1, prefix)
        counts.append(running[-1])
    return _place(keys, prefix, jnp.stack(counts))


def one_hot_scan(keys, num_keys):
    through = jax.lax.associative_scan(jnp.add, _one_hot(keys, num_keys), axis=0)
    prefix = jnp.take_along_axis(through, keys[:, None], axis=1)[:, 0] - 1
    return _place(keys, prefix, through[-1])


def _keys(num_rows: int, capacity: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    length = np.where(rng.random(num_rows) < 0.8, 0, rng.integers(0, capacity + 1, num_rows))
    return (capacity - length).astype(np.int32)


def main() -> None:
    print(f"{_run.machine()}; medians of 50 interleaved calls, ms")
    print("| rows | keys | sort (stable_order) | one-hot cumsum | masked cumsums | one-hot scan |")
    print("|---:|---:|---:|---:|---:|---:|")
    for num_rows in (8_192, 81_920, 655_360):
        for capacity in (7, 15, 31):
            keys = jnp.asarray(_keys(num_rows, capacity))
            num_keys = capacity + 1
            forms = {
                "sort": jax.jit(lambda k, n=num_keys: stable_order(k, n)),
                "one-hot cumsum": jax.jit(lambda k, n=num_keys: one_hot_cumsum(k, n)),
                "masked cumsums": jax.jit(lambda k, n=num_keys: masked_cumsums(k, n)),
                "one-hot scan": jax.jit(lambda k, n=num_keys: one_hot_scan(k, n)),
            }
            want = np.asarray(forms["sort"](keys))
            for name, form in forms.items():
                np.testing.assert_array_equal(np.asarray(form(keys)), want, err_msg=name)
            timings = time_interleaved(
                {name: (form, (keys,)) for name, form in forms.items()}, repeats=50
            )
            cells = " | ".join(f"{1e3 * timing.median_s:.3f}" for timing in timings.values())
            print(f"| {num_rows:,} | {num_keys} | {cells} |")


if __name__ == "__main__":
    main()
