"""``Search``: at every step of a moving, deforming scene, what ``all_to_all`` and ``swept`` return.

One scene shape (the cutting scene at 2,000 nodes, its tool moving in -x into
the workpiece while the workpiece deforms) serves every test, so that the
compiled programs are shared.
"""

import copy
import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import (
    QuerySizes,
    Search,
    SearchState,
    Sizes,
    Surface,
    all_to_all,
    bucket_sort,
    check_overflow,
    swept,
)
from jaxcontact.scenes import cutting_scene
from tests.support.helpers import FLOAT, assert_same_contact, assert_same_crossing, gradient_atol

RADIUS, SKIN = 0.1, 0.05
TOOL_STEP = 0.02  # the tool's travel per step; with the workpiece's motion, about half the skin
NUM_STEPS = 12


def trajectory(dtype, steps=NUM_STEPS, x_tip=20.25, tool_step=TOOL_STEP):
    """Slaves and tool at each step: the tool starts clear of the workpiece and
    moves in; the workpiece bends a little more each step. f[T, N, 2], f[T, P, 2]."""
    scene = cutting_scene(2_000, x_tip, dtype=dtype)
    x0 = np.asarray(scene.x, np.float64)
    wave = np.stack([np.sin(3 * x0[:, 1]), np.cos(2 * x0[:, 0])], axis=-1)
    k = np.arange(steps)[:, None, None]
    xs = x0[None] + 0.004 * k * wave[None]
    nodes = np.asarray(scene.surface.nodes, np.float64)[None] - tool_step * k * np.array([1.0, 0])
    return jnp.asarray(xs, dtype), jnp.asarray(nodes, dtype), scene.surface.segments


def surface_at(nodes, segments):
    return Surface(nodes, segments)


def roomy(search):
    """The same search with slack: sizes grown after an overflow last the rest
    of the trajectory, so that each test compiles its step twice, not once
    per overflow (a state serves any search of the same reach)."""
    return dataclasses.replace(search, slack=3.0)


@pytest.mark.parametrize("method, skin", [("auto", SKIN), ("binned", SKIN), ("auto", 0.0)])
def test_closest_equals_all_to_all_at_every_step_and_outgrown_sizes_say_so(method, skin):
    xs, nodes, segments = trajectory(jnp.float32)
    # Sizes measured with the tool clear of the workpiece and no slack: the
    # tool moving in outgrows them.
    search = Search(radius=RADIUS, skin=skin, method=method, slack=1.0)
    with pytest.warns(UserWarning, match="hold no contact"):
        state = search.allocate(xs[0], surface_at(nodes[0], segments))
    assert state.sizes["closest"].use_cells == (method == "binned")
    step = jax.jit(search.closest)
    overflows = 0
    for x, at in zip(xs, nodes, strict=True):
        surface = surface_at(at, segments)
        contact, next_state = step(state, x, surface)
        if contact.overflow:
            overflows += 1
            assert bool(next_state.overflow)  # the state keeps the flag
            state = roomy(search).allocate(x, surface, at_least=state)
            assert not bool(state.overflow)
            contact, next_state = step(state, x, surface)
        assert_same_contact(contact, all_to_all(x, surface, radius=RADIUS), RADIUS)
        state = next_state
    assert overflows >= 1
    assert not bool(state.overflow)
    if skin:
        assert 0 < int(state.rebuilds) < NUM_STEPS  # candidates found again, and reused
    else:  # no skin: the whole search at every step
        assert state.candidates is None and int(state.rebuilds) == 0


