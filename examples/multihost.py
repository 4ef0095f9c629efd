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
input); the slaves, padded with masked rows to a multiple of the device
count, are split over the global mesh, and each device searches its own rows
against the whole (replicated) tool under ``jax.shard_map``, both
exhaustively (``all_to_all``) and by bucket sort (a ``Search`` whose sizes are
measured once on the host for the batch of the devices' rows). Process 0
prints what was found and the force on the tool: sums over every device
(``psum``; ``forces.penalty(..., axis_name=)`` for the tool's reaction).
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
    import numpy as np
    from jax.sharding import NamedSharding
    from jax.sharding import PartitionSpec as P

    from jaxcontact import Search, all_to_all
    from jaxcontact.forces import penalty
    from jaxcontact.scenes import cutting_scene

    devices = jax.devices()
    mesh = jax.make_mesh((len(devices),), ("slaves",))
    scene = cutting_scene(args.nodes, x_tip=18.0)
    radius, surface = scene.radius, scene.surface
    # shard_map splits evenly: masked rows pad the slaves to a multiple of the devices.
    num_rows = scene.x.shape[0]
    x = np.pad(np.asarray(scene.x), ((0, -num_rows % len(devices)), (0, 0)))
    mask = np.arange(x.shape[0]) < num_rows

    # The bucket sort's sizes: measured once on the host, from the concrete
    # data, for the batch of the devices' rows (the largest of their sizes);
    # each device starts its state from them inside the program.
    search = Search(radius=radius)
    batch = (len(devices), -1)
    sizes = search.allocate(x.reshape(*batch, 2), surface, mask=mask.reshape(batch)).sizes

    def on_device(x, mask, surface):
        """One device's rows against the whole tool; every output summed over the devices."""
        dense = all_to_all(x, surface, radius=radius, mask=mask)
        state = search.init(x, surface, sizes=sizes, mask=mask)
        binned, _ = search.closest(state, x, surface, mask=mask)
        on_tool = penalty(binned, surface, 1e4, axis_name="slaves").on_master.sum(0)

        def total(values):
            return jax.lax.psum(jnp.sum(values.astype(jnp.int32)), "slaves")

        differ = (dense.segment != binned.segment) & dense.found
        return (
            total(binned.found),
            total(binned.active),
            on_tool,
            total(differ) == 0,
            total(binned.overflow) > 0,  # one device's overflow is the run's
        )

    summary = jax.jit(
        jax.shard_map(
            on_device,
            mesh=mesh,
            in_specs=(P("slaves"), P("slaves"), P()),
            out_specs=P(),
            # The detectors' conds return constants where they skip work,
            # which shard_map's check of varying axes refuses.
            check_vma=False,
        )
    )

    def placed(values, spec):
        """``values`` (the same in every process) as a global array over the mesh."""
        values = np.asarray(values)
        sharding = NamedSharding(mesh, spec)
        return jax.make_array_from_callback(values.shape, sharding, lambda index: values[index])

    found, active, on_tool, same, overflow = summary(
        placed(x, P("slaves")),
        placed(mask, P("slaves")),
        jax.tree.map(lambda values: placed(values, P()), surface),
    )
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
