"""Slaves split over devices: arrays sharded with ``jax.sharding``, passed
straight to every detector and to ``Search``, and the user's own ``jax.shard_map``
around a detector (the route that splits the search itself).

Run on 4 CPU devices by ``tests/test_shard.py``. Each case shards the slaves
(and the surface) one way, on explicit or auto mesh axes, calls half of the
detectors plainly or under one ``jax.jit``, and compares each result with the
single-device one: integer and bool fields exactly, floats to rounding.
Compiling for 4 devices costs about a second a program on 2 cores, so the
cases cover each setting once or twice rather than all their products.
"""

from __future__ import annotations

import contextlib
import inspect
import re
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.sharding import AxisType, NamedSharding
from jax.sharding import PartitionSpec as P

from jaxcontact import (
    Contact,
    Pairs,
    Search,
    Surface,
    all_to_all,
    bucket_sort,
    bucket_swept,
    swept,
)
from jaxcontact._pipeline import driver
from jaxcontact._query.closest import CLOSEST
from jaxcontact.forces import Forces, penalty
from tests.support.helpers import local_atol

RADIUS = 0.25
SKIN = 0.1


def _scene(num_slaves: int, dtype):
    """Slaves around an octagon (8 nodes, 8 segments, one masked); paths
    that cross it. Counts divisible by 4 on the master, so it can be split."""
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    nodes = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    segments = np.stack([np.arange(8), (np.arange(8) + 1) % 8], axis=1).astype(np.int32)
    segment_mask = np.arange(8) != 5
    rng = np.random.default_rng(num_slaves)
    theta = rng.uniform(0, 2 * np.pi, num_slaves)
    r = rng.uniform(0.7, 1.2, num_slaves)
    r_prev = np.where(np.arange(num_slaves) % 2 == 0, 2 - r, r + 0.05)
    ring = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    x, x_prev = r[:, None] * ring, r_prev[:, None] * ring
    mask = np.arange(num_slaves) != 3
    surface = Surface(nodes.astype(dtype), segments, segment_mask)
    return x_prev.astype(dtype), x.astype(dtype), surface, mask


class Case(NamedTuple):
    dtype: type
    num_slaves: int
    axis_type: AxisType
    mesh_shape: dict  # axis name -> size
    rows: P  # the slaves' spec (x, x_prev; the mask takes its first entry)
    master: P | None  # the spec of the surface's nodes, segments and mask; None: replicated
    jit: bool
    groups: tuple[str, ...]  # which detectors run: DENSE_AND_BINNED or BUCKET_AND_SKIN
    set_mesh: bool = False


# Each group of detectors runs in one case, and the two cases differ in every
# setting (dtype, N divisible by 4 or not, explicit or auto axes, rows or
# columns split, a split master or not, plain or jit), rather than in all
# combinations: each case compiles its own programs on 4 devices (10-20 s
# on 2 cores).
EXPLICIT, AUTO = AxisType.Explicit, AxisType.Auto
LINE, SQUARE = {"d": 4}, {"a": 2, "b": 2}
DENSE_AND_BINNED = ("all_to_all", "swept", "Search binned")
BUCKET_AND_SKIN = ("bucket_sort", "bucket_swept", "Search with a skin")
CASES = {
    "explicit-f32-12-rows-jit-set_mesh": Case(
        np.float32, 12, EXPLICIT, LINE, P("d"), None, True, DENSE_AND_BINNED, set_mesh=True
    ),
    "auto-f64-13-columns-master-plain": Case(
        np.float64, 13, AUTO, SQUARE, P(None, "a"), P(("a", "b")), False, BUCKET_AND_SKIN
    ),
}  # fmt: skip


def _mesh(case: Case):
    names = tuple(case.mesh_shape)
    return jax.make_mesh(
        tuple(case.mesh_shape.values()), names, axis_types=(case.axis_type,) * len(names)
    )


def _put(mesh, value, spec: P):
    return jax.device_put(jnp.asarray(value), NamedSharding(mesh, spec))


def _rebuilt_mask(mask):
    """Row 5 masked when the search with a skin is allocated: real at its first
    step, so that step finds the candidates again inside the jitted search."""
    return mask & (jnp.arange(mask.shape[0]) != 5)