@pytest.mark.x64_off
def test_closest_in_a_scan_under_jit_equals_all_to_all_at_every_step():
    xs, nodes, segments = trajectory(FLOAT)
    search = Search(radius=RADIUS, skin=SKIN, method="binned")
    # Sized ahead of need for the whole run: the last step, then the first.
    last = search.allocate(xs[-1], surface_at(nodes[-1], segments))
    state = search.allocate(xs[0], surface_at(nodes[0], segments), at_least=last)
    assert state.sizes["closest"].block_capacity >= last.sizes["closest"].block_capacity

    def body(state, step):
        x, at = step
        contact, state = search.closest(state, x, surface_at(at, segments))
        return state, contact

    state, contacts = jax.jit(lambda state: jax.lax.scan(body, state, (xs, nodes)))(state)
    assert not bool(state.overflow)
    assert 0 < int(state.rebuilds) < NUM_STEPS
    dense = jax.vmap(lambda x, at: all_to_all(x, surface_at(at, segments), radius=RADIUS))
    expected = dense(xs, nodes)
    assert int(expected.found.sum()) > 0
    for k in range(NUM_STEPS):
        step = jax.tree.map(lambda field, k=k: field[k], (contacts, expected))
        assert_same_contact(*step, RADIUS)


def test_swept_equals_swept_at_every_step_and_outgrown_sizes_say_so():
    xs, nodes, segments = trajectory(jnp.float32, x_tip=20.05, tool_step=0.05)
    # Paths as the tool sees them: each node comes from a tool step behind.
    search = Search(radius=RADIUS, skin=SKIN, slack=1.0)
    x_prev = xs.at[..., 0].add(-0.05)
    state = search.allocate(xs[0], surface_at(nodes[0], segments), x_prev=x_prev[0])
    step = jax.jit(search.swept)
    overflows = crossed = 0
    for before, x, at in zip(x_prev, xs, nodes, strict=True):
        surface = surface_at(at, segments)
        crossing, next_state = step(state, before, x, surface)
        if crossing.overflow:
            overflows += 1
            state = roomy(search).allocate(x, surface, x_prev=before, at_least=state)
            crossing, next_state = step(state, before, x, surface)
        expected = swept(before, x, surface)
        assert_same_crossing(crossing, expected)
        crossed += int(expected.crossed.sum())
        state = next_state
    assert overflows >= 1 and crossed > 0


def test_closest_under_vmap_one_allocation_for_the_batch():
    xs, nodes, segments = trajectory(jnp.float32, steps=3, x_tip=19.0)
    surfaces = Surface(nodes, jnp.broadcast_to(segments, (3,) + segments.shape))
    search = Search(radius=RADIUS, skin=SKIN, method="binned")
    state = search.allocate(xs, surfaces)
    assert state.overflow.shape == (3,)
    step = jax.jit(jax.vmap(search.closest))
    dense = jax.vmap(lambda x, s: all_to_all(x, s, radius=RADIUS))
    for shift in (0.0, 0.03, 0.2):  # reused, reused, found again
        moved = xs.at[..., 0].add(shift)
        contacts, state = step(state, moved, surfaces)
        expected = dense(moved, surfaces)
        for b in range(3):
            one = jax.tree.map(lambda field, b=b: field[b], (contacts, expected))
            assert_same_contact(*one, RADIUS)
    np.testing.assert_array_equal(state.rebuilds, [1, 1, 1])


def test_gradients_equal_all_to_all():  # x64 off: tests/core/test_grad.py's gradients
    xs, nodes, segments = trajectory(FLOAT, steps=4, x_tip=19.0)
    search = Search(radius=RADIUS, skin=SKIN, method="binned")
    state = search.allocate(xs[0], surface_at(nodes[0], segments))

    def objective(detect):
        def total(x, at):
            contact = detect(x, surface_at(at, segments))
            return jnp.sum(contact.gap**2) + jnp.sum(contact.point * contact.normal)

        return jax.jit(jax.grad(total, argnums=(0, 1)))

    searched = objective(lambda x, s: search.closest(state, x, s)[0])
    dense = objective(lambda x, s: all_to_all(x, s, radius=RADIUS))
    for k in (0, 3):  # candidates reused, then found again inside the gradient
        got, want = searched(xs[k], nodes[k]), dense(xs[k], nodes[k])
        assert float(jnp.abs(want[0]).sum()) > 0
        for g, w in zip(got, want, strict=True):
            assert bool(jnp.all(jnp.isfinite(g)))
            np.testing.assert_allclose(g, w, atol=gradient_atol(FLOAT))


