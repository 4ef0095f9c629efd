"""Trace-and-lower time, XLA compile time and kernels of the search programs, one by one.

On the cutting scene at 10^4 nodes (float64, the tool tip at x = 18, paths
from x = 18.2): ``Search.closest`` (binned and dense, dense and compact
results, without and with a skin), ``Search.swept`` (binned), ``all_to_all``
and ``swept``, each lowered (``jax.jit(f).lower``) and compiled apart, its
kernels counted as ``benchmarks/stages.py`` counts them, and a hash of its
answer printed so that two revisions can be compared bit for bit. Each
program's optimised HLO is written to ``OUT/<program>.hlo``.

To compare two revisions, run it in each checkout, pinned, one after the other:

    taskset -c 0 python benchmarks/compile_probe.py /tmp/probe-new
    git worktree add /tmp/old <rev> && cd /tmp/old && \\
        PYTHONPATH=. taskset -c 0 python benchmarks/compile_probe.py /tmp/probe-old
"""

from __future__ import annotations

import hashlib
import pathlib
import re
import sys
import time

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)


sys.path.insert(0, str(pathlib.Path(__file__).parents[1]))  # benchmarks/: stages.py, compile_ops.py
from compile_ops import programs  # noqa: E402
from stages import kernels  # noqa: E402


def main() -> None:
    out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "compile-probe")
    out.mkdir(parents=True, exist_ok=True)
    print("| program | lower s | compile s | kernels | answer |")
    print("|---|---:|---:|---:|---|")
    for name, (jitted, args) in programs().items():
        started = time.perf_counter()
        lowered = jitted.lower(*args)
        lowered_at = time.perf_counter()
        compiled = lowered.compile()
        compiled_at = time.perf_counter()
        text = re.sub(r"/\*.*?\*/|, metadata=\{[^}]*\}", "", compiled.as_text())
        (out / f"{name}.hlo").write_text(text)
        result = jitted(*args)
        result = result[0] if isinstance(result, tuple) else result
        leaves = jax.tree.leaves(result)
        answer = hashlib.sha1(b"".join(np.asarray(leaf).tobytes() for leaf in leaves))
        print(
            f"| {name} | {lowered_at - started:.2f} | {compiled_at - lowered_at:.2f} | "
            f"{kernels(jitted, args)} | {answer.hexdigest()[:10]} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
