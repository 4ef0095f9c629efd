"""A plain one-call detector against the jitted ``Search`` step on small scenes (issue 25).

Issue 25's target 2 asks that "a plain one-call detector on a small scene
costs about what a jitted step costs". A plain call (``all_to_all(x,
surface, radius=r)``, ``bucket_sort(...)``, ``swept(...)``,
``bucket_swept(...)`` on concrete arrays, outside ``jit``) checks its
inputs on the host, pads them to a size class, runs a compiled program and
cuts the rows back; the bucket forms also need their sizes. A simulation's
step instead calls ``jax.jit(search.closest)`` on a state allocated once.

Scenes (float32): the paper's Test 1 at its smallest (a 5 x 5 grid, 25 slave
nodes, against its 2-segment tool), and the cutting scene at 10^3 and 10^4
nodes (20 segments). Each call gets the next of 8 slave configurations
(the scene moved by up to 1 % of its radius, in turn; JAX arrays, as a
simulation holds them), so that a size or result kept from the last call is
not simply the answer: every detector, plain or jitted, is called on the
same sequence. The jitted steps' states
are allocated once, outside the timer, for the 8 configurations
(``at_least``). Timed round-robin in one process
(``benchmarks.harness.timing.time_interleaved``: warm-up calls, then
``--repeats`` rounds, every call ended by ``block_until_ready``; median and
10th-90th percentile). The ratio column is each median over the jitted
``Search`` step's for the same query; the last, each plain call's over the
same program jitted (``jax.jit`` of the dense detector; for a bucket form,
the ``Search`` step, whose program it runs). Every plain answer's ``segment`` and
``found`` (``crossed``) are checked against the jitted step's.

    python benchmarks/one_call.py             # 300 rounds
    python benchmarks/one_call.py --quick     # 20 rounds, a smoke test
    taskset -c 0 python benchmarks/one_call.py
"""

from __future__ import annotations

import argparse
import itertools
import pathlib
import platform
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

import jaxcontact
from benchmarks.harness.timing import pinned_note, time_interleaved
from jaxcontact.scenes import cutting_scene, paper_scene

CONFIGURATIONS = 8
# Each query's jitted Search step, the reference of its rows.
STEP = {
    "closest": "closest: jitted Search.closest step",
    "swept": "swept: jitted Search.swept step",
}


def scenes():
    """name -> (scene, radius)."""
    return {
        "paper Test 1, 25 nodes, 2 segments": (paper_scene(4), 0.5),
        "cutting, 10^3 nodes, 20 segments": (cutting_scene(1_000, 18.0, x_tip_prev=18.2), 0.1),
        "cutting, 10^4 nodes, 20 segments": (cutting_scene(10_000, 18.0, x_tip_prev=18.2), 0.1),
    }


def configurations(scene, radius: float):
    """``CONFIGURATIONS`` (x_prev, x) pairs: the scene moved a little, in turn."""
    moved = []
    for k in range(CONFIGURATIONS):
        shift = np.float32(0.01 * radius * k / CONFIGURATIONS)
        moved.append((jnp.asarray(scene.x_prev) + shift, jnp.asarray(scene.x) + shift))
    return moved


def cycling(call, moved):
    """A call of no arguments that runs ``call(x_prev, x)`` on the next configuration."""
    turn = itertools.cycle(moved)

    def next_call():
        return call(*next(turn))

    return next_call


def rows_for(scene, radius: float, repeats: int, warmup: int):
    moved = configurations(scene, radius)
    surface = scene.surface
    search = jaxcontact.Search(radius=radius)
    state = None
    for x_prev, x in moved:
        state = search.allocate(x, surface, x_prev=x_prev, at_least=state)
    closest, swept = jax.jit(search.closest), jax.jit(search.swept)
    dense = jax.jit(lambda x: jaxcontact.all_to_all(x, surface, radius=radius))
    dense_swept = jax.jit(lambda xp, x: jaxcontact.swept(xp, x, surface))
    calls = {
        STEP["closest"]: lambda xp, x: closest(state, x, surface)[0],
        "closest: jitted all_to_all": lambda xp, x: dense(x),
        "closest: plain all_to_all": lambda xp, x: jaxcontact.all_to_all(x, surface, radius=radius),
        "closest: plain bucket_sort": lambda xp, x: jaxcontact.bucket_sort(
            x, surface, radius=radius
        ),
        STEP["swept"]: lambda xp, x: swept(state, xp, x, surface)[0],
        "swept: jitted swept": lambda xp, x: dense_swept(xp, x),
        "swept: plain swept": lambda xp, x: jaxcontact.swept(xp, x, surface),
        "swept: plain bucket_swept": lambda xp, x: jaxcontact.bucket_swept(xp, x, surface),
    }
    # Answers first: each plain form against the jitted step, configuration by configuration.
    for x_prev, x in moved:
        want = {query: calls[step](x_prev, x) for query, step in STEP.items()}
        for name, call in calls.items():
            query = name.split(":")[0]
            got, reference = call(x_prev, x), want[query]
            flag = "found" if query == "closest" else "crossed"
            for field in ("segment", flag):
                if not np.array_equal(np.asarray(getattr(got, field)), getattr(reference, field)):
                    raise AssertionError(f"{name}: {field} differs from the jitted step's")
    timed = {name: (cycling(call, moved), ()) for name, call in calls.items()}
    return time_interleaved(timed, repeats=repeats, warmup=warmup)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 rounds: a smoke test")
    parser.add_argument("--repeats", type=int, default=None, help="timed rounds (300)")
    parser.add_argument("--warmup", type=int, default=10, help="untimed calls of each first")
    args = parser.parse_args(argv)
    repeats = args.repeats or (20 if args.quick else 300)
    print(
        f"`python benchmarks/one_call.py`; {platform.processor() or platform.machine()}; "
        f"{pinned_note()}; jax {jax.__version__}, jaxcontact {jaxcontact.__version__}; "
        f"float32; {repeats} interleaved rounds, {CONFIGURATIONS} configurations in turn; "
        "every plain answer equal to the jitted step's (segment, found or crossed)."
    )
    print()
    print("| scene | call | median (ms) | p10-p90 (ms) | / jitted step | / its jitted form |")
    print("|---|---|---:|---|---:|---:|")
    for scene_name, (scene, radius) in scenes().items():
        timings = rows_for(scene, radius, repeats, args.warmup)
        for name, timing in timings.items():
            step = timings[STEP[name.split(":")[0]]]
            # A plain call over the same program jitted: a dense detector's
            # jitted call, a bucket form's Search step.
            own = ""
            if "plain" in name:
                same = timings.get(name.replace("plain", "jitted"), step)
                own = f"{timing.median_s / same.median_s:.2f}"
            print(
                f"| {scene_name} | {name} | {timing.median_s * 1e3:.3f} | "
                f"{timing.p10_s * 1e3:.3f}-{timing.p90_s * 1e3:.3f} | "
                f"{timing.median_s / step.median_s:.2f} | {own} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