def test_stale_candidates_are_found_again_never_used():
    scene = cutting_scene(2_000, 18.0)
    search = Search(radius=RADIUS, skin=SKIN, method="binned")
    step = jax.jit(search.closest)

    def check(state, x, surface, mask=None, *, rebuilt):
        contact, after = step(state, x, surface, mask=mask)
        assert int(after.rebuilds) == int(state.rebuilds) + rebuilt
        assert_same_contact(contact, all_to_all(x, surface, radius=RADIUS, mask=mask), RADIUS)
        return after

    state = search.allocate(scene.x, scene.surface)
    # The skin rule: slaves and tool together moved less, then more, than the skin.
    check(state, scene.x.at[:, 0].add(0.03), scene.surface, rebuilt=0)
    tool = scene.surface._replace(nodes=scene.surface.nodes.at[:, 0].add(-0.03))
    check(state, scene.x.at[:, 0].add(0.03), tool, rebuilt=1)
    # Rows masked (or NaN) when found, real now: never looked at, so found
    # again. (Every state here is allocated at_least the first one: the same
    # sizes, so that the step compiles once per argument structure.)
    near = np.asarray(all_to_all(scene.x, scene.surface, radius=RADIUS).found)
    hidden = search.allocate(scene.x, scene.surface, mask=jnp.asarray(~near), at_least=state)
    check(hidden, scene.x, scene.surface, rebuilt=1)
    check(hidden, scene.x, scene.surface, mask=jnp.asarray(~near), rebuilt=0)
    nan = scene.x.at[np.flatnonzero(near)].set(jnp.nan)
    check(search.allocate(nan, scene.surface, at_least=state), scene.x, scene.surface, rebuilt=1)
    # A move so large its square overflows float32 is a move, not none.
    far = scene.x.at[0].set(jnp.asarray([3e19, 0.0], scene.x.dtype))
    check(state, far, scene.surface, rebuilt=1)
    # A segment joined to other nodes (same node count): found again.
    rejoined = scene.surface._replace(segments=jnp.roll(scene.surface.segments, 1, axis=0))
    check(state, scene.x, rejoined, rebuilt=1)
    # Padding may hold anything and change at every step: masked rows moving
    # far and a masked segment joined to other nodes do not expire the candidates.
    rows = np.arange(scene.x.shape[0]) % 5 == 0
    mask = jnp.asarray(~rows)
    masked = scene.surface._replace(mask=jnp.arange(20) != 7)
    padded = search.allocate(scene.x, masked, mask=mask, at_least=state)
    for garbage, ends in ((5.0, [0, 0]), (-40.0, [3, 12]), (jnp.nan, [19, 2])):
        x = jnp.where(jnp.asarray(rows)[:, None], garbage, scene.x)
        segments = masked.segments.at[7].set(jnp.asarray(ends, jnp.int32))
        padded = check(padded, x, masked._replace(segments=segments), mask, rebuilt=0)


def test_exhaustive_method_is_all_to_all_and_swept_without_sizes():
    scene = cutting_scene(2_000, 18.0, x_tip_prev=18.2)
    search = Search(radius=RADIUS, method="exhaustive")
    state = search.allocate(scene.x, scene.surface, x_prev=scene.x_prev)
    assert state.sizes == {}
    contact, _ = search.closest(state, scene.x, scene.surface)
    expected = all_to_all(scene.x, scene.surface, radius=RADIUS)
    for field, value in zip(expected._fields, expected, strict=True):
        np.testing.assert_array_equal(getattr(contact, field), value, err_msg=field)
    crossing, _ = search.swept(state, scene.x_prev, scene.x, scene.surface)
    np.testing.assert_array_equal(crossing.t, swept(scene.x_prev, scene.x, scene.surface).t)


