"""bucket_sort and bucket_swept: equal to the dense detectors whenever overflow is False.

The one-call forms measure their sizes from concrete data; ``Search`` runs
the same bucket sort under jit, vmap and grad with sizes allocated outside
(tests/core/test_search.py and tests/core/test_batch.py: steps, scans, batches,
gradients); the sized stages (``tests.helpers.sized_bucket_sort``) run it at
sizes the test fixes, for the property tests and for sizes starved on purpose.
"""

import dataclasses
import functools

import hypothesis.extra.numpy as hnp
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxcontact import (
    Pairs,
    QuerySizes,
    Search,
    Sizes,
    Surface,
    all_to_all,
    bucket_sort,
    bucket_swept,
    swept,
)
from jaxcontact._pipeline import candidates as _candidates
from jaxcontact._pipeline.sizes import largest, measure
from jaxcontact._types import CHUNK_ROWS
from jaxcontact.scenes import curling_chip, cutting_scene, paper_scene, rough_die_scene
from tests.support.helpers import (
    FLOAT,
    MODE_DTYPES,
    assert_same_contact,
    assert_same_crossing,
    sized_bucket_sort,
    sized_bucket_swept,
)

# The tests CI runs again with x64 off (tests/test_x64_off.py).
X64_OFF = pytest.mark.x64_off

jit_sized_sort = jax.jit(sized_bucket_sort, static_argnames="sizes")
jit_sized_swept = jax.jit(sized_bucket_swept, static_argnames="sizes")
jit_all_to_all = jax.jit(all_to_all)
jit_expired = jax.jit(_candidates.expired)  # one program, not one per operation
jit_swept = jax.jit(swept)

# ``search.closest`` jitted once for the module (the search is static), with
# a record of its traces.
TRACES = []


@functools.partial(jax.jit, static_argnums=0)
def search_step(search, state, x, surface):
    TRACES.append(search)
    return search.closest(state, x, surface)


@functools.cache
def allocated(name):
    """(scene, search, state) of the scenes the Search tests share, in the
    widest float: one allocation (one compiled measure and find) each. Both
    bin the segments in cells, where a Search with a skin keeps candidates."""
    if name == "cutting":
        scene = cutting_scene(3_000, 18.0, dtype=FLOAT)
        search = Search(radius=0.1, skin=0.05, method="binned", slack=2.0)
    else:
        scene = rough_die_scene(4_000, 400, dtype=FLOAT)
        search = Search(radius=0.02, skin=0.01, slack=2.0)
    return scene, search, search.allocate(scene.x, scene.surface)


SCENES = {
    "cutting_contact": lambda dtype: cutting_scene(3_000, 18.0, x_tip_prev=18.2, dtype=dtype),
    "cutting_deep": lambda dtype: cutting_scene(3_000, 12.0, x_tip_prev=12.4, dtype=dtype),
    "cutting_clear": lambda dtype: cutting_scene(3_000, 20.5, x_tip_prev=20.7, dtype=dtype),
    "paper": lambda dtype: paper_scene(40, dtype=dtype),
    "rough_die": lambda dtype: rough_die_scene(4_000, 400, dtype=dtype),
}
# Each scene with the measured sizes' own choice of narrow phase (the
# one-call form), and the small-tool scenes once more with cells forced on
# (sized). Each case compiles its own programs (the sizes come from the
# data), so the dtypes alternate rather than double the cases: the tool in
# the workpiece in float32 and, deeper, in float64; the rough die (cells) in
# float32; the paper scene in float32 and, cells forced, in float64. The
# rough die's float64 one-call form is its measured sizes (cells) and the
# sized stage: the chunked search below runs them in float64
# (test_kept_slaves_searched_in_chunks_..., bucket_sort), and
# tests/core/test_properties.py runs the float64 one-call forms with and without
# cells against the exact oracle. The float32 rough die (cells) runs with
# x64 off too; without cells, the one-call forms run with x64 off in
# test_masks_nan_padding_and_empty_inputs and
# test_bucket_swept_ignores_a_nan_previous_position_like_swept.
CASES = [
    ("cutting_contact", jnp.float32, None),
    ("cutting_deep", jnp.float64, None),
    ("cutting_clear", jnp.float32, None),
    ("paper", jnp.float32, None),
    pytest.param("rough_die", jnp.float32, None, marks=X64_OFF),
    ("cutting_contact", jnp.float32, True),
    ("paper", jnp.float64, True),
]
# The comparisons are not vacuous: every scene but the clear one finds
# contacts, and every one whose tool moved (not the rough die, where x_prev
# is x) crosses.
FINDS = {"cutting_contact", "cutting_deep", "paper", "rough_die"}
CROSSES = {"cutting_contact", "cutting_deep", "paper"}


