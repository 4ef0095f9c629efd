"""Batches of scenes: every detector under vmap, one Search allocation for the batch."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.extend.core import Jaxpr

from jaxcontact import (
    Search,
    Surface,
    all_to_all,
    swept,
)
from jaxcontact._pipeline.sizes import measure
from jaxcontact.scenes import cutting_scene, rough_die_scene
from tests.support.helpers import FLOAT, assert_same_contact, assert_same_crossing, penalty_total
from tests.support.tolerances import FLOAT64_BATCHED_RTOL, FLOAT64_RTOL

# The tool in, half in and clear of the workpiece: very different needs.
TIPS = (12.0, 18.0, 20.5)
RADIUS = 0.1


def _batch(dtype=jnp.float32):
    scenes = [cutting_scene(900, tip, x_tip_prev=tip + 0.3, dtype=dtype) for tip in TIPS]
    x = jnp.stack([s.x for s in scenes])
    x_prev = jnp.stack([s.x_prev for s in scenes])
    surface = Surface(
        jnp.stack([s.surface.nodes for s in scenes]),
        jnp.stack([s.surface.segments for s in scenes]),
    )
    # Each scene masks out a different block of rows.
    mask = np.ones(x.shape[:2], bool)
    for i in range(len(scenes)):
        mask[i, 100 * i : 100 * i + 50] = False
    return scenes, x_prev, x, surface, jnp.asarray(mask)


def _row(tree, i):
    return jax.tree.map(lambda v: v if v.ndim == 0 else v[i], tree)


@pytest.mark.parametrize("method", ["unbinned", "binned"])
def test_one_allocation_for_a_batch_of_contacts_equals_a_loop(method):
    scenes, _, x, surface, mask = _batch()
    search = Search(radius=RADIUS, method=method)
    state = search.allocate(x, surface, mask=mask)
    cells = method == "binned"
    assert state.sizes["closest"].use_cells == cells
    assert state.overflow.shape == state.rebuilds.shape == (len(scenes),)
    # The batch's sizes are at least as large as any scene's own.
    for i, scene in enumerate(scenes):
        own = measure(scene.x, scene.surface, radius=RADIUS, mask=mask[i], use_cells=cells)
        assert state.sizes["closest"].block_capacity >= own.block_capacity
    detect = jax.jit(jax.vmap(lambda st, x, s, m: search.closest(st, x, s, mask=m)))
    batched, state = detect(state, x, surface, mask)
    assert not bool(jnp.any(batched.overflow)) and not bool(jnp.any(state.overflow))
    for i, scene in enumerate(scenes):
        dense = all_to_all(scene.x, scene.surface, radius=RADIUS, mask=mask[i])
        assert_same_contact(_row(batched, i), dense, RADIUS)


def test_one_allocation_for_a_batch_of_paths_equals_a_loop():
    scenes, x_prev, x, surface, mask = _batch()
    search = Search()  # paths only
    state = search.allocate(x, surface, x_prev=x_prev, mask=mask)
    assert list(state.sizes) == ["swept"] and state.sizes["swept"].for_paths
    detect = jax.jit(jax.vmap(lambda st, p, x, s, m: search.swept(st, p, x, s, mask=m)))
    batched, state = detect(state, x_prev, x, surface, mask)
    assert not bool(jnp.any(state.overflow))
    for i, scene in enumerate(scenes):
        dense = swept(scene.x_prev, scene.x, scene.surface, mask=mask[i])
        assert int(dense.crossed.sum()) > 0 or TIPS[i] > 20
        assert_same_crossing(_row(batched, i), dense)


def test_a_shared_surface_is_allocated_for_every_scene():
    scenes, _, x, _, _ = _batch()
    shared = scenes[1].surface
    search = Search(radius=RADIUS, method="unbinned")
    state = search.allocate(x, shared)
    batched, _ = jax.vmap(search.closest, in_axes=(0, 0, None))(state, x, shared)
    for i in range(len(scenes)):
        assert_same_contact(_row(batched, i), all_to_all(x[i], shared, radius=RADIUS), RADIUS)


def test_a_batch_allocation_grows_sizes_that_another_scene_outgrows():
    # Measured on the clear scene alone the sizes keep one block; the batch's
    # must hold the deep cut as well, and say so by not overflowing.
    scenes, _, x, surface, _ = _batch()
    search = Search(radius=RADIUS, method="unbinned")
    lone = measure(scenes[2].x, scenes[2].surface, radius=RADIUS, use_cells=False)
    assert lone.block_capacity == 1
    detect = jax.jit(jax.vmap(search.closest))
    starved = jax.vmap(lambda x, s: search.init(x, s, sizes={"closest": lone}))(x, surface)
    too_small, starved = detect(starved, x, surface)
    assert bool(too_small.overflow[0]) and bool(starved.overflow[0])
    state = search.allocate(x, surface)
    assert state.sizes["closest"].block_capacity > lone.block_capacity
    contact, state = detect(state, x, surface)
    assert not bool(jnp.any(contact.overflow)) and not bool(jnp.any(state.overflow))


def test_allocate_checks_the_batch_shape():
    scene = cutting_scene(100, 18.0)
    search = Search(radius=RADIUS)
    with pytest.raises(ValueError, match=r"x must have shape \(N, 2\) or \(B, N, 2\)"):
        search.allocate(jnp.zeros((2,) + scene.x.shape[:1] + (3,)), scene.surface)
    with pytest.raises(ValueError, match=r"x must have shape \(N, 2\)"):
        search.allocate(scene.x[None, None], scene.surface)


def test_dense_detectors_and_forces_map_over_a_batch():
    scenes, x_prev, x, surface, mask = _batch(FLOAT)
    contact = jax.vmap(lambda x, s, m: all_to_all(x, s, radius=RADIUS, mask=m))(x, surface, mask)
    crossing = jax.vmap(lambda p, x, s, m: swept(p, x, s, mask=m))(x_prev, x, surface, mask)
    forces, on_tool = jax.vmap(lambda c, s: penalty_total(c, s, 1e3))(contact, surface)
    for i, scene in enumerate(scenes):
        one = all_to_all(scene.x, scene.surface, radius=RADIUS, mask=mask[i])
        for field in ("gap", "segment", "found", "active"):
            np.testing.assert_array_equal(getattr(contact, field)[i], getattr(one, field))
        path = swept(scene.x_prev, scene.x, scene.surface, mask=mask[i])
        np.testing.assert_array_equal(crossing.t[i], path.t)
        single, total = penalty_total(one, scene.surface, 1e3)
        np.testing.assert_allclose(forces[i], single)
        np.testing.assert_allclose(on_tool[i], total)


def test_penalty_pushes_active_slaves_out_and_balances_on_the_master():
    scene = cutting_scene(2_000, 18.0, dtype=FLOAT)
    contact = all_to_all(scene.x, scene.surface, radius=RADIUS)
    assert int(contact.active.sum()) > 0
    on_slaves, on_master = penalty_total(contact, scene.surface, 2.0)
    active = np.asarray(contact.active)
    # Along the outward normal, of size stiffness * depth; zero elsewhere.
    np.testing.assert_allclose(
        np.asarray(on_slaves)[active],
        (2.0 * -np.asarray(contact.gap)[active])[:, None] * np.asarray(contact.normal)[active],
    )
    assert not np.asarray(on_slaves)[~active].any()
    np.testing.assert_allclose(on_master, -np.asarray(on_slaves).sum(axis=0))
    # The tool, moving in -x into the workpiece, is pushed back (+x).
    assert float(on_master[0]) > 0


def test_a_batch_with_nothing_near_in_one_scene_still_bins_many_segments_in_cells():
    # The batch's sizes are the largest of each scene's (``_sizes.largest``),
    # which keeps the choice of narrow phase: a first scene with nothing near
    # a 400-segment die must not switch cells off for the whole batch.
    scene = rough_die_scene(2_000, 400)
    far = scene.x.at[:, 1].add(100.0)
    assert measure(far, scene.surface, radius=scene.radius).use_cells
    state = Search(radius=scene.radius).allocate(jnp.stack([far, scene.x]), scene.surface)
    assert state.sizes["closest"].use_cells


@pytest.mark.x64  # equal to 1e-10: float64
@pytest.mark.parametrize("detector", ["all_to_all", "search"])
def test_gradients_through_a_vmapped_detector_equal_a_loop(detector):
    # The searches run through custom_vmap (scene by scene) on stop_gradient
    # inputs; the gradients must still reach x and the master nodes.
    base = rough_die_scene(1_500, 120, dtype=jnp.float64)
    scenes = [base, base._replace(x=base.x.at[:, 1].add(0.01))]
    radius = scenes[0].radius
    x = jnp.stack([s.x for s in scenes])
    surface = Surface(
        jnp.stack([s.surface.nodes for s in scenes]),
        jnp.stack([s.surface.segments for s in scenes]),
    )
    if detector == "search":
        search = Search(radius=radius)
        state = search.allocate(x, surface)
        assert state.sizes["closest"].use_cells

        def detect(state, x, s):
            return search.closest(state, x, s)[0]
    else:
        state = None

        def detect(state, x, s):
            return all_to_all(x, s, radius=radius)

    def energy(state, x, nodes, segments):
        contact = detect(state, x, Surface(nodes, segments))
        return jnp.sum(jnp.where(contact.found, contact.gap**2, 0))

    gradient = jax.grad(energy, argnums=(1, 2))
    batched = jax.jit(jax.vmap(gradient))(state, x, surface.nodes, surface.segments)
    for i in range(len(scenes)):
        one = jax.tree.map(lambda v, i=i: v[i], state)
        single = gradient(one, x[i], surface.nodes[i], surface.segments[i])
        assert float(jnp.abs(single[0]).sum()) > 0 and float(jnp.abs(single[1]).sum()) > 0
        for got, want in zip(batched, single, strict=True):
            np.testing.assert_allclose(got[i], want, rtol=FLOAT64_BATCHED_RTOL, atol=FLOAT64_RTOL)


def test_nested_vmap_equals_a_double_loop():
    scenes, _, x, surface, _ = _batch()
    grid = jnp.stack([x, x[:, ::-1]])  # (2, B, N, 2): the same scenes, rows reversed
    inner = jax.vmap(lambda x, s: all_to_all(x, s, radius=RADIUS), (0, 0))
    outer = jax.jit(jax.vmap(inner, (0, None)))(grid, surface)
    for j in range(2):
        for i, scene in enumerate(scenes):
            one = all_to_all(grid[j, i], scene.surface, radius=RADIUS)
            np.testing.assert_array_equal(outer.segment[j, i], one.segment)
            np.testing.assert_array_equal(outer.gap[j, i], one.gap)


def _scan_lengths(jaxpr) -> list[int]:
    """The length of every ``scan`` in ``jaxpr`` and the programs it calls."""
    lengths = []
    for eqn in jaxpr.eqns:
        if eqn.primitive.name == "scan":
            lengths.append(eqn.params["length"])
        for param in eqn.params.values():
            for sub in param if isinstance(param, (tuple, list)) else (param,):
                inner = getattr(sub, "jaxpr", sub)
                if isinstance(inner, Jaxpr):
                    lengths += _scan_lengths(inner)
    return lengths


def test_searches_batch_as_usual_off_the_cpu(monkeypatch):
    # On an accelerator the searches are vmapped like everything else (one
    # batched program); on the CPU they run scene by scene, a ``lax.map``:
    # a scan over the batch. The answers are the same, so the programs
    # themselves are compared. (The backend is faked: CI has only a CPU.)
    # JAX keeps a batched program per shape whatever the backend, so each
    # backend traces at a shape of its own that no other test batches.
    import jaxcontact._pipeline.lowest

    scenes, x_prev, x, surface, mask = _batch()
    batch = len(scenes)

    def contacts(x, s, m):
        return all_to_all(x, s, radius=RADIUS, mask=m)

    def paths(p, x, s):
        return swept(p, x, s)

    def programs(rows):
        x_, p_, m_ = x[:, :rows], x_prev[:, :rows], mask[:, :rows]
        return [
            jax.make_jaxpr(jax.vmap(contacts))(x_, surface, m_).jaxpr,
            jax.make_jaxpr(jax.vmap(paths))(p_, x_, surface).jaxpr,
        ]

    rows = x.shape[1] - 7
    for program in programs(rows - 1):
        assert batch in _scan_lengths(program)
    x_prev, x, mask = x_prev[:, :rows], x[:, :rows], mask[:, :rows]
    with monkeypatch.context() as patch:
        patch.setattr(jaxcontact._pipeline.lowest.jax, "default_backend", lambda: "gpu")
        for program in programs(rows):
            assert batch not in _scan_lengths(program)
        got = jax.vmap(contacts)(x, surface, mask)
        got_paths = jax.vmap(paths)(x_prev, x, surface)
    for i, scene in enumerate(scenes):
        one = contacts(x[i], scene.surface, mask[i])
        np.testing.assert_array_equal(got.segment[i], one.segment)
        np.testing.assert_array_equal(got.gap[i], one.gap)
        np.testing.assert_array_equal(got_paths.t[i], paths(x_prev[i], x[i], scene.surface).t)