def test_state_is_a_pytree_with_static_sizes():
    scene = cutting_scene(2_000, 18.0)
    search = Search(radius=RADIUS, skin=SKIN)
    state = search.allocate(scene.x, scene.surface)
    leaves, tree = jax.tree.flatten(state)
    rebuilt = jax.tree.unflatten(tree, leaves)
    assert isinstance(rebuilt, SearchState) and rebuilt.sizes == state.sizes
    # Static: the sizes are the pytree's structure, not its leaves. Equal
    # sizes give the same structure (one program), other sizes another
    # (compiled anew), and a jitted function sees them as Python values.
    assert not any(isinstance(leaf, (Sizes, int)) for leaf in leaves)
    sizes = state.sizes["closest"]
    same = dataclasses.replace(state, sizes=QuerySizes({"closest": dataclasses.replace(sizes)}))
    assert jax.tree.structure(same) == tree
    more = dataclasses.replace(sizes, block_capacity=sizes.block_capacity + 1)
    grown = dataclasses.replace(state, sizes=QuerySizes({"closest": more}))
    assert jax.tree.structure(grown) != tree

    @jax.jit
    def capacity(state):
        assert isinstance(state.sizes["closest"].block_capacity, int)  # not traced
        return jnp.zeros(state.sizes["closest"].slave_capacity)

    assert capacity(state).shape == (sizes.slave_capacity,)
    assert hash(search) == hash(Search(radius=RADIUS, skin=SKIN))


def test_sizes_by_query_are_a_read_only_hashable_mapping():
    sizes = Sizes(num_slaves=10, block_size=4, block_capacity=2)
    paths = dataclasses.replace(sizes, for_paths=True)
    mapped = QuerySizes({"swept": paths, "closest": sizes})
    assert mapped == {"closest": sizes, "swept": paths} and list(mapped) == ["closest", "swept"]
    assert hash(mapped) == hash(QuerySizes(dict(mapped))) and mapped["swept"] is paths
    assert copy.deepcopy(mapped) == mapped and QuerySizes() == {} == QuerySizes(None)
    with pytest.raises(AttributeError, match="read-only"):
        mapped.extra = 1
    with pytest.raises(KeyError):
        mapped["nearest node"]
    with pytest.raises(ValueError, match="sizes must map a query's name to its Sizes"):
        QuerySizes({"closest": 3})


@pytest.mark.x64_off
@pytest.mark.parametrize(
    "settings, message",
    [
        ({"radius": -1.0}, "radius must be finite and >= 0"),
        ({"radius": 0.1, "skin": float("nan")}, "skin must be finite"),
        ({"radius": 0.1, "method": "fast"}, "method must be one of"),
        ({"radius": 0.1, "slack": 0.5}, "slack must be finite and >= 1"),
        ({"radius": 0.1, "block_size": 0}, "block_size must be an int >= 1"),
    ],
)
def test_bad_settings_raise_naming_the_setting(settings, message):
    with pytest.raises(ValueError, match=message):
        Search(**settings)


@pytest.mark.x64_off
def test_misuse_raises_a_clear_error():
    scene = cutting_scene(2_000, 18.0, x_tip_prev=18.2)
    search = Search(radius=RADIUS, skin=SKIN)
    state = search.allocate(scene.x, scene.surface)
    with pytest.raises(ValueError, match="sizes were made for 2002 slaves; x has 1000 rows"):
        search.closest(state, scene.x[:1000], scene.surface)
    with pytest.raises(ValueError, match="allocate it with x_prev="):
        search.swept(state, scene.x_prev, scene.x, scene.surface)
    with pytest.raises(ValueError, match="x must have shape"):
        search.closest(state, scene.x[:, :1], scene.surface)
    with pytest.raises(ValueError, match="concrete data"):
        jax.jit(lambda x: search.allocate(x, scene.surface))(scene.x)
    with pytest.raises(ValueError, match="concrete data.*Search"):
        jax.jit(lambda x: bucket_sort(x, scene.surface, radius=RADIUS))(scene.x)
    with pytest.raises(ValueError, match="x_prev= for a Search without a radius"):
        Search().allocate(scene.x, scene.surface)
    with pytest.raises(ValueError, match="searches paths only"):
        Search().closest(state, scene.x, scene.surface)