@pytest.mark.parametrize("name, dtype, use_cells", CASES)
def test_bucket_sort_equals_all_to_all_on_reference_scenes(name, dtype, use_cells):
    scene = SCENES[name](dtype)
    if use_cells is None:
        binned = bucket_sort(scene.x, scene.surface, radius=scene.radius)
    else:
        sizes = measure(scene.x, scene.surface, radius=scene.radius, use_cells=use_cells)
        assert sizes.use_cells
        binned = sized_bucket_sort(scene.x, scene.surface, radius=scene.radius, sizes=sizes)
    dense = all_to_all(scene.x, scene.surface, radius=scene.radius)
    assert binned.gap.dtype == dtype
    assert_same_contact(binned, dense, scene.radius)
    assert int(binned.found.sum()) > 0 or name not in FINDS


@pytest.mark.parametrize("name, dtype, use_cells", CASES)
def test_bucket_swept_equals_swept_on_reference_scenes(name, dtype, use_cells):
    scene = SCENES[name](dtype)
    if use_cells is None:
        binned = bucket_swept(scene.x_prev, scene.x, scene.surface)
    else:
        sizes = measure(scene.x, scene.surface, x_prev=scene.x_prev, use_cells=use_cells)
        assert sizes.use_cells
        binned = sized_bucket_swept(scene.x_prev, scene.x, scene.surface, sizes=sizes)
    assert_same_crossing(binned, swept(scene.x_prev, scene.x, scene.surface))
    assert int(binned.crossed.sum()) > 0 or name not in CROSSES


def test_tool_clear_of_workpiece_reports_nothing_and_keeps_tiny_sizes():
    scene = cutting_scene(3_000, 20.5)
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    contact = sized_bucket_sort(scene.x, scene.surface, radius=scene.radius, sizes=sizes)
    assert sizes.block_capacity == 1
    assert not bool(contact.found.any())
    assert not bool(contact.overflow)
    np.testing.assert_array_equal(contact.segment, -1)


def test_too_small_block_capacity_sets_overflow_and_larger_sizes_fix_it():
    far = cutting_scene(3_000, 20.5)
    sizes = measure(far.x, far.surface, radius=far.radius)
    near = cutting_scene(3_000, 15.0)
    contact = sized_bucket_sort(near.x, near.surface, radius=near.radius, sizes=sizes)
    assert bool(contact.overflow)
    bigger = largest(sizes, measure(near.x, near.surface, radius=near.radius))
    assert bigger.block_capacity > sizes.block_capacity
    contact = sized_bucket_sort(near.x, near.surface, radius=near.radius, sizes=bigger)
    assert_same_contact(contact, all_to_all(near.x, near.surface, radius=near.radius), near.radius)


def test_too_small_cell_capacity_sets_overflow():
    scene = rough_die_scene(4_000, 400)
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    assert sizes.use_cells
    starved = dataclasses.replace(sizes, cell_capacity=1)
    contact = sized_bucket_sort(scene.x, scene.surface, radius=scene.radius, sizes=starved)
    assert bool(contact.overflow)


