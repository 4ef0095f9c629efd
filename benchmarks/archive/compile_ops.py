"""What a compile costs, kernel by kernel, on XLA's CPU backend (issue 25, target 2).

A closest step compiles in 2-10 s (``benchmarks/targets.py``), against the
1 s target. This asks which of its kernels cost the time, in two parts:

1. **Marginal compile time per kernel kind.** For each kind, a program of
   one such kernel and one of eight (each on a slice of its own length, so
   that XLA keeps them apart; the optimised HLO's kernel count is printed
   beside), each compiled ``REPEATS`` times from a fresh lowering with JAX's
   caches cleared; the median of (eight - one) / 7 is what one more kernel of
   that kind adds. N = 10^4 float32 rows unless the row says otherwise.
2. **The search programs by kind.** The search programs of the archived
   ``benchmarks/archive/compile_probe.py`` (``programs`` below: the cutting
   scene at 10^4 nodes, float64), each compiled
   ``PROGRAM_REPEATS`` times, their kernels (``stages.kernel_lines``) sorted into the same
   kinds, and the sum of count x marginal cost beside the measured compile:
   an estimate that takes the kinds to add up, as part 1 shows they do
   for kernels of one kind.

Run it pinned (one core, as a compile runs on the machine's other tasks
in CI) and unpinned:

    taskset -c 0 python benchmarks/compile_ops.py
    python benchmarks/compile_ops.py
"""

from __future__ import annotations

import pathlib
import re
import statistics
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from stages import kernel_lines  # noqa: E402

import jaxcontact  # noqa: E402
from benchmarks.harness import _run  # noqa: E402
from jaxcontact.scenes import cutting_scene  # noqa: E402

REPEATS = 5
PROGRAM_REPEATS = 3  # part 2's programs take 2-8 s each
N = 10_000
COPIES = 8
ROWS = "row reduction (N/8 x 8 -> N/8)"
WINDOW = "reduce-window (a stage of a tree reduction, or cumsum)"