def test_a_state_is_refused_by_a_search_or_shapes_it_was_not_allocated_for():
    scene = cutting_scene(2_000, 18.0)
    search = Search(radius=RADIUS, skin=SKIN, method="binned")
    state = search.allocate(scene.x, scene.surface)
    wider = Search(radius=0.5, skin=SKIN, method="binned")
    with pytest.raises(ValueError, match="reaching radius \\+ skin = 0.15; this one reaches 0.55"):
        wider.closest(state, scene.x, scene.surface)
    _, stepped = search.closest(state, scene.x, scene.surface)  # a stepped state remembers too
    with pytest.raises(ValueError, match="reaching radius"):
        wider.closest(stepped, scene.x, scene.surface)
    fewer = Surface(scene.surface.nodes, scene.surface.segments[:-1])
    with pytest.raises(
        ValueError, match=r"surface.segments must have the allocated shape \(20, 2\)"
    ):
        search.closest(state, scene.x, fewer)
    more = Surface(jnp.concatenate([scene.surface.nodes, scene.surface.nodes[:1]]), fewer.segments)
    with pytest.raises(ValueError, match="surface.nodes must have the allocated shape"):
        search.closest(state, scene.x, more._replace(segments=scene.surface.segments))
    batch = search.allocate(jnp.stack([scene.x, scene.x]), scene.surface)
    with pytest.raises(
        ValueError, match="batch of 2 scenes: map closest over it with jax.vmap, over the state's"
    ):
        search.closest(batch, scene.x, scene.surface)
    plain = Search(radius=RADIUS)  # no candidates kept: the batch is seen all the same
    with pytest.raises(ValueError, match="batch of 2 scenes: map closest over it"):
        plain.closest(
            plain.allocate(jnp.stack([scene.x, scene.x]), scene.surface), scene.x, scene.surface
        )
    with pytest.raises(ValueError, match=r"at_least must be a SearchState or its sizes \(state"):
        search.allocate(scene.x, scene.surface, at_least=3)
    with pytest.raises(ValueError, match="init with closest sizes needs a Search with a radius"):
        Search(skin=SKIN).init(scene.x, scene.surface, sizes=state.sizes)


@pytest.mark.x64
def test_a_state_is_refused_for_another_float_dtype():
    scene = cutting_scene(2_000, 18.0)
    search = Search(radius=RADIUS, skin=SKIN, method="binned")
    state = search.allocate(scene.x, scene.surface)
    doubled = jax.tree.map(lambda v: v.astype(jnp.float64), (scene.x, scene.surface.nodes))
    with pytest.raises(ValueError, match="x must have the allocated shape .* dtype float32"):
        search.closest(state, doubled[0], scene.surface._replace(nodes=doubled[1]))