def test_too_small_span_sets_overflow():
    scene = rough_die_scene(4_000, 400)
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    narrow = dataclasses.replace(sizes, span=(1, 1), cell_size=sizes.cell_size / 8)
    contact = sized_bucket_sort(scene.x, scene.surface, radius=scene.radius, sizes=narrow)
    assert bool(contact.overflow)


def test_sizes_and_search_are_hashable_and_reused_without_retracing():
    scene, search, state = allocated("cutting")
    sizes = state.sizes["closest"]
    assert hash(state.sizes) == hash(QuerySizes({"closest": dataclasses.replace(sizes)}))
    assert hash(search) == hash(dataclasses.replace(search))
    search_step(search, state, scene.x, scene.surface)  # traced here, or already
    traced = len(TRACES)
    moved = scene.surface._replace(nodes=scene.surface.nodes - 0.5)
    contact, state = search_step(search, state, scene.x + 0.01, moved)
    search_step(search, state, scene.x, scene.surface)
    assert len(TRACES) == traced


@X64_OFF
def test_one_call_forms_under_a_transform_raise_naming_search():
    scene = cutting_scene(500, 18.0)

    def contact(x):
        return bucket_sort(x, scene.surface, radius=0.1)

    def crossing(x):
        return bucket_swept(scene.x_prev, x, scene.surface)

    for transform in (jax.jit, jax.vmap):
        with pytest.raises(ValueError, match="bucket_sort .*Search"):
            transform(contact)(scene.x[None] if transform is jax.vmap else scene.x)
    with pytest.raises(ValueError, match="bucket_sort .*Search"):
        jax.grad(lambda x: jnp.sum(contact(x).gap))(scene.x)
    with pytest.raises(ValueError, match="bucket_swept .*Search"):
        jax.jit(crossing)(scene.x)


def test_wrong_sizes_raise():
    scene, search, state = allocated("cutting")
    with pytest.raises(ValueError, match=f"made for {scene.x.shape[0]} slaves; x has 400 rows"):
        search.closest(state, scene.x[:400], scene.surface)
    with pytest.raises(ValueError, match="no swept sizes: allocate it with x_prev="):
        search.swept(state, scene.x_prev, scene.x, scene.surface)
    with pytest.raises(ValueError, match="other query"):
        sized_bucket_swept(scene.x_prev, scene.x, scene.surface, sizes=state.sizes["closest"])
    with pytest.raises(ValueError, match="radius"):
        measure(scene.x, scene.surface)
    with pytest.raises(ValueError, match="x_prev"):
        Search().allocate(scene.x, scene.surface)


def test_masks_nan_padding_and_empty_inputs():
    scene = cutting_scene(1_000, 18.0, dtype=FLOAT)
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


# Hypothesis scenes are padded to fixed shapes and searched at one set of
# sizes, so each dtype compiles once. Cells small, medium and large against
# the geometry come from scaling the drawn scene by a power of two (exact in
# either dtype): the grid's origin and its cells' growth with the region
# scale with it, so scaling the scene by s is searching it with cells of
# CELL_SIZE / s, without a compilation for each cell size.
MAX_NODES, MAX_SLAVES = 24, 256
CELL_SIZE = 0.4
SCALES = (8.0, 1.0, 0.125)  # cells of 0.05, 0.4 and 3.2 in the drawn scene's units


def fixed_sizes(for_paths, buckets=0):
    """Blocks of 8 with room for all; a 16 x 16 grid; spans and cells that cannot
    overflow. ``buckets`` hashes the 256 cells into that many lists: with 7,
    most lists are shared by many cells and hold some segments more than once."""
    return Sizes(
        num_slaves=MAX_SLAVES,
        block_size=8,
        block_capacity=MAX_SLAVES // 8,
        for_paths=for_paths,
        use_cells=True,
        grid_shape=(16, 16),
        cell_size=CELL_SIZE,
        span=(16, 16),
        cell_capacity=MAX_NODES * (16 * 16 if buckets else 1),
        buckets=buckets,
    )


