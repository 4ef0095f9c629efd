"""bucket_sort and bucket_swept: equal to the dense detectors whenever overflow is False."""

import dataclasses

import hypothesis.extra.numpy as hnp
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxcontact import (
    BucketPlan,
    Surface,
    _narrow,
    all_to_all,
    bucket_sort,
    bucket_swept,
    candidates_expired,
    find_candidates,
    plan_buckets,
    replan,
    swept,
)
from jaxcontact.scenes import cutting_scene, paper_scene, rough_die_scene
from tests.helpers import assert_same_contact, assert_same_crossing

jit_bucket_sort = jax.jit(bucket_sort, static_argnames="plan")
jit_bucket_swept = jax.jit(bucket_swept, static_argnames="plan")
jit_all_to_all = jax.jit(all_to_all)
jit_swept = jax.jit(swept)


SCENES = {
    "cutting_contact": lambda dtype: cutting_scene(3_000, 18.0, x_tip_prev=18.2, dtype=dtype),
    "cutting_deep": lambda dtype: cutting_scene(3_000, 12.0, x_tip_prev=12.4, dtype=dtype),
    "cutting_clear": lambda dtype: cutting_scene(3_000, 20.5, x_tip_prev=20.7, dtype=dtype),
    "paper": lambda dtype: paper_scene(40, dtype=dtype),
    "rough_die": lambda dtype: rough_die_scene(4_000, 400, dtype=dtype),
}
# Each scene in both dtypes with the plan's own choice of narrow phase, and the
# small-tool scenes once more with cells forced on.
CASES = [(name, dtype, None) for name in sorted(SCENES) for dtype in (jnp.float32, jnp.float64)]
CASES += [("cutting_contact", jnp.float32, True), ("paper", jnp.float64, True)]


@pytest.mark.parametrize("name, dtype, use_cells", CASES)
def test_bucket_sort_equals_all_to_all_on_reference_scenes(name, dtype, use_cells):
    scene = SCENES[name](dtype)
    plan = plan_buckets(scene.x, scene.surface, radius=scene.radius, use_cells=use_cells)
    binned = jit_bucket_sort(scene.x, scene.surface, radius=scene.radius, plan=plan)
    dense = all_to_all(scene.x, scene.surface, radius=scene.radius)
    assert binned.gap.dtype == dtype
    assert_same_contact(binned, dense, scene.radius)


@pytest.mark.parametrize("name, dtype, use_cells", CASES)
def test_bucket_swept_equals_swept_on_reference_scenes(name, dtype, use_cells):
    scene = SCENES[name](dtype)
    plan = plan_buckets(scene.x, scene.surface, x_prev=scene.x_prev, use_cells=use_cells)
    binned = jit_bucket_swept(scene.x_prev, scene.x, scene.surface, plan=plan)
    assert_same_crossing(binned, swept(scene.x_prev, scene.x, scene.surface))


def test_paper_scene_finds_contacts_and_crossings():
    scene = paper_scene(40, dtype=jnp.float64)
    contact = bucket_sort(scene.x, scene.surface, radius=scene.radius)
    crossing = bucket_swept(scene.x_prev, scene.x, scene.surface)
    assert int(contact.found.sum()) > 0
    assert int(crossing.crossed.sum()) > 0


def test_tool_clear_of_workpiece_reports_nothing_and_keeps_tiny_plan():
    scene = cutting_scene(3_000, 20.5)
    plan = plan_buckets(scene.x, scene.surface, radius=scene.radius)
    contact = jit_bucket_sort(scene.x, scene.surface, radius=scene.radius, plan=plan)
    assert plan.block_capacity == 1
    assert not bool(contact.found.any())
    assert not bool(contact.overflow)
    np.testing.assert_array_equal(contact.segment, -1)


