"""Steps per second of the ploughing simulation, and the share of a step spent in detection.

    python benchmarks/simulate.py            # 10,000 and 63,001 nodes, travel 0.5 mm
    python benchmarks/simulate.py --quick    # 2,000 nodes, a smoke test

Each row runs ``jaxcontact.sim`` as ``jaxcontact demo`` does
(``jaxcontact.sim.demo.run_demo``): the set-up and the search's sizes on the
host, one run to compile (allocating larger sizes if they overflowed), then
the whole ``lax.scan`` timed ``--repeats`` times (median, 10th–90th
percentile), float32, jit.

Detection share: the same scan with detection replaced by a fixed contact
result (``run(..., detect=False)``: the same elastic update and force
assembly; no ``Search.closest``: no skin check, no re-finding, no search)
is timed too, and the share is ``1 - without / with``: what detection adds to
a step inside the compiled loop. Slaves: the workpiece's free outline (the
default) and, for comparison, every node (the cutting scene's slaves).
"""

from __future__ import annotations

import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness.timing import pinned_note
from jaxcontact.sim.demo import run_demo


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, a smoke test")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per row")
    args = parser.parse_args()
    sizes, travel = ((2_000,), 0.1) if args.quick else ((10_000, 63_001), 0.5)

    print(f"jax {jax.__version__} on {jax.devices()[0].device_kind}; {pinned_note()}")
    print(f"\ntool travel {travel} mm at 3 m/s, steel with mass scaling 1e4, float32\n")
    # The method, with the table, so that RESULTS.md (benchmarks/results.py) carries it.
    print(" ".join(__doc__.split("\n\n", 2)[2].split()) + "\n")
    print(
        "| nodes | slaves | steps | steps/s | scan s (p10-p90) | without detection s "
        "| detection share | list rebuilds | compile + 1st run s |"
    )
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for nodes in sizes:
        for slaves in ("surface", "all"):
            summary, drawn = run_demo(nodes, travel, args.repeats, np.float32, slaves)
            config, timed, untimed = drawn[2], drawn[5], drawn[6]
            print(
                f"| {summary.nodes:,} | {slaves} ({config.sizes.num_slaves:,}) | {summary.steps} "
                f"| {summary.steps_per_s:,.0f} | {timed.median_s:.3f} "
                f"({timed.p10_s:.3f}-{timed.p90_s:.3f}) | {untimed.median_s:.3f} "
                f"| {summary.detection_share:.1%} | {summary.rebuilds} | {summary.first_s:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