@st.composite
def polyline_scenes(draw, dtype):
    """Random slaves near a random polyline, padded to fixed shapes with masks,
    scaled by one of ``SCALES``; returns the scene and its scale."""
    scale = draw(st.sampled_from(SCALES))
    num_nodes = draw(st.integers(2, MAX_NODES))
    coords = st.floats(-3, 3, allow_nan=False, width=32)
    nodes = draw(hnp.arrays(np.float64, (num_nodes, 2), elements=coords))
    slaves = draw(hnp.arrays(np.float64, (draw(st.integers(1, 200)), 2), elements=coords))
    # Some slaves exactly on nodes and on segment midpoints: the hard places.
    on_nodes = nodes[draw(st.lists(st.integers(0, num_nodes - 1), max_size=10))]
    slaves = np.concatenate([slaves, on_nodes, (nodes[:-1] + nodes[1:]) / 2])[:MAX_SLAVES]
    padded_nodes = np.zeros((MAX_NODES, 2))
    padded_nodes[:num_nodes] = nodes.astype(dtype) * scale
    segments = np.stack([np.arange(MAX_NODES - 1), np.arange(1, MAX_NODES)], axis=-1)
    surface = Surface(
        jnp.asarray(padded_nodes, dtype),
        jnp.asarray(segments, jnp.int32),
        jnp.arange(MAX_NODES - 1) < num_nodes - 1,
    )
    padded_slaves = np.full((MAX_SLAVES, 2), np.nan)
    padded_slaves[: len(slaves)] = slaves.astype(dtype) * scale
    mask = jnp.arange(MAX_SLAVES) < len(slaves)
    return (jnp.asarray(padded_slaves, dtype), surface, mask), scale


@given(
    st.sampled_from(MODE_DTYPES).flatmap(polyline_scenes),
    st.sampled_from([0.0, 0.05, 0.3, 1.0]),
    st.sampled_from([0, 7]),
)
def test_bucket_sort_equals_all_to_all_on_random_polylines(scaled_scene, radius, buckets):
    (x, surface, mask), scale = scaled_scene
    radius *= scale
    sizes = fixed_sizes(False, buckets)
    binned = jit_sized_sort(x, surface, radius=radius, mask=mask, sizes=sizes)
    assert_same_contact(
        binned, jit_all_to_all(x, surface, radius=radius, mask=mask), radius, degenerate=True
    )


@given(
    st.sampled_from(MODE_DTYPES).flatmap(polyline_scenes),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
    st.sampled_from([0, 7]),
)
def test_bucket_swept_equals_swept_on_random_polylines(scaled_scene, move, buckets):
    (x_prev, surface, mask), scale = scaled_scene
    x = x_prev + jnp.asarray(move, x_prev.dtype)[None] * scale
    sizes = fixed_sizes(True, buckets)
    binned = jit_sized_swept(x_prev, x, surface, mask=mask, sizes=sizes)
    assert_same_crossing(binned, jit_swept(x_prev, x, surface, mask=mask), degenerate=True)


def test_sizes_fields():
    # The fields against the scene they were measured on, counted here: the
    # kept blocks hold every block of consecutive rows with a slave in reach.
    scene = rough_die_scene(4_000, 400)
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    assert isinstance(sizes, Sizes) and sizes.num_slaves == scene.x.shape[0]
    found = np.asarray(all_to_all(scene.x, scene.surface, radius=scene.radius).found)
    blocks = np.add.reduceat(found, np.arange(0, len(found), sizes.block_size)) > 0
    assert 0 < blocks.sum() <= sizes.block_capacity < len(blocks)
    assert sizes.slave_capacity == sizes.block_capacity * sizes.block_size >= found.sum()
    assert sizes.use_cells and sizes.grid_shape[0] > 1 and sizes.cell_capacity >= 1
    assert sizes.chunk_rows == CHUNK_ROWS
    binned = sized_bucket_sort(scene.x, scene.surface, radius=scene.radius, sizes=sizes)
    assert_same_contact(binned, all_to_all(scene.x, scene.surface, radius=scene.radius))


