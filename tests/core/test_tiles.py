"""The tiled cell search (``narrow.search_tiles``): the same answers as the
chunked one (``narrow.search_listed``) and as all-to-all, on any backend.

The backend picks one (``narrow.tiled``); these tests run the tiles on the
CPU by setting ``narrow.TILED``, which is read when a search is traced, so
each test clears JAX's caches around it.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import Pairs, Search, all_to_all, swept
from jaxcontact._pipeline import narrow
from jaxcontact._pipeline.sizes import measure
from jaxcontact.scenes import curling_chip, rough_die_scene
from tests.support.helpers import (
    FLOAT,
    assert_same_contact,
    assert_same_crossing,
    sized_bucket_sort,
    sized_bucket_swept,
)


@pytest.fixture
def tiles_on(monkeypatch):
    jax.clear_caches()
    monkeypatch.setattr(narrow, "TILED", True)
    yield
    jax.clear_caches()


def _die(dtype=FLOAT):
    scene = rough_die_scene(4_000, 400, dtype=dtype)
    x = scene.x.at[7].set(jnp.nan)
    mask = jnp.asarray(np.arange(x.shape[0]) % 11 != 5)
    return scene, x, mask


@pytest.mark.usefixtures("tiles_on")
@pytest.mark.parametrize("detector", ["bucket_sort", "bucket_swept", "reused"])
def test_tiles_equal_all_to_all_with_masked_and_nan_rows(detector):
    scene, x, mask = _die()
    if detector == "bucket_swept":
        x_prev = x + jnp.asarray([[0.01, 0.03]])
        sizes = measure(x, scene.surface, x_prev=x_prev, mask=mask)
        assert sizes.use_cells and 0 < sizes.tile_capacity < sizes.slave_capacity
        got = sized_bucket_swept(x_prev, x, scene.surface, mask=mask, sizes=sizes)
        assert int(got.crossed.sum()) > 0 and not bool(got.overflow)
        assert_same_crossing(got, swept(x_prev, x, scene.surface, mask=mask))
        return
    if detector == "reused":
        search = Search(radius=scene.radius, skin=scene.radius / 2)
        state = search.allocate(x, scene.surface, mask=mask)
        got, state = search.closest(state, x, scene.surface, mask=mask)
        assert state.candidates is not None and int(state.rebuilds) == 0
    else:
        sizes = measure(x, scene.surface, radius=scene.radius, mask=mask)
        got = sized_bucket_sort(x, scene.surface, radius=scene.radius, mask=mask, sizes=sizes)
    assert not bool(got.overflow)
    want = all_to_all(x, scene.surface, radius=scene.radius, mask=mask)
    assert int(want.found.sum()) > 0
    assert_same_contact(got, want, scene.radius)


@pytest.mark.usefixtures("tiles_on")
def test_tiles_keep_the_pair_rule_and_hashed_lists_of_self_contact():
    scene = curling_chip(1_500, dtype=FLOAT)
    pairs = Pairs(scene.slave_node, self_contact=True)
    search = Search(radius=scene.radius)
    state = search.allocate(scene.x, scene.surface, pairs=pairs)
    assert state.sizes["closest"].use_cells and state.sizes["closest"].buckets > 0
    got, _ = search.closest(state, scene.x, scene.surface, pairs=pairs)
    want = all_to_all(scene.x, scene.surface, radius=scene.radius, pairs=pairs)
    assert int(want.found.sum()) > 0
    assert_same_contact(got, want, scene.radius)


@pytest.mark.usefixtures("tiles_on")
def test_too_few_tiles_set_overflow_and_measured_ones_do_not():
    scene, x, mask = _die()
    sizes = measure(x, scene.surface, radius=scene.radius, mask=mask)
    enough = sized_bucket_sort(x, scene.surface, radius=scene.radius, mask=mask, sizes=sizes)
    assert not bool(enough.overflow)
    starved = dataclasses.replace(sizes, tile_capacity=1)
    short = sized_bucket_sort(x, scene.surface, radius=scene.radius, mask=mask, sizes=starved)
    assert bool(short.overflow)


def test_tiles_and_chunks_choose_the_same_segment_even_at_vertex_ties(monkeypatch):
    # The two cell searches meet each row's list in the same order, so even
    # exact vertex ties go the same way.
    scene, x, mask = _die()
    sizes = measure(x, scene.surface, radius=scene.radius, mask=mask)
    sizes = dataclasses.replace(sizes, chunk_rows=64)
    found = {}
    for tiled in (False, True):
        jax.clear_caches()
        monkeypatch.setattr(narrow, "TILED", tiled)
        result = sized_bucket_sort(x, scene.surface, radius=scene.radius, mask=mask, sizes=sizes)
        found[tiled] = jax.tree.map(np.asarray, result)
    jax.clear_caches()
    np.testing.assert_array_equal(found[True].segment, found[False].segment)
    # The gaps are assembled from the same pair in differently fused programs.
    np.testing.assert_allclose(found[True].gap, found[False].gap, rtol=0, atol=1e-6 * scene.radius)
    assert sizes.tile_capacity > 0