def test_too_small_block_capacity_sets_overflow_and_replan_fixes_it():
    far = cutting_scene(3_000, 20.5)
    plan = plan_buckets(far.x, far.surface, radius=far.radius)
    near = cutting_scene(3_000, 15.0)
    contact = jit_bucket_sort(near.x, near.surface, radius=near.radius, plan=plan)
    assert bool(contact.overflow)
    bigger = replan(plan, near.x, near.surface, radius=near.radius)
    assert bigger.block_capacity > plan.block_capacity
    contact = jit_bucket_sort(near.x, near.surface, radius=near.radius, plan=bigger)
    assert_same_contact(contact, all_to_all(near.x, near.surface, radius=near.radius), near.radius)


def test_too_small_cell_capacity_sets_overflow():
    scene = rough_die_scene(4_000, 400)
    plan = plan_buckets(scene.x, scene.surface, radius=scene.radius)
    assert plan.use_cells
    starved = dataclasses.replace(plan, cell_capacity=1)
    contact = jit_bucket_sort(scene.x, scene.surface, radius=scene.radius, plan=starved)
    assert bool(contact.overflow)


def test_too_small_span_sets_overflow():
    scene = rough_die_scene(4_000, 400)
    plan = plan_buckets(scene.x, scene.surface, radius=scene.radius)
    narrow = dataclasses.replace(plan, span=(1, 1), cell_size=plan.cell_size / 8)
    contact = jit_bucket_sort(scene.x, scene.surface, radius=scene.radius, plan=narrow)
    assert bool(contact.overflow)


def test_plan_is_hashable_and_reused_without_retracing():
    scene = cutting_scene(1_000, 18.0)
    plan = plan_buckets(scene.x, scene.surface, radius=scene.radius)
    assert hash(plan) == hash(dataclasses.replace(plan))
    traces = []

    @jax.jit
    def detect(x, nodes):
        traces.append(1)
        return bucket_sort(x, Surface(nodes, scene.surface.segments), radius=0.1, plan=plan)

    detect(scene.x, scene.surface.nodes)
    detect(scene.x + 0.01, scene.surface.nodes - 0.5)
    assert len(traces) == 1


def test_under_jit_without_plan_raises():
    scene = cutting_scene(500, 18.0)
    with pytest.raises(ValueError, match="plan"):
        jax.jit(lambda x: bucket_sort(x, scene.surface, radius=0.1))(scene.x)


def test_wrong_plan_raises():
    scene = cutting_scene(500, 18.0)
    plan = plan_buckets(scene.x, scene.surface, radius=0.1)
    with pytest.raises(ValueError, match="plan was made for"):
        bucket_sort(scene.x[:400], scene.surface, radius=0.1, plan=plan)
    with pytest.raises(ValueError, match="other detector"):
        bucket_swept(scene.x_prev, scene.x, scene.surface, plan=plan)
    with pytest.raises(ValueError, match="radius"):
        plan_buckets(scene.x, scene.surface)


def test_vmap_over_scenes_equals_loop():
    scenes = [cutting_scene(800, tip) for tip in (15.0, 18.0, 20.5)]
    x = jnp.stack([s.x for s in scenes])
    nodes = jnp.stack([s.surface.nodes for s in scenes])
    segments = scenes[0].surface.segments
    plans = [plan_buckets(s.x, s.surface, radius=0.1) for s in scenes]
    plan = max(plans, key=lambda p: p.block_capacity)

    def detect(x, nodes):
        return bucket_sort(x, Surface(nodes, segments), radius=0.1, plan=plan)

    batched = jax.vmap(detect)(x, nodes)
    for i, scene in enumerate(scenes):
        row = jax.tree.map(lambda v, i=i: v[i], batched)
        assert_same_contact(row, all_to_all(scene.x, scene.surface, radius=0.1), 0.1)


def test_masks_nan_padding_and_empty_inputs():
    scene = cutting_scene(1_000, 18.0, dtype=jnp.float64)
    x = scene.x.at[::7].set(jnp.nan).at[3].set(jnp.inf)
    mask = jnp.arange(x.shape[0]) % 5 != 0
    seg_mask = jnp.arange(20) != 17
    surface = scene.surface._replace(mask=seg_mask)
    binned = bucket_sort(x, surface, radius=0.1, mask=mask)
    dense = all_to_all(x, surface, radius=0.1, mask=mask)
    assert_same_contact(binned, dense, 0.1)
    assert all(bool(jnp.all(jnp.isfinite(v))) for v in binned if v.dtype != bool)
    empty = bucket_sort(jnp.zeros((0, 2)), scene.surface, radius=0.1)
    assert empty.gap.shape == (0,)
    none = Surface(jnp.zeros((0, 2)), jnp.zeros((0, 2), jnp.int32))
    assert not bool(bucket_sort(scene.x, none, radius=0.1).found.any())