def test_an_outline_in_a_wide_box_hashes_its_cells_and_finds_what_all_to_all_does():
    """The curled chip's outline winds through a box of mostly empty cells:
    ``measure`` keeps cells near its radius and hashes them into lists, where
    a grid that fitted would have cells many times wider."""
    scene = curling_chip(3_000)
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    assert sizes.use_cells and sizes.buckets > 0
    assert sizes.cell_size < 8 * scene.radius
    assert sizes.buckets < sizes.grid_shape[0] * sizes.grid_shape[1]
    rule = Pairs(scene.slave_node, self_contact=True)
    binned = sized_bucket_sort(scene.x, scene.surface, radius=scene.radius, sizes=sizes, pairs=rule)
    dense = all_to_all(scene.x, scene.surface, radius=scene.radius, pairs=rule)
    assert not bool(binned.overflow)
    assert_same_contact(binned, dense, scene.radius)
    assert np.asarray(dense.active).sum() > 0


def test_sizes_merged_from_other_cells_get_room_at_their_own():
    """Sizes measured at wide cells on a sparse outline, merged with the full
    outline's (``largest``: the widest cells, the larger capacity) hold less
    than a wide cell of the full outline: that search overflows. A ``Search``
    allocated ``at_least=`` them measures again at the merged cells."""
    scene = curling_chip(3_000)
    radius, (x, surface) = scene.radius, (scene.x, scene.surface)
    num_segments = surface.segments.shape[0]
    sparse = Surface(surface.nodes, surface.segments, jnp.arange(num_segments) % 4 == 0)
    old = measure(x, sparse, radius=radius, cell_size=8 * radius)
    merged = largest(measure(x, surface, radius=radius), old)
    assert bool(sized_bucket_sort(x, surface, radius=radius, sizes=merged).overflow)
    search = Search(radius=radius, method="binned")
    state = search.allocate(x, surface, at_least={"closest": old})
    assert state.sizes["closest"].cell_size == merged.cell_size
    assert state.sizes["closest"].cell_capacity > merged.cell_capacity
    contact, state = search.closest(state, x, surface)
    assert not bool(state.overflow)
    assert_same_contact(contact, all_to_all(x, surface, radius=radius), radius)


@pytest.mark.parametrize("buckets", [-1, 2.5, True])
def test_sizes_refuse_buckets_that_are_no_count(buckets):
    with pytest.raises(ValueError, match=r"Sizes.buckets must be an int >= 0"):
        dataclasses.replace(fixed_sizes(False), buckets=buckets)


@pytest.mark.parametrize("name", ["cutting", "rough_die"])
def test_candidates_reused_over_steps_equal_a_fresh_search_until_expired(name):
    """The tool advances step by step; candidates found once serve while within
    the skin, and are found again (inside the step) once it is exceeded."""
    scene, search, state = allocated(name)
    radius, skin = search.radius, search.skin
    found = state.candidates
    step = jnp.asarray([-0.4 * skin, 0.0])
    for count in range(1, 4):
        surface = scene.surface._replace(nodes=scene.surface.nodes + count * step[None])
        expired = bool(jit_expired(found, scene.x, surface, None, skin))
        assert expired == (count * 0.4 * skin > skin)
        contact, state = search_step(search, state, scene.x, surface)
        assert int(state.rebuilds) == int(expired)
        assert_same_contact(contact, all_to_all(scene.x, surface, radius=radius), radius)
        if expired:
            break
    assert expired, "the test should have run the candidates out"
    assert not bool(state.overflow)


