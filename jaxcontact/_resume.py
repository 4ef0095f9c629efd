"""A long ``lax.scan`` that outgrows its sizes resumes from its last good chunk.

A ``Search``'s sizes are static: under ``jit`` a step that outgrows them can
only say so (``overflow``, which stays set in the state). Checked once after
a whole ``lax.scan``, an overflow at step 9,000 of 10,000 means allocating
again and rerunning from step 0. ``resumable_scan`` runs the scan in chunks
of ``chunk`` steps instead (one compiled program per chunk length and set of
sizes), checks the carry's search states on the host after each chunk, and
when one overflowed runs that chunk again from the carry it started with,
after ``grow`` has allocated larger sizes: only the chunk that overflowed is
repeated. A chunk's outputs are kept only once it ran without overflow, so
the result is what one scan at large enough sizes returns.
"""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact._pipeline import sizes as _sizes_module
from jaxcontact._search import SearchState


def _states(carry) -> list[SearchState]:
    leaves = jax.tree.leaves(carry, is_leaf=lambda node: isinstance(node, SearchState))
    return [leaf for leaf in leaves if isinstance(leaf, SearchState)]


def _overflowed(carry) -> bool:
    return any(bool(np.any(np.asarray(state.overflow))) for state in _states(carry))


def _lost(carry) -> int:
    """How many contacts the search states in ``carry`` lost (``SearchState.lost``)."""
    return sum(int(np.sum(np.asarray(state.lost))) for state in _states(carry))


def _sizes(carry) -> list:
    return [state.sizes for state in _states(carry)]


def _larger(after: list, before: list) -> bool:
    """Whether some capacity of ``after`` (each state's sizes) exceeds ``before``'s."""
    return any(
        _sizes_module.largest(old, new) != old
        for grown, held in zip(after, before, strict=True)
        for name, new in grown.items()
        if (old := held.get(name)) is not None
    ) or any(set(grown) - set(held) for grown, held in zip(after, before, strict=True))


# What to do when contacts were lost: the radius cannot grow within a run.
_RAISE_THE_RADIUS = (
    "a slave active at one step lay, at the next, behind the segment it touched deeper than "
    "the radius reaches, so the search saw it nowhere (a penetrating slave lies |gap| from "
    "its segment) and its contact was dropped: the body passes through. Rerun with a "
    "larger Search(radius=...), above the deepest penetration expected in one step (the "
    "approach speed times the time step, plus what the contact lets a node sink), or with "
    "a shorter time step or a stiffer contact"
)


def check_overflow(carry) -> None:
    """Raises when a search state in ``carry`` overflowed or lost a contact: a
    run's one check, on the host.

    A state's ``overflow`` stays set once any step outgrew its sizes, and its
    ``lost`` counts every contact lost deeper than the radius reaches, so one
    call after a ``lax.scan`` (or a Python loop) covers every step. An
    overflowed step may have missed contacts, and a lost contact let a slave
    pass through the master; every step after it built on that: the run's
    results are not to be used.

    Args:
      carry: a ``SearchState``, or any pytree holding them (a scan's carry).

    Raises:
      RuntimeError: naming how many states overflowed, or how many contacts
        were lost, and what to do (allocate again; raise the radius).
      ValueError: when ``carry`` holds no ``SearchState``.

    Example:
      >>> import jax.numpy as jnp
      >>> import jaxcontact
      >>> floor = jaxcontact.Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]]), jnp.array([[0, 1]]))
      >>> search = jaxcontact.Search(radius=0.5)
      >>> state = search.allocate(jnp.array([[0.5, 0.25]]), floor)
      >>> jaxcontact.check_overflow((state, 1.0))  # nothing outgrown: returns None
    """
    states = _states(carry)
    if not states:
        raise ValueError("carry holds no jaxcontact SearchState: nothing can overflow")
    overflowed = sum(bool(np.any(np.asarray(state.overflow))) for state in states)
    if overflowed:
        raise RuntimeError(
            f"{overflowed} of {len(states)} search state(s) overflowed during this run: a "
            "step outgrew the sizes allocate measured, so contacts may have been missed and "
            "the results from that step on are not to be used. Allocate again at a "
            "configuration in contact (search.allocate(x, surface, at_least=state), with a "
            "larger Search(slack=...) for a scene that changes a lot) and rerun, or run the "
            "loop with jaxcontact.resumable_scan(step, carry, xs, chunk=..., grow=...), which "
            "allocates again and reruns only the chunk that overflowed"
        )
    lost = _lost(states)
    if lost:
        raise RuntimeError(f"{lost} contact(s) were lost during this run: {_RAISE_THE_RADIUS}")