def _detect(groups, x_prev, x, surface, mask, *, jit: bool) -> dict:
    """The detectors of ``groups`` on the same inputs: a dict of results."""
    binned = Search(radius=RADIUS, method="binned")
    skin = Search(radius=RADIUS, skin=SKIN, method="unbinned")
    # Host: sizes measured from the data.
    found, states = {}, {}
    if "bucket_sort" in groups:
        found["bucket_sort"] = bucket_sort(x, surface, radius=RADIUS, mask=mask)
        found["bucket_swept"] = bucket_swept(x_prev, x, surface, mask=mask)
        compact = bucket_sort(x, surface, radius=RADIUS, mask=mask, compact=True)
        found["bucket_sort compact"] = compact
    if "Search binned" in groups:
        states["binned"] = binned.allocate(x, surface, x_prev=x_prev, mask=mask)
    if "Search with a skin" in groups:
        states["skin"] = skin.allocate(x, surface, mask=_rebuilt_mask(mask))

    def traced(x_prev, x, surface, mask, states):
        out = {}
        if "all_to_all" in groups:
            out["all_to_all"] = all_to_all(x, surface, radius=RADIUS, mask=mask)
            out["swept"] = swept(x_prev, x, surface, mask=mask)
            out["gradient"] = jax.grad(_energy)(x, surface, mask)
        if "binned" in states:
            state = states["binned"]
            out["binned closest"], _ = binned.closest(state, x, surface, mask=mask)
            out["binned swept"], _ = binned.swept(state, x_prev, x, surface, mask=mask)
        if "skin" in states:
            state = states["skin"]
            out["skin closest, found again"], state = skin.closest(state, x, surface, mask=mask)
            out["skin closest, reused"], state = skin.closest(state, x, surface, mask=mask)
            out["rebuilds"] = state.rebuilds
            started = skin.init(x, surface, sizes=state.sizes, mask=mask)
            out["skin closest after init"], _ = skin.closest(started, x, surface, mask=mask)
        return out

    found |= (jax.jit(traced) if jit else traced)(x_prev, x, surface, mask, states)
    if "rebuilds" in found:
        assert int(found.pop("rebuilds")) == 1
    return found


def _energy(x, surface, mask):
    contact = all_to_all(x, surface, radius=RADIUS, mask=mask)
    return jnp.sum(jnp.where(contact.active, contact.gap**2, 0))


def _assert_same(name, got, want):
    assert type(got) is type(want), name
    for field, value in zip(want._fields, want, strict=True):
        actual, expected = np.asarray(getattr(got, field)), np.asarray(value)
        assert actual.dtype == expected.dtype, (name, field)
        if expected.dtype.kind == "f":
            atol = local_atol(expected.dtype, scale=4.0)
            np.testing.assert_allclose(actual, expected, rtol=0, atol=atol, err_msg=(name, field))
        else:
            np.testing.assert_array_equal(actual, expected, err_msg=f"{name}: {field}")


_ONE_DEVICE = {}


def _one_device(dtype, num_slaves: int):
    """The single-device results: ``all_to_all`` and ``swept`` (which the bucket
    detectors and ``Search`` equal without overflow), computed once."""
    key = (np.dtype(dtype), num_slaves)
    if key not in _ONE_DEVICE:
        x_prev, x, surface, mask = _scene(num_slaves, dtype)
        contact = all_to_all(x, surface, radius=RADIUS, mask=mask)
        crossing = swept(x_prev, x, surface, mask=mask)
        assert int(contact.active.sum()) > 0 and int(crossing.crossed.sum()) > 0
        _ONE_DEVICE[key] = contact, crossing, jax.grad(_energy)(x, surface, mask)
    return _ONE_DEVICE[key]


@pytest.mark.parametrize("case", CASES.values(), ids=CASES.keys())
def test_sharded_arrays_give_the_single_device_answer(case: Case):
    mesh = _mesh(case)
    x_prev, x, surface, mask = _scene(case.num_slaves, case.dtype)
    contact, crossing, gradient = _one_device(case.dtype, case.num_slaves)
    with jax.set_mesh(mesh) if case.set_mesh else contextlib.nullcontext():
        x_prev, x = _put(mesh, x_prev, case.rows), _put(mesh, x, case.rows)
        mask = _put(mesh, mask, P(case.rows[0]))
        if case.master is not None:
            surface = jax.tree.map(lambda leaf: _put(mesh, leaf, P(case.master[0])), surface)
        found = _detect(case.groups, x_prev, x, surface, mask, jit=case.jit)
    if "gradient" in found:
        atol = local_atol(case.dtype, scale=4.0)
        np.testing.assert_allclose(found.pop("gradient"), gradient, rtol=0, atol=atol)
    entries = found.pop("bucket_sort compact", None)
    if entries is not None:  # a ContactList: its K entries come back replicated
        assert not bool(entries.overflow)
        _assert_same("bucket_sort compact", entries.to_contact(case.num_slaves), contact)
        if case.axis_type is EXPLICIT:
            whole = NamedSharding(mesh, P())
            for value in entries:
                assert value.sharding.is_equivalent_to(whole, value.ndim), value.sharding
    assert not any(bool(result.overflow) for result in found.values())
    for name, result in found.items():
        _assert_same(name, result, crossing if "swept" in name else contact)
    if case.axis_type is AUTO:
        return  # the compiler places the results
    rows = NamedSharding(mesh, P(case.rows[0]))
    for name, result in found.items():
        for field in result._fields:
            value = getattr(result, field)
            want = NamedSharding(mesh, P()) if value.ndim == 0 else rows
            assert value.sharding.is_equivalent_to(want, value.ndim), (name, field, value.sharding)


