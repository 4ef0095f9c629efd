"""Kernels and compile time of each ``Search.closest`` step on the quick scenes, fast.

    python -m benchmarks.harness.kernels

Compiles (does not run) the four ``benchmarks/targets.py`` step forms on its ``QUICK`` scenes,
with ``jax_enable_x64`` as the process has it (on by default here, as the suite runs; the
targets table runs it off), and prints the kernels XLA's CPU runtime would run per call
(``benchmarks.harness.program``: both branches of a ``lax.cond`` count), the ``while`` loops'
trip counts and the compile time. For a quick look at a change to the step's shape; the
targets table is the record.
"""

from __future__ import annotations

import time

from benchmarks import targets
from benchmarks.harness import program


def main() -> None:
    for kind, size, parameter in targets.QUICK:
        x, surface, radius, pair = targets.build(kind, size, parameter)
        for name, (fn, args) in targets.search_steps(x, surface, radius, pair).items():
            start = time.perf_counter()
            compiled = fn.lower(*args).compile()
            seconds = time.perf_counter() - start
            shape = program.describe(compiled)
            print(
                f"{targets.label(kind, size, parameter):45s} {name:40s} "
                f"kernels {shape.kernels:4d}  loops {shape.loops}  compile {seconds:.2f} s"
            )


if __name__ == "__main__":
    main()
