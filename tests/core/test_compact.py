"""The compact result (``ContactList``): the found rows of the dense ``Contact``, packed.

Every test compares it with the dense form: entry by entry, the rows the
dense ``Contact`` reports as found, in increasing slave order, padding after
them: the same slaves and segments, values equal to rounding (the compact
program assembles only the slaves it may find, and XLA fuses that pair
evaluation differently: the last bit may differ).
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import (
    ContactList,
    CrossingList,
    QuerySizes,
    Search,
    Surface,
    all_to_all,
    bucket_sort,
    bucket_swept,
    swept,
)
from jaxcontact._pipeline import driver
from jaxcontact._query.closest import CLOSEST
from jaxcontact.scenes import cutting_scene, rough_die_scene
from tests.core.test_search import NUM_STEPS, RADIUS, SKIN, surface_at, trajectory
from tests.support.helpers import (
    FLOAT,
    assert_same_contact,
    assert_same_crossing,
    binned_tolerance,
    gradient_atol,
)


def _assert_packed(entries, dense, num_rows: int, flag: str, exact, close):
    """``entries`` hold exactly the ``flag`` rows of ``dense`` (its ``exact``
    fields equal, its ``close`` ones to rounding), in order, padding after;
    returns the tolerance."""
    flags = np.asarray(getattr(entries, flag))
    count = int(flags.sum())
    rows = np.flatnonzero(np.asarray(getattr(dense, flag)))
    assert count == rows.size > 0
    assert flags[:count].all() and not flags[count:].any()  # real entries first
    np.testing.assert_array_equal(entries.node[:count], rows)  # increasing slave rows
    tol = binned_tolerance(dense.point.dtype, dense.point)
    for field in exact:
        np.testing.assert_array_equal(getattr(entries, field)[:count], getattr(dense, field)[rows])
    for field in close:
        got, want = getattr(entries, field)[:count], getattr(dense, field)[rows]
        np.testing.assert_allclose(got, want, rtol=0, atol=tol)
    # Padding: one past the last slave, no segment, zeros.
    assert (np.asarray(entries.node[count:]) == num_rows).all()
    assert (np.asarray(entries.segment[count:]) == -1).all()
    for field in close:
        assert not np.asarray(getattr(entries, field)[count:]).any()
    return tol


def assert_packs(entries: ContactList, dense, num_rows: int):
    """``entries`` hold exactly the found rows of ``dense``, in order, padding after."""
    assert isinstance(entries, ContactList)
    close = ("gap", "xi", "point", "normal")
    tol = _assert_packed(entries, dense, num_rows, "found", ("segment", "active"), close)
    # Back to N rows, and a scatter-add over the entries drops the padding.
    for field, want in zip(entries.to_contact(num_rows), dense, strict=True):
        np.testing.assert_allclose(field, want, rtol=0, atol=tol)
    summed = jax.ops.segment_sum(entries.gap, entries.node, num_segments=num_rows)
    np.testing.assert_allclose(summed, dense.gap, rtol=0, atol=tol)


@pytest.mark.parametrize("scene_name", ["cutting", "rough die (cells)"])
def test_one_call_compact_packs_the_dense_rows(scene_name):
    if scene_name == "cutting":
        scene = cutting_scene(2_000, 18.0, dtype=FLOAT)
    else:
        scene = rough_die_scene(2_000, 200, dtype=FLOAT)
    num_rows = scene.x.shape[0]
    # Padding rows hold anything (sentinels), and a masked real contact is not found.
    mask = np.ones(num_rows, bool)
    dense = bucket_sort(scene.x, scene.surface, radius=scene.radius)
    mask[np.flatnonzero(np.asarray(dense.found))[:3]] = False
    x = np.asarray(scene.x).copy()
    x[~mask] = np.nan
    dense = bucket_sort(x, scene.surface, radius=scene.radius, mask=mask)
    entries = bucket_sort(x, scene.surface, radius=scene.radius, mask=mask, compact=True)
    assert not bool(entries.overflow)
    assert_packs(entries, dense, num_rows)
    # The capacity is Search(compact=True)'s: the contacts found times the
    # slack, not one entry per slave the cull kept.
    state = Search(radius=scene.radius, compact=True).allocate(x, scene.surface, mask=mask)
    sizes = state.sizes["closest"]
    assert entries.node.shape == (sizes.contact_capacity,)
    assert int(dense.found.sum()) <= sizes.contact_capacity < sizes.slave_capacity


def test_search_compact_in_a_scan_equals_all_to_all_at_every_step():
    xs, nodes, segments = trajectory(FLOAT)
    search = Search(radius=RADIUS, skin=SKIN, compact=True)
    last = search.allocate(xs[-1], surface_at(nodes[-1], segments))
    state = search.allocate(xs[0], surface_at(nodes[0], segments), at_least=last)
    # The capacity is measured from the contacts found, not the slaves kept.
    capacity = state.sizes["closest"].contact_capacity
    assert 0 < capacity < state.sizes["closest"].slave_capacity

    def body(state, step):
        x, at = step
        entries, state = search.closest(state, x, surface_at(at, segments))
        return state, entries

    state, entries = jax.jit(lambda state: jax.lax.scan(body, state, (xs, nodes)))(state)
    assert entries.node.shape == (NUM_STEPS, capacity)
    assert not bool(state.overflow) and 0 < int(state.rebuilds) < NUM_STEPS
    expected = jax.vmap(lambda x, at: all_to_all(x, surface_at(at, segments), radius=RADIUS))(
        xs, nodes
    )
    num_rows = xs.shape[1]
    assert int(expected.found.sum()) > 0
    for k in range(NUM_STEPS):
        got = jax.tree.map(lambda field, k=k: field[k], entries).to_contact(num_rows)
        assert_same_contact(got, jax.tree.map(lambda field, k=k: field[k], expected), RADIUS)


def test_too_few_entries_overflow_and_keep_the_first_contacts():
    scene = cutting_scene(2_000, 18.0, dtype=FLOAT)
    search = Search(radius=scene.radius, compact=True)
    state = search.allocate(scene.x, scene.surface)
    dense = all_to_all(scene.x, scene.surface, radius=scene.radius)
    assert state.sizes["closest"].contact_capacity >= int(dense.found.sum()) > 3
    small = dataclasses.replace(state.sizes["closest"], contact_capacity=3)
    radius = jnp.asarray(scene.radius, scene.x.dtype)
    entries = driver.sized_jit(CLOSEST, (scene.x,), scene.surface, radius, None, sizes=small)
    assert bool(entries.overflow)
    rows = np.flatnonzero(np.asarray(dense.found))[:3]
    np.testing.assert_array_equal(entries.node, rows)
    np.testing.assert_array_equal(entries.segment, dense.segment[rows])
    # The step carries the flag in the state, as for every other capacity.
    starved = dataclasses.replace(state, sizes=QuerySizes({"closest": small}))
    entries, state = search.closest(starved, scene.x, scene.surface)
    assert bool(entries.overflow) and bool(state.overflow)


def test_gradients_through_the_entries_equal_the_dense_ones():
    scene = cutting_scene(2_000, 18.0, dtype=FLOAT)
    search = Search(radius=scene.radius, compact=True)
    state = search.allocate(scene.x, scene.surface)

    def energy(contact):
        return jnp.sum(contact.gap**2) + jnp.sum(contact.point * contact.normal)

    def compact(x, nodes):
        surface = Surface(nodes, scene.surface.segments)
        return energy(search.closest(state, x, surface)[0])

    def dense(x, nodes):
        return energy(all_to_all(x, Surface(nodes, scene.surface.segments), radius=scene.radius))

    args = (scene.x, scene.surface.nodes)
    got = jax.jit(jax.grad(compact, argnums=(0, 1)))(*args)
    want = jax.jit(jax.grad(dense, argnums=(0, 1)))(*args)
    assert float(jnp.abs(want[0]).sum()) > 0
    for g, w in zip(got, want, strict=True):
        assert bool(jnp.all(jnp.isfinite(g)))
        np.testing.assert_allclose(g, w, atol=gradient_atol(FLOAT))


def test_compact_misuse_raises_a_clear_error():
    scene = cutting_scene(2_000, 18.0, dtype=FLOAT)
    with pytest.raises(ValueError, match="compact=True needs a bucket method"):
        Search(radius=RADIUS, method="exhaustive", compact=True)
    with pytest.raises(ValueError, match="compact must be a bool"):
        Search(radius=RADIUS, compact=1)
    dense_state = Search(radius=RADIUS).allocate(scene.x, scene.surface)
    with pytest.raises(ValueError, match="allocated by a N-row search; this one is compact"):
        Search(radius=RADIUS, compact=True).closest(dense_state, scene.x, scene.surface)


def test_slaves_at_the_radius_to_within_rounding_are_found_as_the_dense_form_finds_them():
    # Long segments (the rounding grows with them) and slaves a few ulps either
    # side of the radius, beside the faces and beyond the ends: the compact form
    # assembles every slave the dense form may find, whatever the rounding.
    radius, length = 0.1, 1_000.0
    eps = float(np.finfo(FLOAT).eps)
    nodes = np.array([[0.0, 0.0], [length, 0.0], [length, length]], FLOAT)
    surface = Surface(jnp.asarray(nodes), jnp.asarray([[0, 1], [1, 2]], jnp.int32))
    ulps = np.arange(-40, 41)
    along = np.linspace(1.0, length - 1.0, ulps.size)
    beside = np.stack([along, -radius * (1 + ulps * eps)], axis=-1)  # below the first face
    beyond = np.stack([-radius * (1 + ulps * eps), np.zeros(ulps.size)], axis=-1)  # before a
    x = jnp.asarray(np.concatenate([beside, beyond]), FLOAT)
    dense = bucket_sort(x, surface, radius=radius)
    entries = bucket_sort(x, surface, radius=radius, compact=True)
    found = np.asarray(dense.found)
    assert 0 < found.sum() < found.size  # some in, some out
    np.testing.assert_array_equal(entries.to_contact(x.shape[0]).found, found)
    np.testing.assert_array_equal(entries.node[: found.sum()], np.flatnonzero(found))


def test_the_guides_compact_snippet_gives_the_n_row_forces():
    import pathlib
    import re
    import textwrap

    import jaxcontact

    readme = pathlib.Path(__file__).resolve().parents[2] / "docs" / "guides" / "search.md"
    section = readme.read_text().split("## Sizes, candidates and overflow")[1].split("\n## ")[0]
    (snippet,) = [s for s in re.findall(r"```python\n(.*?)```", section, re.S) if "compact" in s]
    scene = cutting_scene(2_000, 18.0, dtype=FLOAT)  # the programs of the tests above
    namespace = {"jaxcontact": jaxcontact, "jax": jax, "jnp": jnp, "stiffness": 10.0}
    namespace |= {"x": scene.x, "surface": scene.surface}
    exec(compile(textwrap.dedent(snippet), str(readme), "exec"), namespace)
    dense = all_to_all(scene.x, scene.surface, radius=0.1)
    assert int(dense.active.sum()) > 0
    stiffness = namespace["stiffness"]
    want = jnp.where(dense.active, -stiffness * dense.gap, 0)[:, None] * dense.normal
    tol = binned_tolerance(dense.gap.dtype, dense.point) * stiffness
    np.testing.assert_allclose(namespace["nodal"], want, rtol=0, atol=tol)


def test_a_batch_is_allocated_once_and_searched_under_vmap():
    xs, nodes, segments = trajectory(jnp.float32, steps=3, x_tip=19.0)
    surfaces = Surface(nodes, jnp.broadcast_to(segments, (3,) + segments.shape))
    search = Search(radius=RADIUS, skin=SKIN, compact=True)
    state = search.allocate(xs, surfaces)  # one capacity: the largest count of the batch
    entries, state = jax.jit(jax.vmap(search.closest))(state, xs, surfaces)
    dense = jax.vmap(lambda x, s: all_to_all(x, s, radius=RADIUS))(xs, surfaces)
    counts = np.asarray(dense.found.sum(axis=1))
    assert entries.node.shape == (3, state.sizes["closest"].contact_capacity) and counts.min() > 0
    assert state.sizes["closest"].contact_capacity >= counts.max()
    assert not bool(jnp.any(state.overflow))
    for b in range(3):
        got = jax.tree.map(lambda field, b=b: field[b], entries).to_contact(xs.shape[1])
        assert_same_contact(got, jax.tree.map(lambda field, b=b: field[b], dense), RADIUS)


# The compact swept form (``CrossingList``): the crossed rows of the dense
# ``Crossing``, packed, as ``ContactList`` packs the found rows of a ``Contact``.


def assert_packs_crossings(entries: CrossingList, dense, num_rows: int):
    """``entries`` hold exactly the crossed rows of ``dense``, in order, padding after."""
    assert isinstance(entries, CrossingList)
    tol = _assert_packed(entries, dense, num_rows, "crossed", ("segment",), ("t", "point"))
    for field, want in zip(entries.to_crossing(num_rows), dense, strict=True):
        np.testing.assert_allclose(field, want, rtol=0, atol=tol)


def _crossing_scene():
    """The cutting scene with paths from a tool 0.3 further on: some cross the tool.
    Three crossing rows are masked and hold NaN (padding holds anything)."""
    scene = cutting_scene(2_000, 18.0, x_tip_prev=18.3, dtype=FLOAT)
    crossing = swept(scene.x_prev, scene.x, scene.surface)
    mask = np.ones(scene.x.shape[0], bool)
    mask[np.flatnonzero(np.asarray(crossing.crossed))[:3]] = False
    x = np.where(mask[:, None], np.asarray(scene.x), np.nan).astype(scene.x.dtype)
    return scene, x, mask


def test_one_call_compact_swept_packs_the_crossed_rows():
    scene, x, mask = _crossing_scene()
    dense = bucket_swept(scene.x_prev, x, scene.surface, mask=mask)
    assert_same_crossing(dense, swept(scene.x_prev, x, scene.surface, mask=mask))
    entries = bucket_swept(scene.x_prev, x, scene.surface, mask=mask, compact=True)
    assert not bool(entries.overflow)
    assert_packs_crossings(entries, dense, x.shape[0])
    # The capacity is Search(compact=True)'s: the paths crossing times the slack.
    paths = Search(compact=True).allocate(x, scene.surface, x_prev=scene.x_prev, mask=mask)
    sizes = paths.sizes["swept"]
    assert entries.node.shape == (sizes.contact_capacity,)
    assert int(dense.crossed.sum()) <= sizes.contact_capacity < sizes.slave_capacity


def test_search_compact_swept_measures_its_capacity_and_overflows_when_outgrown():
    scene, x, mask = _crossing_scene()
    search = Search(radius=scene.radius, compact=True, method="binned")
    state = search.allocate(x, scene.surface, x_prev=scene.x_prev, mask=mask)
    dense = swept(scene.x_prev, x, scene.surface, mask=mask)
    count = int(dense.crossed.sum())
    # The capacity is measured from the paths that cross, not the paths kept.
    capacity = state.sizes["swept"].contact_capacity
    assert count <= capacity < state.sizes["swept"].slave_capacity
    step = jax.jit(lambda state, x: search.swept(state, scene.x_prev, x, scene.surface, mask=mask))
    entries, after = step(state, x)
    assert not bool(entries.overflow) and not bool(after.overflow)
    assert entries.node.shape == (capacity,)
    assert_same_crossing(entries.to_crossing(x.shape[0]), dense)
    binned = bucket_swept(scene.x_prev, x, scene.surface, mask=mask)  # the same search, dense
    assert_packs_crossings(entries, binned, x.shape[0])
    # Too few entries: the first crossings are kept, and the state says so.
    small = dataclasses.replace(state.sizes["swept"], contact_capacity=3)
    entries, after = search.swept(
        dataclasses.replace(state, sizes=QuerySizes({"swept": small})),
        scene.x_prev,
        x,
        scene.surface,
        mask=mask,
    )
    assert bool(entries.overflow) and bool(after.overflow)
    rows = np.flatnonzero(np.asarray(dense.crossed))[:3]
    np.testing.assert_array_equal(entries.node, rows)
    np.testing.assert_array_equal(entries.segment, dense.segment[rows])
    # A state of the other form is refused, by name; grown from one, a state
    # takes this search's form (the capacity measured, or none).
    dense_search = Search(radius=scene.radius, method="binned")
    dense_state = dense_search.allocate(x, scene.surface, x_prev=scene.x_prev, mask=mask)
    with pytest.raises(ValueError, match="allocated by a N-row search; this one is compact"):
        search.swept(dense_state, scene.x_prev, x, scene.surface)
    grown = search.allocate(x, scene.surface, x_prev=scene.x_prev, mask=mask, at_least=dense_state)
    assert grown.sizes["swept"].contact_capacity == capacity
    back = dense_search.allocate(x, scene.surface, x_prev=scene.x_prev, mask=mask, at_least=state)
    assert back.sizes["swept"].contact_capacity == 0 == back.sizes["closest"].contact_capacity
    # No segments: padding entries only.
    empty = Surface(scene.surface.nodes, np.zeros((0, 2), np.int32))
    nothing = bucket_swept(scene.x_prev, x, empty, mask=mask, compact=True)
    assert not np.asarray(nothing.crossed).any() and not bool(nothing.overflow)
    assert (np.asarray(nothing.node) == x.shape[0]).all()


def test_a_batch_measures_the_compact_swept_capacity_and_searches_under_vmap():
    scene = cutting_scene(2_000, 18.0, x_tip_prev=18.3, dtype=FLOAT)
    x_prevs = jnp.stack([scene.x_prev, scene.x])  # the second scene does not move: no crossing
    xs = jnp.stack([scene.x, scene.x])
    search = Search(compact=True, method="binned")  # paths only
    state = search.allocate(xs, scene.surface, x_prev=x_prevs)
    count = int(swept(scene.x_prev, scene.x, scene.surface).crossed.sum())
    assert count <= state.sizes["swept"].contact_capacity < state.sizes["swept"].slave_capacity
    entries, _ = jax.jit(jax.vmap(search.swept, (0, 0, 0, None)))(state, x_prevs, xs, scene.surface)
    assert not np.asarray(entries.overflow).any()
    for k in range(2):
        got = jax.tree.map(lambda field, k=k: field[k], entries).to_crossing(xs.shape[1])
        assert_same_crossing(got, swept(x_prevs[k], xs[k], scene.surface))
    assert int(entries.crossed[0].sum()) == count > 0 == int(entries.crossed[1].sum())