def test_gradients_through_bucket_sort_are_finite_and_match_dense():
    scene = cutting_scene(600, 18.0, dtype=jnp.float64)
    plan = plan_buckets(scene.x, scene.surface, radius=0.1)

    def total(detector, x, nodes, **kwargs):
        contact = detector(x, Surface(nodes, scene.surface.segments), radius=0.1, **kwargs)
        return jnp.sum(jnp.where(contact.found, contact.gap, 0)) + jnp.sum(contact.point)

    binned = jax.grad(lambda x, n: total(bucket_sort, x, n, plan=plan), argnums=(0, 1))
    dense = jax.grad(lambda x, n: total(all_to_all, x, n), argnums=(0, 1))
    got_both = binned(scene.x, scene.surface.nodes)
    for got, want in zip(got_both, dense(scene.x, scene.surface.nodes), strict=True):
        assert bool(jnp.all(jnp.isfinite(got)))
        np.testing.assert_allclose(got, want, atol=1e-12)


# Hypothesis scenes are padded to fixed shapes and use plans that differ only
# in the cell size, so each (dtype, cell size) compiles once.
MAX_NODES, MAX_SLAVES = 24, 256
CELL_SIZES = (0.05, 0.4, 3.0)


def fixed_plan(cell_size, for_paths):
    """Blocks of 8 with room for all; a 16 x 16 grid; spans and cells that cannot overflow."""
    return BucketPlan(
        num_slaves=MAX_SLAVES,
        block_size=8,
        block_capacity=MAX_SLAVES // 8,
        for_paths=for_paths,
        use_cells=True,
        grid_shape=(16, 16),
        cell_size=cell_size,
        span=(16, 16),
        cell_capacity=MAX_NODES,
    )


@st.composite
def polyline_scenes(draw, dtype):
    """Random slaves near a random polyline, padded to fixed shapes with masks."""
    num_nodes = draw(st.integers(2, MAX_NODES))
    coords = st.floats(-3, 3, allow_nan=False, width=32)
    nodes = draw(hnp.arrays(np.float64, (num_nodes, 2), elements=coords))
    slaves = draw(hnp.arrays(np.float64, (draw(st.integers(1, 200)), 2), elements=coords))
    # Some slaves exactly on nodes and on segment midpoints: the hard places.
    on_nodes = nodes[draw(st.lists(st.integers(0, num_nodes - 1), max_size=10))]
    slaves = np.concatenate([slaves, on_nodes, (nodes[:-1] + nodes[1:]) / 2])[:MAX_SLAVES]
    padded_nodes = np.zeros((MAX_NODES, 2))
    padded_nodes[:num_nodes] = nodes
    segments = np.stack([np.arange(MAX_NODES - 1), np.arange(1, MAX_NODES)], axis=-1)
    surface = Surface(
        jnp.asarray(padded_nodes, dtype),
        jnp.asarray(segments, jnp.int32),
        jnp.arange(MAX_NODES - 1) < num_nodes - 1,
    )
    padded_slaves = np.full((MAX_SLAVES, 2), np.nan)
    padded_slaves[: len(slaves)] = slaves
    mask = jnp.arange(MAX_SLAVES) < len(slaves)
    return jnp.asarray(padded_slaves, dtype), surface, mask


@given(
    st.sampled_from([jnp.float32, jnp.float64]).flatmap(polyline_scenes),
    st.sampled_from([0.0, 0.05, 0.3, 1.0]),
    st.sampled_from(CELL_SIZES),
)
def test_bucket_sort_equals_all_to_all_on_random_polylines(scene, radius, cell_size):
    x, surface, mask = scene
    plan = fixed_plan(cell_size, for_paths=False)
    binned = jit_bucket_sort(x, surface, radius=radius, mask=mask, plan=plan)
    assert_same_contact(
        binned, jit_all_to_all(x, surface, radius=radius, mask=mask), radius, degenerate=True
    )


