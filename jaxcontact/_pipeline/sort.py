"""Integer sorts shared by the cells, the search and the tie rule."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxcontact._types import Array

# Past this many passes of ``stable_order``'s radix sort, one ``argsort``.
MOST_PASSES = 4


def stable_order(keys: Array, num_values: int) -> Array:
    """i32[E]: the stable ``argsort`` of ``keys``, integers in ``[0, num_values)``.

    Where ``key * E + position`` fits in int32 it is one sort of those
    unique numbers, with no payload: measured 5.6x faster on the CPU than
    ``argsort(stable=True)`` (2.9 against 16 ms for 90,000 entries), whose
    sort carries the positions as a second operand. Where it does not fit
    (many cells, or node indices as keys, with many entries), the keys are
    sorted a digit at a time from the lowest (a radix sort: each pass is the
    same one-operand sort of ``digit * E + place so far``, stable, so the
    passes compose): two passes over 100,000 node indices took 4.0 against
    7.9 ms for ``argsort``, and over 900,000 cell entries 39.7 against 95.0 ms
    (measured on both cores with commit 5928bf7f76cc:benchmarks/archive/sorts.py).
    """
    size = keys.shape[0]
    if size <= 1:
        return jnp.zeros((size,), jnp.int32)
    keys = keys.astype(jnp.int32)
    position = jnp.arange(size, dtype=jnp.int32)
    if num_values * size < 2**31:
        return jax.lax.sort(keys * size + position) % size
    # Digits of ``bits`` bits: ``digit * size + place`` stays below 2**31.
    bits = (2**31 // size).bit_length() - 1
    passes = -(-max(num_values - 1, 1).bit_length() // max(bits, 1))
    if bits < 1 or passes > MOST_PASSES:
        return jnp.argsort(keys, stable=True).astype(jnp.int32)
    order = None
    for index in range(passes):
        ordered = keys if order is None else keys[order]
        digit = (ordered >> (index * bits)) & ((1 << bits) - 1)
        step = jax.lax.sort(digit * size + position) % size
        order = step if order is None else order[step]
    return order


def packs(num_major: int, num_minor: int) -> bool:
    """Whether ``sorted_pairs`` sorts pairs of these ranges (they fit in int32)."""
    return 0 < num_minor and num_major * num_minor < 2**31


def sorted_pairs(major: Array, minor: Array, num_minor: int, num_major: int) -> Array | None:
    """i32[E]: ``minor`` ordered by ``(major, minor)``, or None where
    ``major * num_minor + minor`` does not fit in int32.

    For keys whose ``(major, minor)`` pairs are unique where it matters (a
    segment is in a cell once): one sort of the packed pairs, with no
    position carried, so it fits where ``stable_order``'s ``key * E +
    position`` would not (E is several entries per segment).
    """
    keys = sorted_pair_keys(major, minor, num_minor, num_major)
    return None if keys is None else keys % num_minor


def sorted_pair_keys(major: Array, minor: Array, num_minor: int, num_major: int) -> Array | None:
    """i32[E]: ``sorted_pairs``' packed keys ``major * num_minor + minor``, sorted, or
    None where they do not fit in int32 (``key // num_minor`` is the major, ``key %
    num_minor`` the minor)."""
    if not packs(num_major, num_minor):
        return None
    packed = major.astype(jnp.int32) * num_minor + minor.astype(jnp.int32)
    return jax.lax.sort(packed)


# Up to this many flags, ``first_true`` compacts by a sort; above, by ``jnp.nonzero``.
SORT_COMPACTION_UP_TO = 8192


def first_true(flags: Array, size: int) -> Array:
    """i32[size]: the indices of the first ``size`` True ``flags`` (bool[S]), in
    increasing order, ``S`` past the last.

    ``jnp.nonzero(size=)`` compiles to 17-27 kernels on XLA's CPU (a cumsum, a
    scatter, and the reductions XLA splits them into); one sort of the unique
    keys ``i`` (True) or ``S + i`` (False) is 3. The sort costs more per flag:
    measured 0.047 against 0.065 ms at 640 flags, 0.27 against 0.22 at 15,625
    and 1.75 against 1.31 at 81,920 (one process, both cores), so the sort
    serves up to ``SORT_COMPACTION_UP_TO`` flags, where a kernel's fixed cost
    (about 1-1.6 us) outweighs it.
    """
    num_flags = flags.shape[0]
    if num_flags > SORT_COMPACTION_UP_TO:
        return jnp.nonzero(flags, size=size, fill_value=num_flags)[0].astype(jnp.int32)
    position = jnp.arange(num_flags, dtype=jnp.int32)
    keys = jax.lax.sort(jnp.where(flags, position, num_flags + position))
    if size > num_flags:
        keys = jnp.pad(keys, (0, size - num_flags), constant_values=2 * num_flags)
    return jnp.minimum(keys[:size], num_flags)