def test_settings_are_plain_numbers_and_a_batch_may_share_its_mask_and_segments():
    search = Search(radius=jnp.float32(0.1), skin=np.float64(0.05), block_size=np.int64(64))
    same = Search(radius=float(np.float32(0.1)), skin=0.05)
    assert search == same and hash(search) == hash(same) and type(search.radius) is float
    for bad in ({"cells_above": -1}, {"slack": float("inf")}, {"block_size": 2.5}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            Search(radius=0.1, **bad)
    xs, nodes, segments = trajectory(jnp.float32, steps=2, x_tip=19.0)
    mask = jnp.arange(xs.shape[1]) % 3 != 0
    state = search.allocate(xs, Surface(nodes, segments), mask=mask)
    step = jax.vmap(lambda state, x, surface: search.closest(state, x, surface, mask=mask))
    contacts, _ = step(state, xs, Surface(nodes, jnp.stack([segments, segments])))
    for b in range(2):
        expected = all_to_all(xs[b], Surface(nodes[b], segments), radius=0.1, mask=mask)
        assert_same_contact(jax.tree.map(lambda v, b=b: v[b], contacts), expected, 0.1)


def test_a_radius_past_the_search_bound_says_so_unless_no_row_is_real():
    # The sizes hold contacts within Search.radius: a larger radius at a step may
    # miss one, which overflow says, for a scalar radius and one per slave alike; a
    # scene with no real row misses nothing.
    xs, nodes, segments = trajectory(jnp.float32, steps=1)
    x, surface = xs[0], surface_at(nodes[0], segments)
    search = Search(radius=RADIUS)
    with pytest.warns(UserWarning, match="hold no contact"):  # the tool is clear
        state = search.allocate(x, surface)

    def closest(state, x, radius, mask):
        return search.closest(state, x, surface, radius=radius, mask=mask)

    step = jax.jit(closest)
    real, none = jnp.ones(x.shape[0], bool), jnp.zeros(x.shape[0], bool)
    per_slave = jnp.full(x.shape[0], RADIUS / 2, x.dtype).at[7].set(2 * RADIUS)
    for radius, mask, flagged in [
        (RADIUS / 2, real, False),
        (RADIUS, real, False),
        (2 * RADIUS, real, True),
        (2 * RADIUS, none, False),
        (per_slave, real, True),
        (per_slave, real.at[7].set(False), False),
    ]:
        contact, _ = step(state, x, jnp.asarray(radius, x.dtype), mask)
        assert bool(contact.overflow) == flagged, (radius, flagged)


def _floor_and_chain(height: float):
    """A wavy floor of 40 segments (listed right to left: normals up) and a chain of 200
    slaves at ``height`` above it."""
    along = np.linspace(1.0, -1.0, 41)
    nodes = np.stack([along, 0.05 * np.sin(5 * along)], -1).astype(FLOAT)
    floor = Surface(jnp.asarray(nodes), jnp.stack([jnp.arange(40), jnp.arange(1, 41)], -1))
    chain = np.stack([np.linspace(-0.9, 0.9, 200), np.full(200, height)], -1).astype(FLOAT)
    return floor, jnp.asarray(chain)


def test_allocate_warns_when_no_slave_is_near_the_master():
    """Sizes measured before contact hold none: ``allocate`` says so, for either query,
    and is silent once a slave is within reach, with ``at_least``, and exhaustively."""
    floor, high = _floor_and_chain(2.0)
    _, low = _floor_and_chain(0.06)
    search = Search(radius=RADIUS)
    with pytest.warns(UserWarning, match="no slave comes within the reach 0.1 of the master's"):
        far = search.allocate(high, floor)
    with pytest.warns(UserWarning, match="no slave path comes"):
        Search(radius=None).allocate(high, floor, x_prev=high + 0.1)
    # What it warns of: once the chain reaches the floor the state overflows, and
    # contacts are missing.
    fallen, far = search.closest(far, low, floor)
    assert bool(far.overflow)
    assert int(fallen.found.sum()) < int(all_to_all(low, floor, radius=RADIUS).found.sum())
    near = search.allocate(low, floor)  # filterwarnings = error: any warning fails here
    search.allocate(high, floor, at_least=near)
    Search(radius=RADIUS, method="exhaustive").allocate(high, floor)
    masked = jnp.zeros(200, bool).at[0].set(True)
    with pytest.warns(UserWarning, match="no slave comes"):
        search.allocate(low.at[0].set(high[0]), floor, mask=masked)
    # A batch's sizes are the largest of its scenes': it warns only when no scene is near.
    with pytest.warns(UserWarning, match="no slave comes within the reach"):
        search.allocate(jnp.stack([high, high + 1.0]), floor)
    search.allocate(jnp.stack([high, low]), floor)


def test_check_overflow_is_silent_until_a_state_overflows_then_raises_saying_what_to_do():
    """``check_overflow``: the run's one check on the host, over any pytree of states."""
    floor, high = _floor_and_chain(2.0)
    _, low = _floor_and_chain(0.06)
    search = Search(radius=RADIUS)
    with pytest.warns(UserWarning, match="hold no contact"):
        state = search.allocate(high, floor)
    assert check_overflow(state) is None
    assert check_overflow({"carry": (state, jnp.zeros(3))}) is None
    # The chain falls onto the floor: the sizes measured before contact overflow,
    # and the flag stays set through a later step that fits.
    _, fallen = search.closest(state, low, floor)
    _, after = search.closest(fallen, high, floor)
    assert bool(after.overflow)
    message = r"1 of 2 search state\(s\) overflowed.*at_least=state.*resumable_scan"
    with pytest.raises(RuntimeError, match=message):
        check_overflow((state, {"later": after}))
    with pytest.raises(RuntimeError, match="1 of 1 search state"):
        check_overflow(fallen)
    with pytest.raises(ValueError, match="carry holds no jaxcontact SearchState"):
        check_overflow((jnp.zeros(3), 1.0))
