"""Wall-clock timing of JAX calls: ``jaxcontact demo`` and ``jaxcontact bench`` use it.

JAX dispatches asynchronously, so a call returns before its result exists;
every timed call here ends with ``jax.block_until_ready``. Compilation is
timed apart from the runs, and the runs are summarised by their median and
10th/90th percentiles rather than a mean, which one slow outlier would skew.
"""

from __future__ import annotations

import os
import time
from typing import NamedTuple

import jax
import numpy as np


class Timing(NamedTuple):
    """How long one function took, in seconds."""

    compile_s: float  # tracing and compiling (for a plain function: its first call)
    median_s: float  # median of the timed runs
    p10_s: float  # 10th percentile of the timed runs
    p90_s: float  # 90th percentile of the timed runs
    runs: int  # number of timed runs


def _elapsed(call, args) -> float:
    start = time.perf_counter()
    jax.block_until_ready(call(*args))
    return time.perf_counter() - start


def time_call(fn, *args, repeats: int = 20, warmup: int = 2) -> Timing:
    """Times ``fn(*args)``: compilation once, then ``repeats`` runs after a warm-up.

    A ``jax.jit``-wrapped ``fn`` is compiled ahead of time with
    ``fn.lower(*args).compile()`` and the compiled executable is what runs, so
    ``compile_s`` is compilation alone. Any other ``fn`` is called once and
    that first call, which for a jitted body includes one run, is
    ``compile_s``. Time a jitted function before its first call elsewhere:
    once it has run, JAX's cache holds its executable and ``compile_s`` only
    measures the look-up.

    Args:
      fn: the function; pass keyword arguments with ``functools.partial``.
      *args: its positional arguments (arrays or pytrees of arrays).
      repeats: timed runs, at least 1.
      warmup: untimed runs before them, to settle caches and thread pools.

    Returns:
      A ``Timing``.

    Example:
      >>> import jax, jax.numpy as jnp
      >>> timing = time_call(jax.jit(jnp.sin), jnp.zeros(4), repeats=3)
      >>> timing.runs, timing.p10_s <= timing.median_s <= timing.p90_s
      (3, True)
    """
    return time_interleaved({"fn": (fn, args)}, repeats=repeats, warmup=warmup)["fn"]


def compiled_call(fn, args):
    """``(call, compile_s)``: ``fn`` compiled ahead of time if jitted, else its first call."""
    if hasattr(fn, "lower"):
        start = time.perf_counter()
        call = fn.lower(*args).compile()
        return call, time.perf_counter() - start
    return fn, _elapsed(fn, args)


def time_interleaved(
    calls: dict, *, repeats: int = 20, warmup: int = 2, rotate: bool = False
) -> dict:
    """Times several calls round-robin: A, B, C, A, B, C, ... rather than all A first.

    Load that comes and goes on a shared machine then falls on every method
    alike, so their ratios stay fair even when their absolute times do not.
    Each call is compiled (or first called) and warmed up as in ``time_call``.

    Args:
      calls: name -> ``(fn, args)``, ``args`` a tuple of positional arguments.
      repeats: timed runs of each, at least 1.
      warmup: untimed runs of each before the first timed round.
      rotate: start each round one call later (A, B, C; B, C, A; ...): a
        call that runs slower right after some other call (its caches
        evicted) then pays that in every position alike, not always in
        its own.

    Returns:
      name -> ``Timing``, in the order of ``calls``.

    Example:
      >>> import jax, jax.numpy as jnp
      >>> x = jnp.zeros(4)
      >>> timings = time_interleaved({"sin": (jax.jit(jnp.sin), (x,)), "cos": (jnp.cos, (x,))},
      ...                            repeats=3)
      >>> list(timings), timings["sin"].runs
      (['sin', 'cos'], 3)
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1; got {repeats}")
    prepared = {name: (*compiled_call(fn, args), args) for name, (fn, args) in calls.items()}
    for call, _, args in prepared.values():
        for _ in range(warmup):
            _elapsed(call, args)
    runs = {name: [] for name in prepared}
    names = list(prepared)
    for round_ in range(repeats):
        start = round_ % len(names) if rotate else 0
        for name in names[start:] + names[:start]:
            call, _, args = prepared[name]
            runs[name].append(_elapsed(call, args))
    timings = {}
    for name, (_, compile_s, _) in prepared.items():
        p10, median, p90 = np.percentile(runs[name], [10, 50, 90])
        timings[name] = Timing(float(compile_s), float(median), float(p10), float(p90), repeats)
    return timings


def pinned_note() -> str:
    """One line saying which CPU cores this process may run on.

    XLA's CPU backend spreads even small kernels over every core it may use,
    so a figure means little without it: run under ``taskset -c 0`` to pin.
    """
    total = os.cpu_count()
    try:
        allowed = sorted(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux (macOS, Windows): no affinity to read
        return f"CPU affinity unknown on this platform; {total} cores in the machine"
    listed = ",".join(str(core) for core in allowed)
    if len(allowed) == 1:
        return f"pinned to core {listed} (1 of {total} cores)"
    return f"not pinned: {len(allowed)} of {total} cores allowed ({listed})"
