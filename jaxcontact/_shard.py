"""Scale-out on JAX's own machinery: slaves split over devices.

(Batches need nothing new: every detector, and ``Search``, maps over a
leading axis with ``jax.vmap``.)

Devices: ``sharded`` runs a detector under ``jax.shard_map`` with the slave
rows split over one mesh axis and the master replicated. Each device searches
its own rows, so the only communication is the ``psum`` that ORs
``overflow``; reductions onto the tool (``forces.penalty(...,
axis_name=...)``) are one more ``psum``. The same code runs on one host or
many (``jax.distributed.initialize`` first; see the README).

Arrays already sharded with ``jax.sharding`` may also be passed to the
detectors as they are (``_pipeline.placement``): each program gathers them and
searches every row on every device, which is simpler but does not split the
work.
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding
from jax.sharding import PartitionSpec as P

from jaxcontact._detect import bucket_sort, bucket_swept
from jaxcontact._pipeline import driver
from jaxcontact._pipeline import inputs as _inputs
from jaxcontact._pipeline.sizes import measure_batch
from jaxcontact._query.closest import CLOSEST
from jaxcontact._query.swept import SWEPT
from jaxcontact._types import Array, Sizes, Surface


def shard_rows(num_rows: int, num_shards: int) -> int:
    """Rows per device once ``num_rows`` are padded to a multiple of ``num_shards``."""
    return max(1, -(-num_rows // num_shards))


def _pad_rows(values: Array, rows: int, fill=0) -> Array:
    pad = rows - values.shape[0]
    return jnp.pad(values, ((0, pad),) + ((0, 0),) * (values.ndim - 1), constant_values=fill)


def _device_sizes(detector, points, surface: Surface, rows, num_shards: int, radius) -> Sizes:
    """Sizes for one device's rows of a bucket detector: the padded rows
    split ``num_shards`` ways and measured as a batch."""
    per_device = points[0].shape[0] // num_shards

    def split(values):
        return np.asarray(values).reshape((num_shards, per_device) + values.shape[1:])

    if detector is bucket_swept:
        return measure_batch(split(points[1]), surface, x_prev=split(points[0]), mask=split(rows))
    return measure_batch(split(points[0]), surface, radius=radius, mask=split(rows))


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
        or a function of the same form. The bucket detectors measure their
        sizes for one device's rows from the concrete data, so call them
        plainly (the call compiles itself), not under an outer ``jit``.
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
        if kwargs.get("compact"):
            raise ValueError(
                "sharded(...) returns the N-row Contact or Crossing: compact=True is not supported "
                "(search the sharded arrays with Search(compact=True) instead)"
            )
        per_row = [k for k in ("slave_node", "slave_body") if kwargs.get(k) is not None]
        per_row += ["radius"] if np.ndim(kwargs.get("radius", 0)) else []
        per_row += ["self_contact"] if kwargs.get("self_contact") else []
        rule = kwargs.get("pairs")
        every_pair = rule is None or (
            rule.slave_node is None
            and rule.slave_body is None
            and not rule.self_contact
            and rule.allow is None
        )
        per_row += [] if every_pair else ["pairs"]
        if per_row:
            raise ValueError(
                f"sharded(...) splits the slave arrays only: {', '.join(per_row)} "
                "(the pair rule, a radius per slave) are not supported; pass the arrays "
                "sharded with jax.sharding straight to the detector instead"
            )
        kwargs.pop("self_contact", None)
        kwargs.pop("pairs", None)  # every pair: the detector's default
        *points, surface = args
        if not points:
            raise ValueError("sharded(detector) needs the slave arrays before the surface")
        num_rows = jnp.shape(points[0])[0]
        total = shard_rows(num_rows, num_shards) * num_shards
        points = [_pad_rows(jnp.asarray(p), total) for p in points]
        rows = jnp.ones(num_rows, bool) if mask is None else jnp.asarray(mask)
        rows = _pad_rows(rows, total, False)
        static = tuple(sorted(k for k, v in kwargs.items() if v is None))
        arrays = {k: v for k, v in kwargs.items() if v is not None}
        on_device = detector
        if detector is bucket_sort or detector is bucket_swept:
            on_device = _sized(detector, points, surface, rows, num_shards, arrays)
        split = NamedSharding(mesh, P(axis))
        rows, *points = (jax.reshard(v, split) for v in (rows, *points))
        # Compiled once per detector, sizes, mesh and shapes: a plain call
        # of ``run`` at the same shapes reuses it.
        where = {"on_device": on_device, "mesh": mesh, "axis": axis, "none": static}
        result = _split(surface, arrays, rows, *points, **where)
        if total == num_rows:
            return result
        # Uneven rows cannot stay split (JAX's explicit sharding refuses the
        # slice): the padded result is gathered, then cut.
        whole = NamedSharding(mesh, P())
        return jax.tree.map(
            lambda v: v if v.ndim == 0 else jax.reshard(v, whole)[:num_rows], result
        )

    return run


@functools.partial(jax.jit, static_argnames=("on_device", "mesh", "axis", "none"))
def _split(surface, arrays, rows, *points, on_device, mesh, axis, none):
    """``on_device`` on each device's rows under ``jax.shard_map``; overflow OR-ed."""
    static = dict.fromkeys(none)

    def on_one_device(surface, arrays, rows, *points):
        return on_device(*points, surface, mask=rows, **arrays, **static)

    def local(*args):
        result = on_one_device(*args)
        anywhere = jax.lax.psum(result.overflow.astype(jnp.int32), axis) > 0
        return result._replace(overflow=anywhere)

    num_shards = mesh.shape[axis]
    one_device = [
        jax.ShapeDtypeStruct((v.shape[0] // num_shards,) + v.shape[1:], v.dtype)
        for v in (rows, *points)
    ]
    template = jax.eval_shape(on_one_device, surface, arrays, *one_device)
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
    return mapped(surface, arrays, rows, *points)


@dataclasses.dataclass(frozen=True)
class _Sized:
    """A bucket detector with fixed sizes: hashable, so its program is cached."""

    sizes: Sizes

    def __call__(self, *points, mask, radius=None):
        surface = points[-1]
        if self.sizes.for_paths:
            x_prev, x = points[:2]
            return driver.sized_jit(SWEPT, (x_prev, x), surface, None, mask, sizes=self.sizes)
        return driver.sized_jit(CLOSEST, (points[0],), surface, radius, mask, sizes=self.sizes)


def _sized(detector, points, surface, rows, num_shards: int, arrays) -> _Sized:
    """``detector`` on one device's rows with sizes measured for them on the host."""
    _inputs.require_concrete(f"sharded({detector.__name__})", (points, surface, rows, arrays))
    if detector is bucket_swept:
        _, x, _ = _inputs.check_path_inputs(points[0], points[1], None)
        surface = _inputs.check_surface(surface, x.dtype)
        return _Sized(_device_sizes(detector, points, surface, rows, num_shards, None))
    x, surface, radius, _ = _inputs.check_contact_inputs(
        points[0], surface, arrays.get("radius"), None
    )
    arrays["radius"] = radius
    return _Sized(_device_sizes(detector, points, surface, rows, num_shards, radius))
