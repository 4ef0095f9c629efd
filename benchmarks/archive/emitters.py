"""XLA's CPU code generation, three ways per program: run time and compile time.

XLA compiles CPU fusions with its "fusion emitters" by default; the debug
option ``xla_cpu_use_fusion_emitters=false`` selects its older emitters, and
``xla_backend_optimization_level=0`` (XLA's default is 3) turns LLVM's
optimisation off, as jaxcontact's test suite compiles (tests/conftest.py).
jaxcontact keeps XLA's defaults; this script shows what the other choices
would give: each program is compiled the three ways in one process
(``jax.jit(..., compiler_options=...)``, as top-level programs) and timed
interleaved, call by call. The two emitters must give the same answer bit
for bit; without LLVM's optimisation the floating-point results may differ
in their last bits, so the table counts the elements that differ from the
default's answer and the largest difference.

The scenes are docs/scenes.md's: the cutting scene, tool tip in the workpiece
(x = 18, previous tip 18.2), and the rough die; float32.

    python benchmarks/emitters.py            # cutting 81,939 nodes, rough die 10^5 x 10^4
    python benchmarks/emitters.py --quick    # cutting 8,000 nodes, rough die 10^4 x 10^3
"""

from __future__ import annotations

import argparse
import functools
import inspect
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import numpy as np
from row_counts import medians  # benchmarks/, beside this script

from benchmarks.harness._run import machine
from benchmarks.harness.internals import _dense, measure, sized_bucket_sort, sized_bucket_swept
from jaxcontact import Search
from jaxcontact.scenes import cutting_scene, rough_die_scene

OLDER_EMITTERS = {"xla_cpu_use_fusion_emitters": False}
UNOPTIMISED = {**OLDER_EMITTERS, "xla_backend_optimization_level": 0}


def compiled_each_way(fn, args):
    """[(executable, compile seconds)] with XLA's defaults, the older emitters,
    and the older emitters without LLVM's optimisation."""
    out = []
    for options in (None, OLDER_EMITTERS, UNOPTIMISED):
        jitted = jax.jit(fn, compiler_options=options) if options else jax.jit(fn)
        began = time.perf_counter()
        executable = jitted.lower(*args).compile()
        out.append((executable, time.perf_counter() - began))
    return out


def differences(reference, other) -> str:
    """Where two answers (pytrees of arrays) differ: per field, the elements that
    differ and the largest absolute difference; "bit for bit" where none do.
    NaN against NaN is no difference."""
    found = []
    leaves = jax.tree_util.tree_flatten_with_path(reference)[0]
    for (path, a), b in zip(leaves, jax.tree.leaves(other), strict=True):
        a, b = np.asarray(a), np.asarray(b)
        same = a == b
        if np.issubdtype(a.dtype, np.inexact):
            same |= np.isnan(a) & np.isnan(b)
        if not same.all():
            gaps = np.abs(a[~same].astype(np.complex128) - b[~same].astype(np.complex128))
            field = jax.tree_util.keystr(path).lstrip(".")
            found.append(f"{field}: {int((~same).sum()):,} of {a.size:,}, up to {gaps.max():.1e}")
    return "; ".join(found) or "bit for bit"


def programs(quick: bool):
    """(scene label, program label, function, arguments)."""
    cut = cutting_scene(8_000 if quick else 81_939, 18.0, x_tip_prev=18.2)
    die = rough_die_scene(10_000, 1_000) if quick else rough_die_scene(100_000, 10_000)
    label = f"cutting, {cut.x.shape[0]:,} nodes"
    dense_closest = inspect.unwrap(_dense._all_to_all)
    dense_swept = inspect.unwrap(_dense._swept)
    closest_sizes = measure(cut.x, cut.surface, radius=cut.radius)
    path_sizes = measure(cut.x, cut.surface, x_prev=cut.x_prev)
    search = Search(radius=cut.radius)
    state = search.allocate(cut.x, cut.surface)
    die_sizes = measure(die.x, die.surface, radius=die.radius)
    die_label = f"rough die, {die.x.shape[0]:,} x {die.surface.segments.shape[0]:,}"
    return [
        (label, "all_to_all", functools.partial(dense_closest, radius=cut.radius, mask=None),
         (cut.x, cut.surface)),
        (label, "swept", functools.partial(dense_swept, mask=None),
         (cut.x_prev, cut.x, cut.surface)),
        (label, "bucket_sort (sized)",
         functools.partial(sized_bucket_sort, radius=cut.radius, sizes=closest_sizes),
         (cut.x, cut.surface)),
        (label, "bucket_swept (sized)", functools.partial(sized_bucket_swept, sizes=path_sizes),
         (cut.x_prev, cut.x, cut.surface)),
        (label, "Search.closest", search.closest, (state, cut.x, cut.surface)),
        (die_label, "bucket_sort (sized)",
         functools.partial(sized_bucket_sort, radius=die.radius, sizes=die_sizes),
         (die.x, die.surface)),
    ]  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller scenes, fewer repeats")
    parser.add_argument("--repeats", type=int, default=None, help="timed calls per program")
    args = parser.parse_args(argv)
    repeats = args.repeats or (10 if args.quick else 40)
    command = "python benchmarks/emitters.py" + (" --quick" if args.quick else "")
    print(f"`{command}`; {machine()}; float32; medians of {repeats} interleaved calls.\n")
    print(
        "| scene | program | run, fusion emitters | run, older emitters | older / fusion "
        "| run, older at O0 | O0 / fusion | compile, fusion | compile, older "
        "| compile, older at O0 | O0's answer against the default's |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for scene, name, fn, fn_args in programs(args.quick):
        (fusion, fusion_s), (older, older_s), (bare, bare_s) = compiled_each_way(fn, fn_args)
        fusion_run, older_run, bare_run = medians([fusion, older, bare], fn_args, repeats, 2)
        print(f"| {scene} | `{name}` | {fusion_run * 1e3:.2f} ms | {older_run * 1e3:.2f} ms "
              f"| {older_run / fusion_run:.2f} | {bare_run * 1e3:.2f} ms "
              f"| {bare_run / fusion_run:.2f} | {fusion_s:.2f} s | {older_s:.2f} s "
              f"| {bare_s:.2f} s | {differences(fusion(*fn_args), bare(*fn_args))} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
