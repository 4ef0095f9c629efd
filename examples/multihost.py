"""Contact detection with the slaves split over every device of every host.

Start one process per host. On one machine (the default) it makes a
one-process "cluster" on localhost; on a cluster give each process the same
coordinator and its own id, or ``--auto`` where JAX detects the cluster
(SLURM, Open MPI, TPU pods, ...):

    python examples/multihost.py                                  # one host
    XLA_FLAGS=--xla_force_host_platform_device_count=4 python examples/multihost.py
    python examples/multihost.py --coordinator host0:1234 --processes 2 --process-id 0  # host 0
    python examples/multihost.py --coordinator host0:1234 --processes 2 --process-id 1  # host 1
    python examples/multihost.py --auto                           # under SLURM etc.

Every process builds the same scene (as a simulation would from the same
input), the detection runs once over the global mesh, and process 0 prints
what was found and the force on the tool (a ``psum`` across all devices).
"""

from __future__ import annotations

import argparse
import socket


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--coordinator", help="host:port of process 0 (default: localhost)")
    parser.add_argument("--processes", type=int, default=1)
    parser.add_argument("--process-id", type=int, default=0)
    parser.add_argument("--auto", action="store_true", help="let JAX detect the cluster")
    parser.add_argument("--nodes", type=int, default=81_939, help="workpiece nodes")
    args = parser.parse_args()

    import jax

    if args.auto:
        jax.distributed.initialize()
    else:
        jax.distributed.initialize(
            coordinator_address=args.coordinator or f"127.0.0.1:{free_port()}",
            num_processes=args.processes,
            process_id=args.process_id,
        )

    import jax.numpy as jnp

    from jaxcontact import all_to_all, bucket_sort, sharded
    from jaxcontact.forces import penalty
    from jaxcontact.scenes import cutting_scene

    devices = jax.devices()
    mesh = jax.make_mesh((len(devices),), ("slaves",))
    scene = cutting_scene(args.nodes, x_tip=18.0)
    # The bucket sort measures its sizes for one device's rows from the
    # concrete data on the host, so it is called plainly, outside jit.
    binned = sharded(bucket_sort, mesh)(scene.x, scene.surface, radius=scene.radius)
    dense = jax.jit(sharded(all_to_all, mesh))(scene.x, scene.surface, radius=scene.radius)

    @jax.jit
    def summary(binned, dense):
        # The sum over devices is a collective.
        on_tool = -jnp.sum(penalty(binned, scene.surface, 1e4).on_slaves, axis=0)
        same = jnp.all((dense.segment == binned.segment) | ~dense.found)
        return jnp.sum(binned.found), jnp.sum(binned.active), on_tool, same, binned.overflow

    found, active, on_tool, same, overflow = summary(binned, dense)
    if jax.process_index() == 0:
        print(
            f"{jax.process_count()} process(es), {len(devices)} device(s): "
            f"{int(found)} slaves found, {int(active)} active, "
            f"force on the tool {[round(float(v), 3) for v in on_tool]}, "
            f"bucket sort = all-to-all: {bool(same)}, overflow: {bool(overflow)}"
        )
    jax.distributed.shutdown()


if __name__ == "__main__":
    main()