def test_expired_candidates_can_miss_contacts_which_is_why_the_check_exists():
    scene = cutting_scene(3_000, 20.3)
    search = Search(radius=0.1, skin=0.05, method="binned", slack=2.0)
    with pytest.warns(UserWarning, match="hold no contact"):  # the tool is clear
        state = search.allocate(scene.x, scene.surface)
    moved = scene.surface._replace(nodes=scene.surface.nodes.at[:, 0].add(-1.5))
    assert bool(jit_expired(state.candidates, scene.x, moved, None, search.skin))
    stale = sized_bucket_sort(
        scene.x, moved, radius=0.1, sizes=state.sizes["closest"], candidates=state.candidates
    )
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
    scene, search, state = allocated("rough_die")
    assert state.sizes["closest"].use_cells and state.candidates is not None
    masked = scene.surface._replace(mask=jnp.arange(400) % 3 != 0)
    reused, state = search.closest(state, scene.x, masked)
    assert int(state.rebuilds) == 0  # masking a segment keeps the candidates
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


def test_measure_rejects_a_non_positive_cell_factor_and_largest_merges_sizes():
    scene = rough_die_scene(2_000, 100)
    with pytest.raises(ValueError, match="cell_factor"):
        measure(scene.x, scene.surface, radius=0.02, cell_factor=0.0)
    sizes = measure(scene.x, scene.surface, radius=0.02)
    more = measure(scene.x, scene.surface, radius=0.02, slack=3.0, use_cells=True)
    bigger = largest(sizes, more)
    assert bigger.use_cells and bigger.cell_capacity >= sizes.cell_capacity
    assert bigger.cell_capacity >= more.cell_capacity
    assert bigger.block_capacity == max(sizes.block_capacity, more.block_capacity)
    paths = measure(scene.x, scene.surface, x_prev=scene.x_prev)
    with pytest.raises(ValueError, match="different searches"):
        largest(sizes, paths)


@pytest.mark.parametrize("detector", ["bucket_sort", "bucket_swept", "reused"])
def test_kept_slaves_searched_in_chunks_longest_lists_first_equal_dense(detector):
    # Above ``Sizes.chunk_rows`` kept slaves, the cell search sorts them by
    # list length and stops at the first chunk of empty lists. A chunk of 64
    # rows puts the rough die's 2,496 kept slaves in 39 chunks: full, partly
    # empty and empty ones, with masked slaves and NaN rows among them.
    scene = rough_die_scene(4_000, 400, dtype=FLOAT)
    x = scene.x.at[7].set(jnp.nan)
    mask = jnp.asarray(np.arange(x.shape[0]) % 11 != 5)
    if detector == "bucket_swept":
        x_prev = x + jnp.asarray([[0.01, 0.03]])
        sizes = measure(x, scene.surface, x_prev=x_prev, mask=mask, chunk_rows=64)
        assert sizes.use_cells and sizes.slave_capacity > sizes.chunk_rows == 64
        got = sized_bucket_swept(x_prev, x, scene.surface, mask=mask, sizes=sizes)
        assert int(got.crossed.sum()) > 0
        assert_same_crossing(got, swept(x_prev, x, scene.surface, mask=mask))
        return
    if detector == "reused":
        # Candidates found at allocate (with a skin) and reused: nothing has moved.
        search = Search(radius=scene.radius, skin=scene.radius / 2, chunk_rows=64)
        state = search.allocate(x, scene.surface, mask=mask)
        sizes = state.sizes["closest"]
        got, state = search.closest(state, x, scene.surface, mask=mask)
        assert state.candidates is not None and int(state.rebuilds) == 0
    else:
        sizes = dataclasses.replace(
            measure(x, scene.surface, radius=scene.radius, mask=mask), chunk_rows=64
        )
        got = sized_bucket_sort(x, scene.surface, radius=scene.radius, mask=mask, sizes=sizes)
    assert sizes.use_cells and sizes.slave_capacity > sizes.chunk_rows == 64
    want = all_to_all(x, scene.surface, radius=scene.radius, mask=mask)
    assert int(want.found.sum()) > 0
    assert_same_contact(got, want, scene.radius)