@given(
    st.sampled_from([jnp.float32, jnp.float64]).flatmap(polyline_scenes),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
    st.sampled_from(CELL_SIZES),
)
def test_bucket_swept_equals_swept_on_random_polylines(scene, move, cell_size):
    x_prev, surface, mask = scene
    x = x_prev + jnp.asarray(move, x_prev.dtype)[None]
    plan = fixed_plan(cell_size, for_paths=True)
    binned = jit_bucket_swept(x_prev, x, surface, mask=mask, plan=plan)
    assert_same_crossing(binned, jit_swept(x_prev, x, surface, mask=mask), degenerate=True)


def test_plan_fields():
    scene = rough_die_scene(4_000, 400)
    plan = plan_buckets(scene.x, scene.surface, radius=scene.radius)
    assert isinstance(plan, BucketPlan)
    assert plan.slave_capacity == plan.block_capacity * plan.block_size
    assert plan.grid_shape[0] > 1 and plan.cell_capacity >= 1


@pytest.mark.parametrize("name", ["cutting", "rough_die"])
def test_candidates_reused_over_steps_equal_a_fresh_search_until_expired(name):
    """The tool advances step by step; candidates found once serve while within the skin."""
    radius, skin = (0.1, 0.05) if name == "cutting" else (0.02, 0.01)
    if name == "cutting":
        scene = cutting_scene(3_000, 18.0, dtype=jnp.float64)
    else:
        scene = rough_die_scene(4_000, 400, dtype=jnp.float64)
    plan = plan_buckets(scene.x, scene.surface, radius=radius + skin, slack=2.0)
    near = find_candidates(scene.x, scene.surface, radius=radius, skin=skin, plan=plan)
    step = jnp.asarray([-0.4 * skin, 0.0])
    for count in range(1, 4):
        surface = scene.surface._replace(nodes=scene.surface.nodes + count * step[None])
        expired = bool(candidates_expired(near, scene.x, surface))
        assert expired == (count * 0.4 * skin > skin)
        if expired:
            break
        reused = jit_bucket_sort(scene.x, surface, radius=radius, plan=plan, candidates=near)
        assert_same_contact(reused, all_to_all(scene.x, surface, radius=radius), radius)
    assert expired, "the test should have run the candidates out"


def test_expired_candidates_can_miss_contacts_which_is_why_the_check_exists():
    scene = cutting_scene(3_000, 20.3)
    plan = plan_buckets(scene.x, scene.surface, radius=0.15, slack=2.0)
    near = find_candidates(scene.x, scene.surface, radius=0.1, skin=0.05, plan=plan)
    moved = scene.surface._replace(nodes=scene.surface.nodes.at[:, 0].add(-1.5))
    assert bool(candidates_expired(near, scene.x, moved))
    stale = bucket_sort(scene.x, moved, radius=0.1, plan=plan, candidates=near)
    fresh = all_to_all(scene.x, moved, radius=0.1)
    assert int(fresh.found.sum()) > int(stale.found.sum())


# Regressions found in review.


def test_bucket_swept_ignores_a_nan_previous_position_like_swept():
    wall = Surface(jnp.asarray([[1.0, -1.0], [1.0, 1.0]]), jnp.asarray([[0, 1]], jnp.int32))
    x_prev = jnp.asarray([[jnp.nan, 0.0], [0.0, 0.5]])
    x = jnp.asarray([[4.0, 0.0], [4.0, 0.5]])
    binned = bucket_swept(x_prev, x, wall)
    np.testing.assert_array_equal(binned.crossed, [False, True])
    np.testing.assert_array_equal(binned.crossed, swept(x_prev, x, wall).crossed)


