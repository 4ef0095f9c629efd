"""XLA's threads inside one program: each ``Search.closest`` step with and without them.

On a CPU with more than one core, XLA's CPU compiler splits large loops of a
program into parts that its thread pool runs at once (its
``cpu-parallel-task-assigner`` pass; the kernels carry
``outer_dimension_partitions``). Each split loop waits for its parts, so it
pays a start and a join on every call. Pinned to one core (``taskset -c
0``) XLA makes no parts, so this comparison only means something unpinned.

On issue 25's scenes (``benchmarks/targets.py``'s, without the rough die at
10^6 x 10^5, float32) the whole-search step (``skin=0``) in both result
forms is compiled twice from one lowering: with XLA's defaults, and with
``compiler_options={"xla_disable_hlo_passes": "cpu-parallel-task-assigner"}``
(one thread per loop). Both are timed round-robin in one process
(``time_interleaved``: two warm-up runs, then ``--repeats`` rounds), and
their answers compared field by field, bit for bit, with glibc's allocator
keeping freed pages (as in ``benchmarks/targets.py``). The hand-written numba
grid on one thread (``benchmarks.peer_codes.numba_grid``, as in
``benchmarks/targets.py``) runs in the same rounds, where numba is
installed: the last columns are its median over each of jaxcontact's.

A user chooses per program: the option goes to the ``jax.jit`` of their own
step (``jax.jit(step, compiler_options=...)``), or to every program through
``XLA_FLAGS=--xla_disable_hlo_passes=cpu-parallel-task-assigner``.
jaxcontact chooses nothing for them.

    python benchmarks/threads.py              # 40 rounds
    python benchmarks/threads.py --quick      # small scenes, 10 rounds
"""

from __future__ import annotations

import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run
from benchmarks.harness.timing import time_interleaved

sys.path.insert(0, str(pathlib.Path(__file__).parents[1]))  # benchmarks/: targets.py
from targets import QUICK, WITHOUT_LARGEST_DIE, build, numba_closest, whole_search_steps  # noqa: E402

ONE_THREAD = {"xla_disable_hlo_passes": "cpu-parallel-task-assigner"}
SPLIT, ALONE = "XLA's threads", "one thread"


def same(first, second) -> str:
    """'equal', or the fields that differ."""
    leaves = jax.tree_util.tree_leaves_with_path(first)
    other = jax.tree.leaves(second)
    differ = [
        jax.tree_util.keystr(path)
        for (path, a), b in zip(leaves, other, strict=True)
        if not np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
    ]
    return "equal" if not differ else "differ: " + ", ".join(differ)


def run_scene(kind: str, size: int, parameter, repeats: int) -> list[str]:
    x, surface, radius, pair = build(kind, size, parameter)
    calls, parts = {}, {}
    for form, (jitted, args) in whole_search_steps(x, surface, radius, pair).items():
        lowered = jitted.lower(*args)
        for label, options in ((SPLIT, None), (ALONE, ONE_THREAD)):
            executable = lowered.compile(compiler_options=options)
            parts[(form, label)] = executable.as_text().count('"outer_dimension_partitions":["')
            calls[(form, label)] = (executable, args)
    peer = numba_closest(x, surface, radius)
    if not isinstance(peer, str):
        calls["numba"] = peer
    timings = time_interleaved(calls, repeats=repeats, warmup=2)
    answers = {key: jax.block_until_ready(fn(*args)) for key, (fn, args) in calls.items()}
    numba_s = timings["numba"].median_s if "numba" in timings else float("nan")
    lines = []
    for form in ("dense", "compact"):
        split, alone = timings[(form, SPLIT)], timings[(form, ALONE)]
        check = same(answers[(form, SPLIT)], answers[(form, ALONE)])
        lines.append(
            f"| {kind}, {size:,} | {form} | {parts[(form, SPLIT)]} "
            f"| {split.median_s * 1e3:.3f} | {alone.median_s * 1e3:.3f} "
            f"| {split.median_s / alone.median_s:.2f} | {check} "
            f"| {numba_s / split.median_s:.2f} | {numba_s / alone.median_s:.2f} |"
        )
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small scenes, 10 rounds")
    parser.add_argument("--repeats", type=int, default=None, help="timed rounds (40)")
    args = parser.parse_args(argv)
    repeats = args.repeats or (10 if args.quick else 40)
    scenes = QUICK if args.quick else WITHOUT_LARGEST_DIE
    _run.reuse_pages()  # as benchmarks/targets.py does
    command = "python benchmarks/threads.py" + " --quick" * args.quick
    print(
        f"`{command}`; {_run.machine()}; float32; median of {repeats} "
        "interleaved rounds after 2 warm-up runs. Split loops: the kernels XLA splits "
        "over its threads by default. Ratio: the default's median over one thread's "
        "(above 1: one thread is faster). numba / ...: the numba grid's (one thread) "
        "median over each of jaxcontact's in the same rounds (1 or more: jaxcontact is "
        "as fast or faster; on the "
        "chip's outline it answers the plain query, with no self-contact rule).\n",
        flush=True,
    )
    print(
        "| scene | form | split loops | XLA's threads (ms) | one thread (ms) | ratio "
        "| answers | numba / XLA's threads | numba / one thread |\n"
        "|---|---|---:|---:|---:|---:|---|---:|---:|",
        flush=True,
    )
    for kind, size, parameter in scenes:
        print("\n".join(run_scene(kind, size, parameter, repeats)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
