"""Small scenes take shorter paths (fewer kernels); each gives the general path's answer.

- ``_narrow.search_all`` scores the whole plane at once (``_lowest_in_plane``)
  up to ``PLANE_PAIRS`` pairs when there are more segments than
  ``lowest_score`` unrolls; the running minimum is the general path.
- ``_outline._first_match`` uses the M x M table of matches up to
  ``TABLE_SEGMENTS`` segments; a sort and a binary search is the general path.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact._pipeline import outline as _outline
from jaxcontact._pipeline.geometry import edge, squared_distance
from jaxcontact._pipeline.lowest import lowest_score
from jaxcontact._pipeline.narrow import _lowest_in_plane
from jaxcontact._pipeline.segments import resolve_segments
from jaxcontact._types import Surface
from tests.support import helpers

pytestmark = pytest.mark.x64_off


def test_plane_chooses_as_the_running_minimum_does():
    # 40 segments (more than lowest_score unrolls), the second 20 repeating the
    # first (every slave ties exactly between k and k + 20: the lower index
    # wins), some masked, and scores that are NaN or inf (no candidate).
    scene = helpers.random_scene(3, 11, 20)
    doubled = np.concatenate([scene.segments, scene.segments])
    starts = jnp.asarray(scene.nodes[doubled[:, 0]])
    ends = jnp.asarray(scene.nodes[doubled[:, 1]])
    x = jnp.asarray(scene.x).at[0].set(jnp.nan)  # a row whose every score is NaN
    ok = jnp.ones(40, bool).at[jnp.array([1, 7, 22])].set(False)
    pair_value = jax.vmap(squared_distance, in_axes=(0, None))

    # With XLA's default code generation, as users compile it: the suite
    # (tests/conftest.py) leaves LLVM's optimisation off, and there the two
    # routes' float64 squared distances were seen 1 ulp apart (1 row of 11).
    @functools.partial(jax.jit, compiler_options=helpers.XLA_DEFAULTS)
    def both(x, starts, ends, ok):
        edges = edge(starts, ends)

        def score(k):
            value = pair_value(x, jax.tree.map(lambda field: field[k], edges))
            return jnp.where(ok[k], value, jnp.inf), jnp.broadcast_to(k, x.shape[:1])

        loop = lowest_score(score, 40, x.shape[0], x.dtype)
        plane = _lowest_in_plane(lambda e: pair_value(x, e), edges, ok, x.dtype)
        return loop, plane

    (loop_choice, loop_best), (plane_choice, plane_best) = both(x, starts, ends, ok)
    np.testing.assert_array_equal(plane_choice, loop_choice)
    np.testing.assert_array_equal(plane_best, loop_best)
    assert int(plane_choice[0]) == -1 and np.isinf(plane_best[0])
    assert np.all(np.asarray(plane_choice)[1:] < 20)  # ties to the lower index
    assert np.all(np.asarray(plane_choice) != 1) and np.all(np.asarray(plane_choice) != 7)


def test_neighbour_table_equals_the_sorted_search(monkeypatch):
    # Two closed loops and an open chain, in shuffled order, with a masked
    # segment, a padding row pointing anywhere, and a node shared by three
    # segments (a branch: the lowest index is its neighbour).
    indices = np.array(
        [[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 6], [6, 3], [7, 8], [8, 9], [1, 7], [9, 9]]
    )
    order = np.random.default_rng(0).permutation(len(indices))
    nodes = np.random.default_rng(1).normal(size=(10, 2))
    mask = np.ones(len(indices), bool)
    mask[order.tolist().index(10)] = False  # the degenerate row is masked too
    mask[order.tolist().index(5)] = False
    surface = Surface(jnp.asarray(nodes), jnp.asarray(indices[order]), mask=jnp.asarray(mask))
    segments = resolve_segments(surface)
    table = [np.asarray(a) for a in _outline.vertex_neighbours(segments)]
    monkeypatch.setattr(_outline, "TABLE_SEGMENTS", 0)
    sorted_ = [np.asarray(a) for a in _outline.vertex_neighbours(segments)]
    for got, want in zip(table, sorted_, strict=True):
        np.testing.assert_array_equal(got, want)
    assert np.any(table[0] >= 0) and np.any(table[0] == -1)
