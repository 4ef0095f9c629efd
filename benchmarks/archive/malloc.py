"""glibc's allocator and a call's time: each program's buffers on fresh pages, and reused.

glibc's ``malloc`` serves a block of ``M_MMAP_THRESHOLD`` bytes or more (128
KiB in a new process) with pages newly mapped from the system, and unmaps
them at ``free``: every call's buffers are then new pages, whose first write
faults. glibc raises that threshold itself when such a block is freed (up to
32 MiB), so a process's history decides which calls pay: in one process
the numba grid took 4.4-4.7 ms on the chip's outline at 10^4 nodes before
any larger scene ran, and 1.0 ms after the rough die at 10^6 nodes. XLA's
CPU buffers come from the same ``malloc``.

Each program runs under two settings, chosen with glibc's ``mallopt``, in
alternating phases of ``PHASE`` rounds (every program once per round, each
phase begun by one untimed call of each, so that the heap has settled),
until each program has ``--repeats`` timed calls under each setting: both
settings see the same machine, and the heap changes only between phases.
Setting them before each call instead mixed the two (a call under one
trimmed the heap that the next, under the other, would have reused).

- "fresh pages": ``M_MMAP_THRESHOLD`` and ``M_TRIM_THRESHOLD`` fixed at 128
  KiB, glibc's starting values;
- "pages reused": both at 1 GiB: blocks come from the heap, which is not
  given back. A process gets this from its start with
  ``MALLOC_MMAP_THRESHOLD_=1073741824 MALLOC_TRIM_THRESHOLD_=1073741824``
  in its environment.

Programs: ``Search.closest``'s whole-search step (``skin=0``) in both result
forms, jitted, and the hand-written numba grid on one thread (where numba is
installed), on issue 25's scenes (``benchmarks/targets.py``'s, without the
rough die at 10^6 x 10^5); float32. Every answer is the same whatever the
setting (checked bit for bit for jaxcontact's).

    python benchmarks/malloc.py             # 30 rounds
    python benchmarks/malloc.py --quick     # small scenes, 10 rounds
"""

from __future__ import annotations

import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run
from benchmarks.harness.timing import _elapsed

sys.path.insert(0, str(pathlib.Path(__file__).parents[1]))  # benchmarks/: targets.py
from targets import QUICK, WITHOUT_LARGEST_DIE, build, numba_closest, whole_search_steps  # noqa: E402
from threads import same  # noqa: E402

SETTINGS = {"fresh pages": 128 * 1024, "pages reused": _run.PAGES_REUSED}
PHASE = 5  # timed rounds per phase of one setting
NUMBA = "numba grid (1 thread)"


def run_scene(mallopt, kind: str, size: int, parameter, repeats: int) -> list[str]:
    x, surface, radius, pair = build(kind, size, parameter)
    programs = {
        form: (jitted.lower(*args).compile(), args)
        for form, (jitted, args) in whole_search_steps(x, surface, radius, pair).items()
    }
    peer = numba_closest(x, surface, radius)
    if not isinstance(peer, str):
        programs[NUMBA] = peer
    samples = {(name, setting): [] for name in programs for setting in SETTINGS}
    for _ in range(-(-repeats // PHASE)):
        for setting, threshold in SETTINGS.items():
            _run.set_thresholds(mallopt, threshold)
            for fn, args in programs.values():
                _elapsed(fn, args)
            for _ in range(PHASE):
                for name, (fn, args) in programs.items():
                    samples[(name, setting)].append(_elapsed(fn, args))
    answers = {}
    for setting, threshold in SETTINGS.items():
        _run.set_thresholds(mallopt, threshold)
        for name, (fn, args) in programs.items():
            if name != NUMBA:
                answers[(name, setting)] = jax.block_until_ready(fn(*args))
    lines = []
    for name in programs:
        fresh, reused = (float(np.median(samples[(name, s)])) for s in SETTINGS)
        check = "" if name == NUMBA else same(*(answers[(name, s)] for s in SETTINGS))
        lines.append(
            f"| {kind}, {size:,} | {name} | {fresh * 1e3:.3f} | {reused * 1e3:.3f} "
            f"| {fresh / reused:.2f} | {check} |"
        )
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small scenes, 10 rounds")
    parser.add_argument("--repeats", type=int, default=None, help="timed rounds (30)")
    args = parser.parse_args(argv)
    mallopt = _run.glibc_mallopt()
    if mallopt is None:
        print("Not run: this C library has no mallopt (glibc's).")
        return 0
    repeats = args.repeats or (10 if args.quick else 30)
    scenes = QUICK if args.quick else WITHOUT_LARGEST_DIE
    command = "python benchmarks/malloc.py" + " --quick" * args.quick
    print(
        f"`{command}`; {_run.machine()}; float32; median of {repeats} rounds "
        f"in phases of {PHASE} under each setting in turn, each begun by an untimed call. Ratio: "
        "fresh pages' median over pages reused' (above 1: reusing pages is faster).\n",
        flush=True,
    )
    print(
        "| scene | program | fresh pages (ms) | pages reused (ms) | ratio | answers |\n"
        "|---|---|---:|---:|---:|---|",
        flush=True,
    )
    for kind, size, parameter in scenes:
        print("\n".join(run_scene(mallopt, kind, size, parameter, repeats)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
