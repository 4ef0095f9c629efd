"""The benchmarks behind ``jaxcontact bench`` and ``benchmarks/*.py``.

One module per benchmark, each with ``run(quick, out)`` (returns its markdown
section and writes CSV and PNG files into ``out``) and ``main(argv)``:

- ``paper_tests``: the source paper's Tests 1 and 2 (its Figs. 8 and 9);
- ``peers``: jaxcontact beside NumPy, scipy, shapely, jax-md, libigl, a
  hand-written numba grid and IPC Toolkit;
- ``swept_peers``: the same for the path-crossing query (``bucket_swept``
  beside NumPy, the numba grid and IPC Toolkit's CCD);
- ``time_vs_error``: run time against error, and float32 error against offset.

``oracle`` is the float64 reference every answer is checked against and
``baselines`` holds the peers (with ``numba_grid`` and ``ipc``). Optional
packages (matplotlib, tqdm, scipy, shapely, jax-md, libigl, numba, ipctk) are
imported where used; a missing one is reported, never a crash.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

MODULES = ("paper_tests", "peers", "swept_peers", "time_vs_error")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``jaxcontact bench``, on ``parser`` (the command line's subparser)."""
    parser.add_argument("--quick", action="store_true", help="small sizes: under two minutes")
    parser.add_argument("--out", default="jaxcontact-bench", help="folder for CSV and PNG files")
    parser.add_argument(
        "--only",
        default=",".join(MODULES),
        type=_names,
        help=f"benchmarks to run, of {','.join(MODULES)}",
    )


def _names(text: str) -> list[str]:
    names = text.split(",")
    unknown = [name for name in names if name not in MODULES]
    if unknown:
        raise argparse.ArgumentTypeError(f"expected names from {MODULES}; got {unknown}")
    return names


def run_all(args: argparse.Namespace) -> int:
    """Runs the benchmarks ``args.only`` names in turn; prints their tables; returns 0."""
    import importlib

    import jax

    names = args.only if isinstance(args.only, list) else _names(args.only)
    jax.config.update("jax_enable_x64", True)  # float64 oracle scenes and variants
    began = time.perf_counter()
    for name in names:
        module = importlib.import_module(f"jaxcontact.bench.{name}")
        print(module.run(args.quick, args.out), flush=True)
    print(
        f"wrote CSV, markdown and PNG files to {os.path.abspath(args.out)} "
        f"in {time.perf_counter() - began:.0f} s",
        file=sys.stderr,
    )
    return 0


def main(argv=None) -> int:
    """``jaxcontact bench`` as a function of its argument list."""
    parser = argparse.ArgumentParser(prog="jaxcontact bench", description=__doc__.splitlines()[0])
    add_arguments(parser)
    return run_all(parser.parse_args(argv))
