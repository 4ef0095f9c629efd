"""Slaves split over 4 CPU devices; run by ``tests/test_shard.py`` in a process of its own.

Collected only when ``JAXCONTACT_SHARDED=1`` (set with the device count
before JAX starts).
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.sharding import NamedSharding
from jax.sharding import PartitionSpec as P

from jaxcontact import (
    all_to_all,
    bucket_sort,
    bucket_swept,
    sharded,
    swept,
)
from jaxcontact._pipeline import driver
from jaxcontact._pipeline.sizes import measure
from jaxcontact._query.closest import CLOSEST
from jaxcontact._types import CELLS_ABOVE
from jaxcontact.forces import penalty
from jaxcontact.scenes import cutting_scene, rough_die_scene
from tests.support.helpers import assert_same_contact, assert_same_crossing, penalty_total
from tests.support.tolerances import FLOAT64_EXACT_ATOL, FLOAT64_RTOL

DEVICES = 4
RADIUS = 0.1


@pytest.fixture(scope="module")
def mesh():
    assert len(jax.devices()) == DEVICES, jax.devices()
    return jax.make_mesh((DEVICES,), ("slaves",))


def _scene(num_nodes, dtype=jnp.float32):
    return cutting_scene(num_nodes, 18.0, x_tip_prev=18.3, dtype=dtype)


# cutting_scene rounds to a grid: 1,100 nodes give 1,105 rows, which need
# padding to split over 4 devices (an even split is tests/sharded/
# test_jax_sharding.py's 12 rows). One case: it compiles three programs for 4
# devices (15-20 s on 2 cores), float64 (float32 runs in the other file). The
# bucket detectors measure one device's sizes from the data themselves, so
# they are called plainly, not under jit (sharded compiles them).
@pytest.mark.parametrize("num_nodes, dtype", [(1_100, jnp.float64)])
def test_sharded_contact_equals_one_device(mesh, num_nodes, dtype):
    scene = _scene(num_nodes, dtype)
    mask = jnp.asarray(np.arange(scene.x.shape[0]) % 7 != 3)
    one = all_to_all(scene.x, scene.surface, radius=RADIUS, mask=mask)
    dense = jax.jit(sharded(all_to_all, mesh))(scene.x, scene.surface, radius=RADIUS, mask=mask)
    for field, value in zip(one._fields, one, strict=True):
        np.testing.assert_array_equal(getattr(dense, field), value, err_msg=field)
    binned = sharded(bucket_sort, mesh)(scene.x, scene.surface, radius=RADIUS, mask=mask)
    assert_same_contact(binned, one, RADIUS)
    if scene.x.shape[0] % DEVICES == 0:
        assert dense.gap.sharding.spec == P("slaves")
        assert binned.gap.sharding.spec == P("slaves")


@pytest.mark.parametrize("num_nodes", [1_100])  # padded rows; the even split is above
def test_sharded_crossing_equals_one_device(mesh, num_nodes):
    scene = _scene(num_nodes)
    one = swept(scene.x_prev, scene.x, scene.surface)
    assert int(one.crossed.sum()) > 0
    dense = jax.jit(sharded(swept, mesh))(scene.x_prev, scene.x, scene.surface)
    for field, value in zip(one._fields, one, strict=True):
        np.testing.assert_array_equal(getattr(dense, field), value, err_msg=field)
    binned = sharded(bucket_swept, mesh)(scene.x_prev, scene.x, scene.surface)
    assert_same_crossing(binned, one)


def test_sharded_bucket_sort_with_cells_on_the_rough_die(mesh):
    scene = rough_die_scene(4_000, 400)
    assert scene.surface.segments.shape[0] > CELLS_ABOVE  # the measured sizes bin in cells
    binned = sharded(bucket_sort, mesh)(scene.x, scene.surface, radius=scene.radius)
    assert_same_contact(binned, all_to_all(scene.x, scene.surface, radius=scene.radius))


def test_sharded_bucket_detectors_under_jit_raise_naming_search(mesh):
    scene = _scene(1_000)
    with pytest.raises(ValueError, match=r"sharded\(bucket_sort\) .*Search"):
        jax.jit(sharded(bucket_sort, mesh))(scene.x, scene.surface, radius=RADIUS)
    with pytest.raises(ValueError, match=r"sharded\(bucket_swept\) .*Search"):
        jax.jit(sharded(bucket_swept, mesh))(scene.x_prev, scene.x, scene.surface)


def test_overflow_on_one_device_is_overflow_of_the_whole(mesh):
    # Sizes measured for the quarter of the rows clear of the tool keep one
    # block; with them on every device (a detector of the bucket sort's form
    # at fixed sizes), the device holding the cut overflows, and the result
    # says so.
    scene = _scene(1_100)
    per_device = -(-scene.x.shape[0] // DEVICES)
    clear = measure(scene.x[:per_device], scene.surface, radius=RADIUS)
    assert clear.block_capacity == 1

    def starved(x, surface, *, radius, mask):
        return driver.sized_jit(CLOSEST, (x,), surface, radius, mask, sizes=clear)

    radius = jnp.asarray(RADIUS, scene.x.dtype)
    result = jax.jit(sharded(starved, mesh))(scene.x, scene.surface, radius=radius)
    assert bool(result.overflow)


@pytest.mark.x64
def test_tool_force_is_a_collective_sum_equal_to_one_device(mesh):
    scene = _scene(1_100, jnp.float64)
    # The contact test's mask and shapes: its sharded program, which CI's persistent
    # compilation cache loads instead of compiling it again.
    mask = jnp.asarray(np.arange(scene.x.shape[0]) % 7 != 3)
    one = penalty_total(
        all_to_all(scene.x, scene.surface, radius=RADIUS, mask=mask), scene.surface, 1e3
    )[1]

    # Explicitly: inside shard_map, the reaction is a psum over the devices.
    def local(x, surface):
        contact = all_to_all(x, surface, radius=RADIUS)
        return penalty_total(contact, surface, 1e3, axis_name="slaves")

    explicit = jax.jit(
        jax.shard_map(
            local, mesh=mesh, in_specs=(P("slaves"), P()), out_specs=(P("slaves"), P()),
            check_vma=False,
        )
    )  # fmt: skip
    # (shard_map itself needs rows divisible by the device count; sharded pads.)
    rows = scene.x.shape[0] // DEVICES * DEVICES
    x = jax.device_put(scene.x[:rows], NamedSharding(mesh, P("slaves")))
    part = penalty_total(
        all_to_all(scene.x[:rows], scene.surface, radius=RADIUS), scene.surface, 1e3
    )[1]
    np.testing.assert_allclose(explicit(x, scene.surface)[1], part, rtol=FLOAT64_RTOL)

    # Implicitly: jit over a sharded result; XLA's partitioner adds the all-reduce.
    contact = jax.jit(sharded(all_to_all, mesh))(scene.x, scene.surface, radius=RADIUS, mask=mask)
    total = jax.jit(lambda c: penalty_total(c, scene.surface, 1e3)[1])(contact)
    np.testing.assert_allclose(total, one, rtol=FLOAT64_RTOL)


@pytest.mark.x64
def test_gradients_through_the_sharded_detector_equal_one_device(mesh):
    scene = _scene(1_100, jnp.float64)

    def energy(x, detect):
        contact = detect(x, scene.surface, radius=RADIUS)
        return jnp.sum(jnp.where(contact.active, contact.gap**2, 0))

    one = jax.grad(functools.partial(energy, detect=all_to_all))(scene.x)
    split = jax.jit(jax.grad(functools.partial(energy, detect=sharded(all_to_all, mesh))))(scene.x)
    assert float(jnp.abs(one).sum()) > 0
    np.testing.assert_allclose(split, one, rtol=FLOAT64_RTOL, atol=FLOAT64_EXACT_ATOL)


@pytest.mark.parametrize("num_rows", [0, 3])
def test_fewer_rows_than_devices(mesh, num_rows):
    scene = _scene(1_000)
    x = scene.x[:num_rows].at[:, 1].set(4.95) if num_rows else scene.x[:0]
    one = all_to_all(x, scene.surface, radius=RADIUS)
    got = jax.jit(sharded(all_to_all, mesh))(x, scene.surface, radius=RADIUS)
    assert got.gap.shape == (num_rows,)
    for field, value in zip(one._fields, one, strict=True):
        np.testing.assert_array_equal(getattr(got, field), value, err_msg=field)


def test_penalty_takes_a_result_split_over_the_mesh(mesh):
    scene = _scene(1_100, jnp.float32)
    contact = jax.jit(sharded(all_to_all, mesh))(scene.x, scene.surface, radius=RADIUS)
    got = penalty(contact, scene.surface, 1e3)
    want = penalty(all_to_all(scene.x, scene.surface, radius=RADIUS), scene.surface, 1e3)
    assert bool(jnp.any(want.on_slaves != 0))
    np.testing.assert_array_equal(got.on_master, want.on_master)
    np.testing.assert_array_equal(got.on_slaves, want.on_slaves)