def test_reused_candidates_skip_a_segment_masked_since():
    scene = rough_die_scene(2_000, 100, dtype=jnp.float64)
    plan = plan_buckets(scene.x, scene.surface, radius=0.03, use_cells=True)
    near = find_candidates(scene.x, scene.surface, radius=0.02, skin=0.01, plan=plan)
    masked = scene.surface._replace(mask=jnp.arange(100) % 3 != 0)
    reused = bucket_sort(scene.x, masked, radius=0.02, plan=plan, candidates=near)
    assert_same_contact(reused, all_to_all(scene.x, masked, radius=0.02), 0.02)


def test_a_masked_padding_segment_does_not_change_a_vertex_tie():
    # A triangle, counter-clockwise; below-left of the corner (1, 0) a slave in
    # its blind spot. A masked padding segment [1, 1] listed first must not
    # change which face the slave gets.
    nodes = jnp.asarray([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    triangle = jnp.asarray([[0, 1], [1, 2], [2, 0]], jnp.int32)
    slave = jnp.asarray([[1.3, -0.1]])
    plain = all_to_all(slave, Surface(nodes, triangle), radius=1.0)
    padded = Surface(
        nodes,
        jnp.concatenate([jnp.asarray([[1, 1]], jnp.int32), triangle]),
        jnp.asarray([False, True, True, True]),
    )
    with_padding = all_to_all(slave, padded, radius=1.0)
    np.testing.assert_array_equal(with_padding.segment, plain.segment + 1)
    np.testing.assert_array_equal(with_padding.normal, plain.normal)
    assert float(plain.gap[0]) > 0


def test_plan_rejects_a_non_positive_cell_factor_and_replan_takes_keywords():
    scene = rough_die_scene(2_000, 100)
    with pytest.raises(ValueError, match="cell_factor"):
        plan_buckets(scene.x, scene.surface, radius=0.02, cell_factor=0.0)
    plan = plan_buckets(scene.x, scene.surface, radius=0.02)
    bigger = replan(plan, scene.x, scene.surface, radius=0.02, slack=3.0, use_cells=True)
    assert bigger.cell_capacity >= plan.cell_capacity


@pytest.mark.parametrize("detector", ["bucket_sort", "bucket_swept", "reused"])
def test_kept_slaves_searched_in_chunks_longest_lists_first_equal_dense(monkeypatch, detector):
    # Above _narrow._CHUNK kept slaves, the cell search sorts them by list
    # length and stops at the first chunk of empty lists. A chunk of 64 rows
    # puts the rough die's 2,496 kept slaves in 39 chunks: full, partly empty
    # and empty ones, with masked slaves and NaN rows among them.
    monkeypatch.setattr(_narrow, "_CHUNK", 64)
    jax.clear_caches()  # programs traced with the default chunk must not be reused
    try:
        scene = rough_die_scene(4_000, 400, dtype=jnp.float64)
        x = scene.x.at[7].set(jnp.nan)
        mask = jnp.asarray(np.arange(x.shape[0]) % 11 != 5)
        if detector == "bucket_swept":
            x_prev = x + jnp.asarray([[0.01, 0.03]])
            plan = plan_buckets(x, scene.surface, x_prev=x_prev, mask=mask)
            assert plan.use_cells and plan.slave_capacity > 64
            got = jit_bucket_swept(x_prev, x, scene.surface, mask=mask, plan=plan)
            assert int(got.crossed.sum()) > 0
            assert_same_crossing(got, swept(x_prev, x, scene.surface, mask=mask))
            return
        plan = plan_buckets(x, scene.surface, radius=scene.radius, mask=mask)
        assert plan.use_cells and plan.slave_capacity > 64
        near = None
        if detector == "reused":
            near = find_candidates(x, scene.surface, radius=scene.radius, skin=0.0, plan=plan)
        got = jit_bucket_sort(
            x, scene.surface, radius=scene.radius, mask=mask, plan=plan, candidates=near
        )
        want = all_to_all(x, scene.surface, radius=scene.radius, mask=mask)
        assert int(want.found.sum()) > 0
        assert_same_contact(got, want, scene.radius)
    finally:
        jax.clear_caches()
