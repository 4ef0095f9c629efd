"""Time against device count and batch size.

    python benchmarks/scaling.py            # devices 1, 2, 4; batches 1, 4, 16
    python benchmarks/scaling.py --quick    # small sizes, a smoke test

Device counts are fixed when JAX starts, so each count runs in a process of
its own (``--xla_force_host_platform_device_count``). On a CPU those devices
share the machine's cores: on a 2-core machine the numbers show the overhead
of splitting (padding, the shard_map, the overflow psum, a gather where N is
not a multiple of the device count), not a speed-up. Run it where the devices
are real (several GPUs, or hosts with ``examples/multihost.py``) to see
scaling; the script is the same.

Devices: ``sharded(all_to_all)`` under ``jit``; ``bucket_sort (sized)``, the
bucket sort under ``sharded`` and ``jit`` with one device's ``Sizes``
measured outside the timer (as ``sharded(bucket_sort)`` measures them); and
``sharded(bucket_sort)`` called plainly, as a user calls it, which measures
those sizes on the host at every call (its "compile s" is its first call;
timed by 3 calls, as each call currently compiles its ``shard_map`` anew).

Devices, "x sharded on explicit axes" / "on auto axes": the slaves sharded
with ``jax.sharding`` and passed straight to ``all_to_all`` and the sized
bucket sort under ``jit``, rows cut to a multiple of 4 (and
``sharded(all_to_all)`` on the same rows). On explicit axes each program
gathers them, so every device searches every row; on auto axes the
compiler partitions the program.

Batches: B cutting scenes (the tool at B positions) under ``jax.vmap`` with
one ``Sizes`` for the batch (``jaxcontact._pipeline.sizes.measure_batch``; on the CPU
the searches inside run scene by scene, the rest batched), against
``jax.lax.map`` over the whole detector and a Python loop of single calls,
each scene with its own sizes; time per scene. The bucket sort rows are
"(sized)": sizes measured outside the timer, the whole search inside.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

RESULT = "RESULT "


def worker(devices: int, num_nodes: int, repeats: int, batches: list[int]) -> None:
    import functools

    import jax
    import jax.numpy as jnp
    from jax.sharding import AxisType, NamedSharding
    from jax.sharding import PartitionSpec as P

    from benchmarks.harness._run import sized_contact
    from benchmarks.harness.internals import (
        _bucket,
        _device_sizes,
        _pad_rows,
        measure,
        measure_batch,
        shard_rows,
    )
    from benchmarks.harness.timing import time_call
    from jaxcontact import Surface, all_to_all, bucket_sort, sharded
    from jaxcontact.scenes import cutting_scene

    assert len(jax.devices()) == devices, jax.devices()
    radius = 0.1

    def emit(kind, method, size, timing, per=1):
        row = {
            "kind": kind,
            "devices": devices,
            "method": method,
            "size": size,
            "median_ms": timing.median_s * 1e3 / per,
            "p10_ms": timing.p10_s * 1e3 / per,
            "p90_ms": timing.p90_s * 1e3 / per,
            "compile_s": timing.compile_s,
        }
        print(RESULT + json.dumps(row), flush=True)

    scene = cutting_scene(num_nodes, 18.0)
    mesh = jax.make_mesh((devices,), ("slaves",))
    dense = jax.jit(functools.partial(sharded(all_to_all, mesh), radius=radius))
    emit(
        "devices",
        "all_to_all",
        num_nodes,
        time_call(dense, scene.x, scene.surface, repeats=repeats),
    )
    # One device's sizes, measured here as sharded(bucket_sort) measures them
    # at each call: the rows padded to a multiple of the device count, split.
    num_rows = scene.x.shape[0]
    total = shard_rows(num_rows, devices) * devices
    rows = _pad_rows(jnp.ones(num_rows, bool), total, False)
    padded = _pad_rows(scene.x, total)
    sizes = _device_sizes(bucket_sort, [padded], scene.surface, rows, devices, radius)

    def on_device(x, surface, *, mask, radius):
        r = jnp.asarray(radius, x.dtype)
        return _bucket.contact_jit(x, surface, r, mask, sizes=sizes)

    binned = jax.jit(functools.partial(sharded(on_device, mesh), radius=radius))
    emit(
        "devices",
        "bucket_sort (sized)",
        num_nodes,
        time_call(binned, scene.x, scene.surface, repeats=repeats),
    )
    # As a user calls it: a plain call that measures the sizes every time.
    # Each call also compiles its shard_map anew (seconds), so 3 runs only.
    measured = functools.partial(sharded(bucket_sort, mesh), radius=radius)
    emit(
        "devices",
        "sharded(bucket_sort), plain call",
        num_nodes,
        time_call(measured, scene.x, scene.surface, repeats=min(repeats, 3), warmup=0),
    )
    # The slaves sharded with jax.sharding and passed straight in. Explicit
    # axes: each program gathers them and searches every row on every device.
    # Auto axes: the compiler partitions the program as it sees fit.
    # Rows cut to a multiple of 4, to split evenly over 1, 2 and 4 devices (on
    # the CPU all_to_all also runs faster on such a count: compare these rows
    # with each other, not with those above).
    even = num_rows - num_rows % 4
    timing = time_call(dense, scene.x[:even], scene.surface, repeats=repeats)
    emit("devices", "all_to_all, sharded(), rows cut to a multiple of 4", even, timing)
    detectors = {
        "all_to_all": jax.jit(functools.partial(all_to_all, radius=radius)),
        "bucket_sort (sized)": sized_contact(
            radius, measure(scene.x[:even], scene.surface, radius=radius)
        ),
    }
    for axes in (AxisType.Explicit, AxisType.Auto):
        typed = jax.make_mesh((devices,), ("slaves",), axis_types=(axes,))
        split = jax.device_put(scene.x[:even], NamedSharding(typed, P("slaves")))
        for name, detect in detectors.items():
            timing = time_call(detect, split, scene.surface, repeats=repeats)
            emit("devices", f"{name}, x sharded on {axes.name.lower()} axes", even, timing)
    if devices != 1:
        return

    # Batches, on one device.
    for size in batches:
        tips = jnp.linspace(12.0, 20.5, size)
        scenes = [cutting_scene(num_nodes, float(tip)) for tip in tips]
        x = jnp.stack([s.x for s in scenes])
        surface = Surface(
            jnp.stack([s.surface.nodes for s in scenes]),
            jnp.stack([s.surface.segments for s in scenes]),
        )
        for name in ("all_to_all", "bucket_sort (sized)"):
            if name == "bucket_sort (sized)":
                one = sized_contact(radius, measure_batch(x, surface, radius=radius))
            else:
                one = functools.partial(all_to_all, radius=radius)
            mapped = jax.jit(jax.vmap(one))
            emit(
                "batch", f"{name} vmap", size, time_call(mapped, x, surface, repeats=repeats), size
            )
            serial = jax.jit(lambda x, s, one=one: jax.lax.map(lambda a: one(*a), (x, s)))
            emit(
                "batch",
                f"{name} lax.map",
                size,
                time_call(serial, x, surface, repeats=repeats),
                size,
            )
            if name == "bucket_sort (sized)":
                own = [
                    sized_contact(radius, measure(s.x, s.surface, radius=radius)) for s in scenes
                ]
            else:
                own = [one] * size
            single = [jax.jit(f) for f in own]

            def loop(x, surface, single=single):
                return [
                    f(x[i], Surface(surface.nodes[i], surface.segments[i]))
                    for i, f in enumerate(single)
                ]

            emit(
                "batch",
                f"{name} Python loop",
                size,
                time_call(loop, x, surface, repeats=repeats),
                size,
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--nodes", type=int, default=None)
    args = parser.parse_args()
    num_nodes = args.nodes or (5_000 if args.quick else 81_939)
    batches = [1, 4] if args.quick else [1, 4, 16]
    repeats = 5 if args.quick else args.repeats
    if args.worker:
        worker(args.worker, num_nodes, repeats, batches)
        return

    import jax

    rows = []
    for devices in (1, 2, 4):
        env = dict(os.environ)
        env["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={devices}"
        done = subprocess.run(
            [sys.executable, __file__, "--worker", str(devices), "--nodes", str(num_nodes)]
            + (["--quick"] if args.quick else ["--repeats", str(repeats)]),
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode:
            sys.exit(done.stdout + done.stderr)
        rows += [
            json.loads(line[len(RESULT) :])
            for line in done.stdout.splitlines()
            if line.startswith(RESULT)
        ]

    print(
        f"# scaling.py: jax {jax.__version__}, {os.cpu_count()} CPU cores,"
        f" cutting scene {num_nodes:,} nodes, float32"
    )
    print("\n## Slaves split over devices (per call)\n")
    print("| method | devices | median ms | p10-p90 ms | vs 1 device | compile s |")
    print("|---|---:|---:|---:|---:|---:|")
    base = {
        r["method"]: r["median_ms"] for r in rows if r["kind"] == "devices" and r["devices"] == 1
    }
    for r in (r for r in rows if r["kind"] == "devices"):
        spread = f"{r['p10_ms']:.3f}-{r['p90_ms']:.3f}"
        ratio = r["median_ms"] / base[r["method"]]
        print(
            f"| {r['method']} | {r['devices']} | {r['median_ms']:.3f} | {spread}"
            f" | {ratio:.2f}x | {r['compile_s']:.2f} |"
        )
    print("\n## Batches of scenes on one device (per scene)\n")
    print("| method | batch | median ms per scene | p10-p90 ms | compile s |")
    print("|---|---:|---:|---:|---:|")
    for r in (r for r in rows if r["kind"] == "batch"):
        compile_s = "" if r["compile_s"] is None else f"{r['compile_s']:.2f}"
        spread = f"{r['p10_ms']:.3f}-{r['p90_ms']:.3f}"
        print(f"| {r['method']} | {r['size']} | {r['median_ms']:.3f} | {spread} | {compile_s} |")


if __name__ == "__main__":
    main()
