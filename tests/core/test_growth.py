"""A search over a scene that grows: segments that appear, long runs that
outgrow their sizes, batches that share their nodes."""

from __future__ import annotations

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import Search, Surface, all_to_all, resumable_scan
from jaxcontact.scenes import cutting_scene, rough_die_scene
from tests.support.helpers import FLOAT, assert_same_contact

NUM_SEGMENTS = 100
POOL = slice(40, 60)


def die(mask):
    scene = rough_die_scene(2_000, NUM_SEGMENTS, dtype=FLOAT)
    return scene, scene.surface._replace(mask=jnp.asarray(mask))


def test_segments_of_the_pool_switch_on_without_overflow_or_rebuild():
    """A new free surface: masked segments named at allocate as the pool are
    listed among the candidates; switching them on rebuilds nothing, and only
    a segment outside the pool does (and the state says why)."""
    pool = np.zeros(NUM_SEGMENTS, bool)
    pool[POOL] = True
    outside = 10
    mask = ~pool
    mask[outside] = False
    scene, surface = die(mask)
    for with_pool in (True, False):
        search = Search(radius=scene.radius, skin=0.02, method="binned")
        state = search.allocate(scene.x, surface, pool=pool if with_pool else None)
        step = jax.jit(search.closest)
        for stop in range(44, 64, 4):
            now = mask | (pool & (np.arange(NUM_SEGMENTS) < stop))
            contact, state = step(state, scene.x, surface._replace(mask=jnp.asarray(now)))
            if with_pool:
                expected = all_to_all(scene.x, surface._replace(mask=jnp.asarray(now)), radius=0.02)
                assert_same_contact(contact, expected, 0.02)
        if with_pool:
            assert int(state.rebuilds) == 0 and not bool(state.overflow)
            assert state.rebuild_reasons() == []
        else:  # the 0.2.0 behaviour: every switch finds the candidates again
            assert int(state.rebuilds) == 5 and int(state.last_rebuild) == 4
    now = mask | pool
    now[outside] = True
    contact, state = step(state, scene.x, surface._replace(mask=jnp.asarray(now)))
    assert int(state.last_rebuild) == 4
    assert state.rebuild_reasons() == ["a segment outside the pool became real"]
    moved = scene.x.at[:, 1].add(0.03)  # more than the skin
    contact, state = step(state, moved, surface._replace(mask=jnp.asarray(now)))
    assert state.rebuild_reasons() == ["the slaves and the master moved more than the skin"]


def trajectory(steps=12):
    """The cutting scene's tool moving 0.05 a step into the workpiece."""
    scene = cutting_scene(2_000, 20.2, dtype=FLOAT)
    shift = 0.05 * np.arange(steps)[:, None, None] * np.array([1.0, 0.0])
    nodes = jnp.asarray(np.asarray(scene.surface.nodes)[None] - shift, FLOAT)
    return scene.x, nodes, scene.surface.segments


def test_resumable_scan_repeats_only_the_chunks_that_overflowed():
    x, nodes, segments = trajectory()
    search = Search(radius=0.1, skin=0.05, slack=1.0)

    def step(state, tool):
        contact, state = search.closest(state, x, Surface(tool, segments))
        return state, contact.segment

    def grow(state, tools):
        for tool in tools:  # sized for every configuration the chunk reaches
            state = search.allocate(x, Surface(tool, segments), at_least=state)
        return state

    with pytest.warns(UserWarning, match="hold no contact"):  # the tool is clear
        first = search.allocate(x, Surface(nodes[0], segments))
    with pytest.raises(ValueError, match="chunk must be an int >= 1"):
        resumable_scan(step, first, nodes, chunk=0, grow=grow)
    # The tool is driven through nodes that stay put: contacts are lost, and said so.
    with pytest.warns(UserWarning, match="lost [0-9]+ contact"):
        final, segment, regrown = resumable_scan(step, first, nodes, chunk=4, grow=grow)
    assert int(final.lost) > 0
    assert 0 < len(regrown) < 3 and regrown == sorted(regrown)
    assert not bool(final.overflow)
    for t in range(len(nodes)):
        expected = all_to_all(x, Surface(nodes[t], segments), radius=0.1)
        np.testing.assert_array_equal(segment[t], expected.segment)
    # One scan from step 0 with the sizes the run ended with gives the same.
    _, again = jax.lax.scan(step, grow(first, nodes), nodes)
    np.testing.assert_array_equal(again, segment)
    with pytest.raises(ValueError, match="overflowed SearchState"):
        resumable_scan(step, replace(final, overflow=jnp.ones((), bool)), nodes, chunk=4, grow=grow)


def test_a_batch_shares_its_nodes_and_segments_and_masks_its_segments_per_scene():
    x, nodes, segments = trajectory(steps=3)
    masks = np.ones((2, segments.shape[0]), bool)
    masks[1, :8] = False  # the second scene without the rake face
    xs = jnp.stack([x, x])
    surface = Surface(nodes[2], segments, jnp.asarray(masks))
    search = Search(radius=0.1, skin=0.05, method="binned")
    state = search.allocate(xs, surface)
    axes = (0, 0, Surface(None, None, 0))
    contacts, _ = jax.vmap(search.closest, in_axes=axes)(state, xs, surface)
    for b in range(2):
        one = Surface(nodes[2], segments, jnp.asarray(masks[b]))
        expected = all_to_all(x, one, radius=0.1)
        assert_same_contact(jax.tree.map(lambda v, b=b: v[b], contacts), expected, 0.1)
    with pytest.raises(ValueError, match="surface.mask must be shared by the batch"):
        search.allocate(xs, Surface(nodes[2], segments, jnp.ones((3, 20), bool)))


def test_the_skin_check_names_each_reason_and_ignores_what_padding_held():
    """``expired`` bit by bit (one pass over the rows since 0.7.4): a row that
    becomes real is new, whatever its padding held; a real row moved past the
    skin, or so far that its squared move overflows, moved; a masked row, or
    one not finite (not real), may change freely."""
    scene = cutting_scene(500, 18.0, dtype=FLOAT)
    mask = np.ones(scene.x.shape[0], bool)
    mask[7] = False
    x = np.asarray(scene.x).copy()
    x[7] = (1e6, -1e6)  # padding: anything
    search = Search(radius=0.1, skin=0.05, method="binned")
    state = search.allocate(jnp.asarray(x), scene.surface, mask=jnp.asarray(mask))
    step = jax.jit(search.closest)

    def reasons(x, mask):
        _, after = step(state, jnp.asarray(x, FLOAT), scene.surface, mask=jnp.asarray(mask))
        return after.rebuild_reasons()

    assert reasons(x, mask) == []
    padded = x.copy()
    padded[7] = (np.nan, 3.0)  # a masked row changes freely
    assert reasons(padded, mask) == []
    moved = x.copy()
    moved[3, 0] += 0.06  # one real row, past the skin
    assert reasons(moved, mask) == ["the slaves and the master moved more than the skin"]
    far = x.copy()
    far[3] = (3e38, -3e38)  # a real row whose squared move overflows to inf
    assert reasons(far, mask) == ["the slaves and the master moved more than the skin"]
    lost = x.copy()
    lost[3] = (np.nan, 0.0)  # a row that is not finite is not real: dropped, as padding
    assert reasons(lost, mask) == []
    joined = x.copy()
    joined[7] = np.asarray(scene.x)[7]  # far from its padding, and real now
    assert reasons(joined, np.ones_like(mask)) == ["a slave row became real"]