def resumable_scan(step, carry, xs=None, *, chunk: int, grow, length: int | None = None):
    """``jax.lax.scan(step, carry, xs)`` in chunks; a chunk whose search
    states overflowed is run again from its start, with larger sizes.

    Args:
      step: ``step(carry, x) -> (carry, y)``, as for ``lax.scan``.
      carry: the initial carry, holding one or more ``SearchState`` (found
        anywhere in the pytree), none of them overflowed.
      xs: the scanned inputs, each with a leading axis of T steps, or None
        with ``length``.
      chunk: steps per chunk (static, >= 1). Each chunk is one compiled
        ``lax.scan``; a last, shorter chunk compiles once more, so a
        ``chunk`` that divides T compiles least.
      grow: ``grow(carry, xs_chunk) -> carry``, called on the host with the
        carry at the start of a chunk that overflowed and that chunk's
        inputs: it returns the carry with its search states allocated again,
        large enough for the chunk (``search.allocate(..., at_least=state)``
        at the configurations the chunk will reach, as far as the caller
        can tell from its inputs; with ``slack`` to spare, one regrowth
        usually covers many chunks). A body that has not touched yet holds no
        contact where it is: allocate also where the chunk takes it (moved
        ahead by its velocity times the chunk's duration). New sizes compile
        the chunk's program anew.
      length: T, when ``xs`` is None.

    Returns:
      ``(carry, ys, regrown)``: the final carry and the stacked outputs, as
      ``lax.scan`` returns them, and the first step of each chunk that was
      run again (a list of ints, in order).

    Raises:
      ValueError: when ``carry`` already holds an overflowed state, when
        ``grow`` returns one, or on a bad ``chunk``.
      RuntimeError: when ``grow`` returned sizes no larger than those a
        chunk overflowed with (it would overflow again), or when a chunk
        still overflows after ``grow`` ran 8 times in a row on it.

    Warns:
      UserWarning: when a chunk lost a contact (``SearchState.lost``: a
        slave passed through the master deeper than the radius reaches). No
        sizes mend that: the radius must grow. The count stays in the state,
        and ``check_overflow`` raises on it.
    """
    if isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1:
        raise ValueError(f"chunk must be an int >= 1; got {chunk!r}")
    if not _states(carry):
        raise ValueError("carry holds no jaxcontact SearchState: nothing can overflow")
    if _overflowed(carry):
        raise ValueError("carry holds an overflowed SearchState: allocate it again first")
    leaves = jax.tree.leaves(xs)
    if length is None:
        if not leaves:
            raise ValueError("resumable_scan needs xs with a leading axis, or length=")
        length = int(np.shape(leaves[0])[0])
    run = jax.jit(
        lambda carry, part, size: jax.lax.scan(step, carry, part, length=size), static_argnums=2
    )
    outputs, regrown = [], []
    for first in range(0, length, chunk):
        size = min(chunk, length - first)
        part = jax.tree.map(lambda values, at=slice(first, first + size): values[at], xs)
        after, ys = run(carry, part, size)
        for _ in range(8):
            if not _overflowed(after):
                break
            before = _sizes(carry)
            carry = grow(carry, part)
            if _overflowed(carry):
                raise ValueError("grow must return a carry whose search states have not overflowed")
            if not _larger(_sizes(carry), before):
                raise RuntimeError(
                    f"the chunk from step {first} overflowed, and grow returned sizes no larger "
                    "than those it overflowed with: it would overflow again. grow must allocate "
                    "at the configurations the chunk will reach, not only where it starts: a "
                    "body that has not touched yet holds no contact where it is. Allocate also "
                    "where it will be (moved ahead by its velocity times the chunk's duration, "
                    "or placed at the master), passing at_least= the state. (A slave's radius "
                    "above Search.radius overflows at any sizes: raise Search.radius)"
                )
            regrown.append(first)
            after, ys = run(carry, part, size)
        else:
            if _overflowed(after):
                raise RuntimeError(f"the chunk from step {first} still overflows after 8 regrowths")
        lost = _lost(after) - _lost(carry)
        if lost > 0:
            # No sizes mend a loss, and a run of prescribed motion may mean it: warned,
            # and kept in the state for check_overflow.
            warnings.warn(
                f"resumable_scan: the chunk from step {first} lost {lost} contact(s): "
                f"{_RAISE_THE_RADIUS}",
                UserWarning,
                stacklevel=2,
            )
        carry = after
        outputs.append(ys)
    ys = jax.tree.map(lambda *parts: jnp.concatenate(parts), *outputs) if outputs else None
    return carry, ys, sorted(set(regrown))