@pytest.mark.parametrize("axis_type", [EXPLICIT, AUTO], ids=["explicit", "auto"])
def test_a_batch_split_over_its_scenes(axis_type):
    # Four scenes (the slaves turned about the octagon), split one per device.
    mesh = jax.make_mesh((4,), ("d",), axis_types=(axis_type,))
    _, x, surface, mask = _scene(12, np.float32)
    turns = [np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]) for a in range(4)]
    xs = np.stack([x @ turn.astype(np.float32) for turn in turns])
    want = jax.vmap(lambda x: all_to_all(x, surface, radius=RADIUS, mask=mask))(xs)
    split = _put(mesh, xs, P("d"))
    search = Search(radius=RADIUS)
    state = search.allocate(split, surface, mask=mask)
    if axis_type is EXPLICIT:
        # vmap maps no axis split over explicit mesh axes beside the
        # (replicated) state: the batch is gathered for the step.
        split = jax.reshard(split, NamedSharding(mesh, P()))
    step = jax.jit(jax.vmap(lambda state, x: search.closest(state, x, surface, mask=mask)))
    got, _ = step(state, split)
    _assert_same("vmapped closest", got, want)


def _printed(jaxpr) -> str:
    # Some JAX versions print the address of a closed-over function.
    return re.sub(r"0x[0-9a-f]+", "0x", str(jaxpr))


def test_inputs_not_split_over_explicit_axes_trace_to_the_same_program():
    # One device, replicated on explicit axes, split on auto axes: the
    # programs gather nothing, so they are what they were without it.
    _, x, surface, _ = _scene(12, np.float32)
    radius = jnp.asarray(RADIUS, np.float32)
    unwrapped = jax.jit(inspect.unwrap(driver.exhaustive), static_argnums=0)
    for name, x_in in {
        "one device": x,
        "explicit, replicated": _put(jax.make_mesh((4,), ("d",)), x, P()),
        "auto, split": _put(jax.make_mesh((4,), ("d",), axis_types=(AUTO,)), x, P("d")),
    }.items():
        got = jax.make_jaxpr(driver.exhaustive, static_argnums=0)(
            CLOSEST, (x_in,), surface, radius, None
        )
        want = jax.make_jaxpr(unwrapped, static_argnums=0)(CLOSEST, (x_in,), surface, radius, None)
        assert _printed(got) == _printed(want), name
    split = _put(jax.make_mesh((4,), ("d",)), x, P("d"))
    got = jax.make_jaxpr(driver.exhaustive, static_argnums=0)(
        CLOSEST, (split,), surface, radius, None
    )
    assert "reshard" in str(got)


# -- jax.shard_map: each device searches its own rows ------------------------------

DEVICES = 4
# The slaves' fields split as their rows, the bool[] overflow one per program.
SPLIT = Contact(*[P("slaves")] * len(Contact._fields))._replace(overflow=P())


def _shard_map(function, in_specs, out_specs):
    """``function`` mapped over the 4 devices' slaves, as docs/guides/devices.md does,
    its arguments first placed as ``in_specs`` says.

    check_vma=False: the detectors' conds return constants where they skip
    work, which shard_map's check of varying axes refuses. The placement:
    shard_map on explicit axes refuses an input whose sharding differs from
    its spec (JAX 0.10), and a ``jax.reshard`` inside the program places a
    host array and a traced one alike."""
    mesh = _slaves_mesh()
    mapped = jax.shard_map(
        function, mesh=mesh, in_specs=in_specs, out_specs=out_specs, check_vma=False
    )

    def placed(*args):
        def put(spec, arg):
            return jax.tree.map(lambda value: jax.reshard(value, NamedSharding(mesh, spec)), arg)

        return mapped(*map(put, in_specs, args))

    return jax.jit(placed)


