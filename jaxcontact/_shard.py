"""Scale-out on JAX's own machinery: batches of scenes and slaves split over devices.

Batches need nothing new: every detector maps over a leading axis with
``jax.vmap``. The bucket detectors take one static plan for the whole batch,
which ``plan_batch`` makes by planning each scene and keeping the largest
sizes, then checking every scene against the result.

Devices: ``sharded`` runs a detector under ``jax.shard_map`` with the slave
rows split over one mesh axis and the master replicated. Each device searches
its own rows, so the only communication is the ``psum`` that ORs
``overflow``; reductions onto the tool (``contact_forces(...,
axis_name=...)``) are one more ``psum``. The same code runs on one host or
many (``jax.distributed.initialize`` first; see the README).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding
from jax.sharding import PartitionSpec as P

from jaxcontact import _inputs
from jaxcontact._bucket import _contact_jit, _crossing_jit
from jaxcontact._plan import BucketPlan, plan_buckets
from jaxcontact._types import Array, Contact, Surface


def _scene(values, index):
    return None if values is None else values[index]


def plan_batch(
    x: Array,
    surface: Surface,
    *,
    radius=None,
    x_prev: Array | None = None,
    mask: Array | None = None,
    **kwargs,
) -> BucketPlan:
    """One bucket plan that holds every scene of a batch.

    Args:
      x: f[B, N, 2] concrete slave coordinates of B scenes.
      surface: the master, shared (nodes f[P, 2]) or one per scene (f[B, P, 2],
        segments i32[B, M, 2], mask bool[B, M]).
      radius: scalar search radius (for ``bucket_sort``).
      x_prev: f[B, N, 2] previous positions (for ``bucket_swept``).
      mask: optional bool[B, N].
      **kwargs: further arguments of ``plan_buckets`` (``slack``, ``block_size``, ...).

    Returns:
      A ``BucketPlan`` with which no scene of the batch overflows (checked by
      running each), for ``jax.vmap(lambda x, s: bucket_sort(x, s, radius=r, plan=plan))``.
    """
    x = np.asarray(x)
    if x.ndim != 3 or x.shape[-1] != 2:
        raise ValueError(f"x must have shape (B, N, 2); got {x.shape}")
    shared = np.ndim(surface.nodes) == 2
    scenes = []
    for index in range(x.shape[0]):
        own = surface if shared else jax.tree.map(lambda leaf, i=index: leaf[i], surface)
        scenes.append((x[index], own, _scene(x_prev, index), _scene(mask, index)))

    def plan_for(scene, **sizes):
        points, own, before, rows = scene
        where = {"radius": radius} if x_prev is None else {"x_prev": before}
        return plan_buckets(points, own, mask=rows, **where, **kwargs, **sizes)

    # Each scene's own plan, then every scene measured again at one cell edge
    # (the largest chosen), so that the largest of each size holds for all.
    alone = [plan_for(scene) for scene in scenes]
    edge = max(plan.cell_size for plan in alone)
    plans = [plan_for(scene, cell_size=edge) for scene in scenes] if edge > 0 else alone
    plan = plans[0]
    for other in plans[1:]:
        plan = _largest(plan, other)
    stuck = [index for index, scene in enumerate(scenes) if _overflows(plan, scene, radius)]
    if stuck:
        raise RuntimeError(f"plan_batch: scenes {stuck} overflow the merged plan {plan}")
    return plan


def _largest(first: BucketPlan, second: BucketPlan) -> BucketPlan:
    """Each size the larger of two plans' (measured at the same cell edge)."""
    return dataclasses.replace(
        first,
        block_capacity=max(first.block_capacity, second.block_capacity),
        use_cells=first.use_cells or second.use_cells,
        grid_shape=tuple(map(max, first.grid_shape, second.grid_shape)),
        cell_size=max(first.cell_size, second.cell_size),
        span=tuple(map(max, first.span, second.span)),
        cell_capacity=max(first.cell_capacity, second.cell_capacity),
    )


def _overflows(plan: BucketPlan, scene, radius) -> bool:
    points, surface, before, rows = scene
    points = jnp.asarray(points)
    rows = None if rows is None else jnp.asarray(rows)
    if plan.for_paths:
        result = _crossing_jit(jnp.asarray(before), points, surface, rows, plan=plan)
    else:
        radius = _inputs.check_radius(radius, points.dtype)
        result = _contact_jit(points, surface, radius, rows, plan=plan)
    return bool(result.overflow)