def _kinds():
    """kind -> (one kernel of it on the first ``n`` rows, arguments)."""
    rng = np.random.default_rng(0)
    x = rng.random(10**5).astype(np.float32)
    index = rng.integers(0, N, N).astype(np.int32)
    counts = rng.integers(0, 9, N).astype(np.int32)
    table = x[:N].reshape(N // 8, 8)

    def value(x):
        # Arithmetic and a select, no transcendental (whose inlined
        # approximation would dominate a kernel's code): like the pair kernel.
        return jnp.where(x > 0.5, x * x * 1.5 + x, 1.0 - x)

    return {
        "elementwise": (lambda x, n: value(x[:n]), (x[:N],)),
        "gather + elementwise": (lambda x, i, n: value(x[i[:n]]), (x[:N], index)),
        "reduction to a scalar": (lambda x, n: jnp.max(value(x[:n])), (x[:N],)),
        "reduction to a scalar, N = 10^3": (lambda x, n: jnp.max(value(x[:n])), (x[:1000],)),
        "reduction to a scalar, N = 10^5": (lambda x, n: jnp.max(value(x[:n])), (x,)),
        ROWS: (lambda t, n: jnp.max(t[: n // 8], axis=1), (table,)),
        "argmin to a scalar": (lambda x, n: jnp.argmin(value(x[:n])), (x[:N],)),
        "cumsum": (lambda c, n: jnp.cumsum(c[:n]), (counts,)),
        "sort": (lambda x, n: jnp.sort(x[:n]), (x[:N],)),
        "scatter-add": (
            lambda x, i, n: jnp.zeros(N, x.dtype).at[i[:n]].add(x[:n]),
            (x[:N], index),
        ),
    }


def _compile_seconds(fn, args, repeats: int = REPEATS) -> tuple[float, str]:
    """Median seconds of ``repeats`` compiles from fresh lowerings; the optimised HLO."""
    times = []
    for _ in range(repeats):
        jax.clear_caches()
        lowered = jax.jit(fn).lower(*args)
        started = time.perf_counter()
        compiled = lowered.compile()
        times.append(time.perf_counter() - started)
    return statistics.median(times), compiled.as_text()


def _copies(one, count):
    """A program of ``count`` kernels: ``one`` on ``N - j`` rows, for j < count."""

    def program(*args):
        rows = args[0].shape[0]
        return tuple(one(*args, rows - j) for j in range(count))

    return program


def marginal_costs() -> tuple[list[str], dict[str, float]]:
    lines = [
        "| kind | 1 kernel (ms) | 8 kernels (ms) | one more (ms) | kernels in the 8 |",
        "|---|---:|---:|---:|---:|",
    ]
    cost = {}
    for kind, (one, args) in _kinds().items():
        single, _ = _compile_seconds(_copies(one, 1), args)
        many, text = _compile_seconds(_copies(one, COPIES), args)
        cost[kind] = (many - single) / (COPIES - 1)
        count = len(kernel_lines(text)[0])
        lines.append(
            f"| {kind} | {single * 1e3:.0f} | {many * 1e3:.0f} | {cost[kind] * 1e3:.0f} | {count} |"
        )
        print(lines[-1], file=sys.stderr, flush=True)
    return lines, cost


def kind_of(line: str, bodies: dict[str, list[str]]) -> str:
    """The kind (as ``_kinds`` names them) of one kernel of an optimised HLO."""
    called = re.search(r"calls=%([\w.-]+)", line)
    body = " ".join(bodies.get(called.group(1), [])) if called else line
    ops = set(re.findall(r"= (?:\([^=]*?\)|\S+) ([a-z][a-z0-9-]*)\(", body))
    scalar = re.search(r"= (?:\w+\[\]|\([^)]*\w+\[\][^)]*\))", line) is not None
    if "sort" in ops:
        return "sort"
    if "scatter" in ops:
        return "scatter-add"
    if "reduce-window" in ops:
        return WINDOW
    if "reduce" in ops:
        return "reduction to a scalar" if scalar else ROWS
    if "gather" in ops or "dynamic-slice" in ops:
        return "gather + elementwise"
    return "elementwise"


def programs():
    """name -> (jitted, args): the search programs on the cutting scene at 10^4
    nodes (float64: x64 on, as ``main`` sets it), as the archived
    ``benchmarks/archive/compile_probe.py`` compiled them."""
    scene = cutting_scene(10_000, 18.0, x_tip_prev=18.2)
    found = {}
    for method in ("binned", "unbinned"):
        for compact in (False, True):
            for skin in (0.0, 0.05):
                search = jaxcontact.Search(radius=0.1, skin=skin, method=method, compact=compact)
                state = search.allocate(scene.x, scene.surface, x_prev=scene.x_prev)
                name = f"closest-{method}-{'compact' if compact else 'dense'}-skin{skin}"
                found[name] = (jax.jit(search.closest), (state, scene.x, scene.surface))
    search = jaxcontact.Search(radius=0.1, method="binned")
    state = search.allocate(scene.x, scene.surface, x_prev=scene.x_prev)
    found["swept-binned"] = (jax.jit(search.swept), (state, scene.x_prev, scene.x, scene.surface))
    found["all_to_all"] = (
        jax.jit(lambda x, surface: jaxcontact.all_to_all(x, surface, radius=0.1)),
        (scene.x, scene.surface),
    )
    found["swept"] = (jax.jit(jaxcontact.swept), (scene.x_prev, scene.x, scene.surface))
    return found


def by_kind(cost: dict[str, float]) -> list[str]:
    # A reduce-window stage is costed as a cumsum (itself a reduce-window on
    # XLA's CPU backend): a tree reduction's stage costs less, as part 1's
    # whole "reduction to a scalar" is 2-4 such stages and a last reduce.
    cost = {**cost, WINDOW: cost["cumsum"]}
    names = ["elementwise", "gather + elementwise", "reduction to a scalar", ROWS, WINDOW]
    names += ["sort", "scatter-add"]
    lines = [
        "| program | compile (s) | kernels | "
        + " | ".join(names)
        + " | estimate (s) | measured - estimate (s) |",
        "|---|---:|---:|" + "---:|" * (len(names) + 2),
    ]
    for name, (jitted, args) in programs().items():
        seconds, text = _compile_seconds(jitted, args, PROGRAM_REPEATS)
        found, bodies = kernel_lines(text)
        counts = {kind: 0 for kind in names}
        for line in found:
            counts[kind_of(line, bodies)] += 1
        estimate = sum(counts[kind] * cost[kind] for kind in names)
        cells = " | ".join(str(counts[kind]) for kind in names)
        lines.append(
            f"| {name} | {seconds:.2f} | {len(found)} | {cells} | {estimate:.2f} | "
            f"{seconds - estimate:.2f} |"
        )
        print(lines[-1], file=sys.stderr, flush=True)
    return lines


def main() -> None:
    jax.config.update("jax_enable_x64", True)
    print(
        f"`python benchmarks/compile_ops.py`; {_run.machine()}; medians of {REPEATS} compiles"
        f" (part 2: {PROGRAM_REPEATS}).\n"
    )
    lines, cost = marginal_costs()
    print("Marginal compile time of one kernel, by kind (float32):\n")
    print("\n".join(lines))
    print("\nThe search programs' kernels by kind (the cutting scene at 10^4 nodes, float64):\n")
    print("\n".join(by_kind(cost)))


if __name__ == "__main__":
    main()