def _slaves_mesh():
    """The 4 devices on one explicit axis, "slaves" (jax.make_mesh's default)."""
    return jax.make_mesh((DEVICES,), ("slaves",))


def _scene_with_own_nodes():
    """The octagon scene (12 slaves, 3 a device), slaves 0, 5 and 10 (on three
    devices) placed on octagon nodes 0, 2 and 6 with the pair rule saying so,
    and a radius per slave."""
    _, x, surface, mask = _scene(12, np.float64)
    x, node = np.array(x), np.full(12, -1, np.int32)
    node[[0, 5, 10]] = [0, 2, 6]
    x[[0, 5, 10]] = np.asarray(surface.nodes)[[0, 2, 6]]
    radius = RADIUS * (1 + np.arange(12) % 3) / 2  # 0.125, 0.25, 0.375
    return x, surface, mask, node, radius


@pytest.mark.x64
def test_shard_map_over_a_detector_with_a_split_pair_rule_equals_one_device():
    """The documented route: the slaves, their mask, the pair rule's per-slave
    array and radius split over the devices, the master replicated, and the
    master's reaction a psum (``penalty(..., axis_name=)``)."""
    x, surface, mask, node, radius = _scene_with_own_nodes()

    def on_device(x, mask, node, radius, surface):
        contact = all_to_all(x, surface, radius=radius, mask=mask, pairs=Pairs(node))
        return contact, penalty(contact, surface, 1e3, axis_name="slaves")

    rows = P("slaves")
    mapped = _shard_map(on_device, (rows, rows, rows, rows, P()), (SPLIT, Forces(rows, P())))
    contact, forces = mapped(x, mask, node, radius, surface)
    want = all_to_all(x, surface, radius=radius, mask=mask, pairs=Pairs(node))
    _assert_same("shard_map all_to_all", contact, want)
    want_forces = penalty(want, surface, 1e3)
    atol = local_atol(np.float64, scale=1e3)
    np.testing.assert_allclose(forces.on_slaves, want_forces.on_slaves, rtol=0, atol=atol)
    np.testing.assert_allclose(forces.on_master, want_forces.on_master, rtol=0, atol=atol)
    # What the check can tell: the rule and the radii change the answer on
    # each device, and the reaction comes from more than one device's rows.
    plain = all_to_all(x, surface, radius=RADIUS, mask=mask)
    own = np.array([0, 5, 10])
    # Each own-node slave lies on its node: at gap 0 without the rule, and
    # nothing else of the octagon within its radius with it.
    assert (np.asarray(plain.gap)[own] == 0).all() and np.asarray(plain.found)[own].all()
    assert not np.asarray(want.found)[own].any()
    assert (np.asarray(plain.found) != np.asarray(want.found)).any()
    active = np.asarray(want.active).reshape(DEVICES, -1).any(axis=1)
    assert active.sum() >= 2 and float(np.abs(want_forces.on_master).sum()) > 0


@pytest.mark.x64
def test_gradients_through_shard_map_equal_one_device():
    # The energy of the split contacts, a psum of each device's part; its
    # gradient by the slaves (split) and by the master's nodes (replicated).
    x, surface, mask, node, radius = _scene_with_own_nodes()

    def energy(contact):
        return jnp.sum(jnp.where(contact.active, contact.gap**2, 0))

    def on_device(x, nodes, mask, node, radius):
        rule = Pairs(node)
        contact = all_to_all(x, surface._replace(nodes=nodes), radius=radius, mask=mask, pairs=rule)
        return jax.lax.psum(energy(contact), "slaves")

    rows = P("slaves")
    mapped = _shard_map(on_device, (rows, P(), rows, rows, rows), P())
    # The gradient's program is placed on the mesh: its context, as for any
    # jit over explicit mesh axes.
    with jax.set_mesh(_slaves_mesh()):
        got = jax.jit(jax.grad(mapped, argnums=(0, 1)))(x, surface.nodes, mask, node, radius)

    def one_device(x, nodes):
        surface_at = surface._replace(nodes=nodes)
        return energy(all_to_all(x, surface_at, radius=radius, mask=mask, pairs=Pairs(node)))

    want = jax.grad(one_device, argnums=(0, 1))(x, surface.nodes)
    for g, w in zip(got, want, strict=True):
        assert float(jnp.abs(w).sum()) > 0
        np.testing.assert_allclose(g, w, rtol=0, atol=local_atol(np.float64, scale=4.0))