def shard_rows(num_rows: int, num_shards: int) -> int:
    """Rows per device once ``num_rows`` are padded to a multiple of ``num_shards``."""
    return max(1, -(-num_rows // num_shards))


def _pad_rows(values: Array, rows: int, fill=0) -> Array:
    pad = rows - values.shape[0]
    return jnp.pad(values, ((0, pad),) + ((0, 0),) * (values.ndim - 1), constant_values=fill)


def plan_sharded(
    x: Array, surface: Surface, num_shards: int, *, x_prev: Array | None = None, mask=None, **kwargs
) -> BucketPlan:
    """A bucket plan for ``sharded(bucket_sort or bucket_swept, ...)``: one
    device's rows of ``x`` padded as ``sharded`` pads them, planned as a batch.

    Arguments as for ``plan_buckets``, plus the device count ``num_shards``.
    """
    x = jnp.asarray(x)
    per_shard = shard_rows(x.shape[0], num_shards)
    total = per_shard * num_shards
    rows = jnp.ones(x.shape[0], bool) if mask is None else jnp.asarray(mask)

    def split(values, fill=0):
        values = _pad_rows(values, total, fill)
        return values.reshape((num_shards, per_shard) + values.shape[1:])

    before = None if x_prev is None else split(jnp.asarray(x_prev))
    return plan_batch(split(x), surface, x_prev=before, mask=split(rows, False), **kwargs)


def sharded(detector, mesh: Mesh, *, axis: str | None = None):
    """``detector`` with the slave rows split over one axis of ``mesh``.

    The master (and every keyword array, such as ``radius``) is replicated;
    the slave arrays (the positional arguments before the surface) and
    ``mask`` are padded with masked rows to a multiple of the device count
    and split by rows. Every device runs ``detector`` on its rows; the rows
    come back in order, and ``overflow`` is True if it is on any device. The
    result stays sharded over ``axis`` when N is a multiple of the device
    count; otherwise it is gathered (replicated) to cut the padding off, so
    pad N yourself to keep it split.

    Args:
      detector: ``all_to_all``, ``bucket_sort``, ``swept``, ``bucket_swept``,
        or a function of the same form. Bucket detectors need
        ``plan=plan_sharded(...)``: a plan for one device's rows.
      mesh: a ``jax.sharding.Mesh``.
      axis: the mesh axis to split over; the mesh's only axis by default.

    Returns:
      A function with ``detector``'s signature.

    Example:
      >>> import jax
      >>> from jaxcontact import all_to_all, sharded
      >>> from jaxcontact.scenes import cutting_scene
      >>> scene = cutting_scene(1_000, 18.0)
      >>> mesh = jax.make_mesh((len(jax.devices()),), ("slaves",))
      >>> contact = jax.jit(sharded(all_to_all, mesh))(scene.x, scene.surface, radius=0.1)
      >>> bool((contact.gap == all_to_all(scene.x, scene.surface, radius=0.1).gap).all())
      True
    """
    if axis is None:
        if len(mesh.axis_names) != 1:
            raise ValueError(f"axis must name one of the mesh axes {mesh.axis_names}")
        axis = mesh.axis_names[0]
    num_shards = mesh.shape[axis]

    def run(*args, mask: Array | None = None, **kwargs):
        *points, surface = args
        if not points:
            raise ValueError("sharded(detector) needs the slave arrays before the surface")
        num_rows = jnp.shape(points[0])[0]
        total = shard_rows(num_rows, num_shards) * num_shards
        points = [_pad_rows(jnp.asarray(p), total) for p in points]
        rows = jnp.ones(num_rows, bool) if mask is None else jnp.asarray(mask)
        rows = _pad_rows(rows, total, False)
        # Plans and other static values stay closed over; arrays go in replicated.
        static = {k: v for k, v in kwargs.items() if v is None or isinstance(v, BucketPlan)}
        arrays = {k: v for k, v in kwargs.items() if k not in static}

        def on_one_device(surface, arrays, rows, *points):
            return detector(*points, surface, mask=rows, **arrays, **static)

        def local(*args):
            result = on_one_device(*args)
            anywhere = jax.lax.psum(result.overflow.astype(jnp.int32), axis) > 0
            return result._replace(overflow=anywhere)

        per_device = total // num_shards
        one_device = [jax.ShapeDtypeStruct((per_device,) + v.shape[1:], v.dtype) for v in points]
        rows_shape = jax.ShapeDtypeStruct((per_device,), bool)
        template = jax.eval_shape(on_one_device, surface, arrays, rows_shape, *one_device)
        out_specs = jax.tree.map(lambda leaf: P() if leaf.ndim == 0 else P(axis), template)
        mapped = jax.shard_map(
            local,
            mesh=mesh,
            in_specs=(P(), P(), P(axis)) + (P(axis),) * len(points),
            out_specs=out_specs,
            # The detectors' conds return constants in their skip branches,
            # which the varying-axes check would reject; each device's
            # result is its own rows, and overflow is reduced above.
            check_vma=False,
        )
        split = NamedSharding(mesh, P(axis))
        rows, *points = (jax.reshard(v, split) for v in (rows, *points))
        result = mapped(surface, arrays, rows, *points)
        if total == num_rows:
            return result
        # Uneven rows cannot stay split (JAX's explicit sharding refuses the
        # slice): the padded result is gathered, then cut.
        whole = NamedSharding(mesh, P())
        return jax.tree.map(
            lambda v: v if v.ndim == 0 else jax.reshard(v, whole)[:num_rows], result
        )

    return run


def contact_forces(
    contact: Contact, stiffness, *, axis_name: str | None = None
) -> tuple[Array, Array]:
    """Penalty forces of a ``Contact``: on each slave, and their reaction on the master.

    The force on an active slave is ``stiffness * (-gap) * normal`` (it pushes
    the slave out along the master's outward normal); inactive rows get zero.
    The master takes the opposite of their sum. Inside ``jax.shard_map`` with
    the slaves split over ``axis_name``, that sum is a ``psum`` over the
    devices; under ``jit`` with sharded inputs, XLA inserts the same
    collective for the plain sum.

    Returns:
      ``(on_slaves f[N, 2], on_master f[2])``.
    """
    depth = jnp.where(contact.active, -contact.gap, 0)
    on_slaves = (stiffness * depth)[:, None] * contact.normal
    on_master = -jnp.sum(on_slaves, axis=0)
    if axis_name is not None:
        on_master = jax.lax.psum(on_master, axis_name)
    return on_slaves, on_master
