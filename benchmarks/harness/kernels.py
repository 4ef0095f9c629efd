"""Kernels and compile time of each ``Search.closest`` step on the quick scenes, fast.

    python -m benchmarks.harness.kernels

Compiles (does not run) the four ``benchmarks/targets.py`` step forms on its ``QUICK`` scenes,
and a ``Search.swept`` step in both result forms on ``benchmarks/swept_peers.py``'s first
quick scene, with ``jax_enable_x64`` as the process has it (on by default here, as the suite
runs; the targets table runs it off), and prints the kernels XLA's CPU runtime would run per call
(``benchmarks.harness.program``: both branches of a ``lax.cond`` count), those on the path a
step with kept slaves takes (``taken``: of each ``lax.cond`` its larger branch; a loop's body
once), the ``while`` loops' trip counts and the compile time. For a quick look at a change
to the step's shape; the targets table is the record.
"""

from __future__ import annotations

import time

import jax

from benchmarks import swept_peers, targets
from benchmarks.harness import program
from jaxcontact import Search


def taken(text: str) -> int:
    """The kernels of an optimised HLO ``text`` on the path a step with kept slaves takes:
    of each ``conditional`` its branch of most kernels (the stages' work, not their skip),
    of a ``while`` or ``call`` its computations once."""
    entry, bodies = program.computations(text)

    def kernels(name: str) -> int:
        total = 0
        for line in bodies.get(name, []):
            code = program.opcode(line)
            if code == "conditional":
                total += max(map(kernels, program.callees(line)))
            elif code in program.CONTROL:
                total += sum(map(kernels, program.callees(line)))
            elif program.is_kernel(code):
                total += 1
        return total

    return kernels(entry)


def show(scene: str, name: str, fn, args) -> None:
    """One line: ``fn`` compiled for ``args``, its kernels (all, and ``taken``), loop trips
    and compile time."""
    start = time.perf_counter()
    compiled = fn.lower(*args).compile()
    seconds = time.perf_counter() - start
    shape = program.describe(compiled)
    print(
        f"{scene:45s} {name:40s} kernels {shape.kernels:4d} (taken "
        f"{taken(compiled.as_text()):4d})  loops {shape.loops}  compile {seconds:.2f} s"
    )


def main() -> None:
    for kind, size, parameter in targets.QUICK:
        x, surface, radius, pair = targets.build(kind, size, parameter)
        for name, (fn, args) in targets.search_steps(x, surface, radius, pair).items():
            show(targets.label(kind, size, parameter), name, fn, args)
    kind, size, parameters = swept_peers.QUICK_SCENES[0]
    scene = swept_peers.build(kind, size, parameters)
    for compact in (False, True):
        search = Search(compact=compact)
        state = search.allocate(scene.x, scene.surface, x_prev=scene.x_prev)
        args = (state, scene.x_prev, scene.x, scene.surface)
        name = "Search.swept" + (" (compact)" if compact else "")
        show(f"{kind}, {size:,} nodes", name, jax.jit(search.swept), args)


if __name__ == "__main__":
    main()
