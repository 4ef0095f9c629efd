"""A third query is a new ``Query`` instance and nothing else.

The nearest master node within the radius (a node-to-node search), written
here as the protocol asks (a pair kernel, an assembly, two result types) and
run by the library's own drivers, unchanged: the exhaustive one and the
sized bucket sort, in its N-row and list forms, and ``Search``'s allocation
and step, alone, beside the closest point and for a batch, against a NumPy
brute force.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import Search, all_to_all
from jaxcontact._pipeline import driver
from jaxcontact._pipeline.pairs import EVERY_PAIR
from jaxcontact._pipeline.sizes import measure, room_for_every_slot
from jaxcontact._query.closest import CLOSEST, Closest
from jaxcontact.scenes import rough_die_scene
from tests.support.helpers import assert_same_contact
from tests.support.tolerances import FLOAT64_RTOL


class NearestNode(NamedTuple):
    distance: jax.Array  # f[N]  distance to the nearest node of a real segment
    segment: jax.Array  # i32[N]  a segment that has it as an end, -1 where not found
    vertex: jax.Array  # i32[N]  the node, -1 where not found
    point: jax.Array  # f[N, 2]  its position
    found: jax.Array  # bool[N]  within the radius
    overflow: jax.Array  # bool[]


class NearestNodeList(NamedTuple):
    node: jax.Array  # i32[K]  slave row, N for padding
    distance: jax.Array  # f[K]
    segment: jax.Array  # i32[K]
    vertex: jax.Array  # i32[K]
    point: jax.Array  # f[K, 2]
    found: jax.Array  # bool[K]
    overflow: jax.Array  # bool[]


class NearestNodeQuery(Closest):
    """Closest's reach, boxes and checks; its own kernel, assembly and results."""

    name = "nearest node"
    result = NearestNode
    listing = NearestNodeList

    def kernel(self, x, edge):
        to_start, to_end = x - edge.start, x - edge.end
        return jnp.minimum(jnp.sum(to_start * to_start), jnp.sum(to_end * to_end))

    def assemble(self, kept, segments, choice, radius, overflow, ok, ruling):
        (x,) = kept
        index = jnp.maximum(choice, 0)
        start, end = segments.start[index], segments.end[index]
        nearer_end = jnp.sum((x - end) ** 2, -1) < jnp.sum((x - start) ** 2, -1)
        point = jnp.where(nearer_end[:, None], end, start)
        distance = jnp.sqrt(jnp.sum((x - point) ** 2, -1))
        found = ok & (choice >= 0) & (distance <= radius)
        ends = segments.indices[index]
        vertex = jnp.where(nearer_end, ends[:, 1], ends[:, 0])
        return NearestNode(
            distance=jnp.where(found, distance, 0),
            segment=jnp.where(found, choice, -1),
            vertex=jnp.where(found, vertex, -1),
            point=jnp.where(found[:, None], point, 0),
            found=found,
            overflow=overflow,
        )


NEAREST_NODE = NearestNodeQuery()


def _brute_force(x, nodes, segments, radius):
    """Per slave: the distance to the nearest node that ends a segment, and that node."""
    ends = np.unique(segments)
    gaps = np.linalg.norm(x[:, None, :] - nodes[ends][None, :, :], axis=-1)
    nearest = np.argmin(gaps, axis=1)
    distance = gaps[np.arange(len(x)), nearest]
    return distance, ends[nearest], distance <= radius


@pytest.fixture(scope="module")
def scene():
    die = rough_die_scene(3_000, 300, dtype=jnp.float64)
    nodes, segments = np.asarray(die.surface.nodes), np.asarray(die.surface.segments)
    return die, _brute_force(np.asarray(die.x), nodes, segments, float(die.radius))


def _check(result, expected):
    distance, vertex, found = expected
    np.testing.assert_array_equal(np.asarray(result.found), found)
    assert found.any() and not found.all()
    np.testing.assert_allclose(
        np.asarray(result.distance)[found], distance[found], rtol=FLOAT64_RTOL
    )
    np.testing.assert_array_equal(np.asarray(result.vertex)[found], vertex[found])


@pytest.mark.x64
def test_the_exhaustive_driver_runs_a_new_query(scene):
    die, expected = scene
    radius = jnp.asarray(die.radius, die.x.dtype)
    args = ((die.x,), die.surface, radius, None, EVERY_PAIR)
    _check(driver.exhaustive(NEAREST_NODE, *args), expected)


@pytest.mark.x64
@pytest.mark.parametrize("use_cells", [False, True])
def test_the_sized_driver_runs_a_new_query_in_both_forms(scene, use_cells):
    die, expected = scene
    radius = jnp.asarray(die.radius, die.x.dtype)
    sizes = measure(die.x, die.surface, radius=radius, use_cells=use_cells)
    assert sizes.use_cells == use_cells
    rows = driver.sized_jit(NEAREST_NODE, (die.x,), die.surface, radius, None, sizes=sizes)
    assert not bool(rows.overflow)
    _check(rows, expected)
    entries = driver.sized_jit(
        NEAREST_NODE, (die.x,), die.surface, radius, None, sizes=room_for_every_slot(sizes)
    )
    assert isinstance(entries, NearestNodeList) and not bool(entries.overflow)
    listed = np.asarray(entries.node)[np.asarray(entries.found)]
    np.testing.assert_array_equal(listed, np.flatnonzero(expected[2]))


@pytest.mark.x64
@pytest.mark.parametrize("compact", [False, True])
def test_search_sizes_and_steps_a_new_query_by_its_name(scene, compact):
    die, expected = scene
    search = Search(radius=float(die.radius), method="binned", compact=compact)
    queries = {NEAREST_NODE: (die.x,), CLOSEST: (die.x,)}
    state = search._allocate_queries(queries, die.surface)
    assert set(state.sizes) == {"nearest node", "closest"}
    assert bool(state.sizes["nearest node"].contact_capacity) == compact
    radius = jnp.asarray(die.radius, die.x.dtype)
    found, state = search._step(
        NEAREST_NODE, state, (die.x,), die.surface, radius, None, EVERY_PAIR
    )
    assert not bool(found.overflow) and not bool(state.overflow)
    if compact:
        listed = np.asarray(found.node)[np.asarray(found.found)]
        np.testing.assert_array_equal(listed, np.flatnonzero(expected[2]))
    else:
        _check(found, expected)
        # The closest point from the same state, as allocated beside it.
        contact, _ = search.closest(state, die.x, die.surface)
        assert_same_contact(contact, all_to_all(die.x, die.surface, radius=die.radius), die.radius)


@pytest.mark.x64
def test_search_sizes_a_batch_of_a_new_query_with_the_same_code(scene):
    die, expected = scene
    search = Search(radius=float(die.radius), method="binned")
    xs = jnp.stack([die.x, die.x.at[:, 1].add(die.radius)])  # the second lifted by r
    state = search._allocate_queries({NEAREST_NODE: (xs,)}, die.surface, warn=False)
    assert state.overflow.shape == (2,)
    radius = jnp.asarray(die.radius, die.x.dtype)

    def step(state, x):
        return search._step(NEAREST_NODE, state, (x,), die.surface, radius, None, EVERY_PAIR)

    found, state = jax.vmap(step)(state, xs)
    assert not np.asarray(state.overflow).any()
    nodes, segments = np.asarray(die.surface.nodes), np.asarray(die.surface.segments)
    lifted = _brute_force(np.asarray(xs[1]), nodes, segments, float(die.radius))
    for index, scene_expected in enumerate((expected, lifted)):
        _check(jax.tree.map(lambda values, i=index: values[i], found), scene_expected)
