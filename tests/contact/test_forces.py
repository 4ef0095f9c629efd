"""``jaxcontact.forces``: the normal penalty and Coulomb friction, on slaves and master nodes.

Analytic checks: a rigid block on an incline sticks below ``tan(theta) = mu``
and slides above it with ``a = g (sin(theta) - mu cos(theta))``; friction
never adds energy over a random run; the force of a sliding block does not
depend on how the master is split into segments; two deformable bodies
searched both ways count each contact once with ``two_pass``; gradients of
a frictional penalty energy equal finite differences.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from jaxcontact import (
    ContactList,
    Pairs,
    Search,
    Smooth,
    Surface,
    all_to_all,
    bucket_sort,
    track,
)
from jaxcontact.forces import Forces, Friction, coulomb, penalty
from tests.support.helpers import FLOAT
from tests.support.tolerances import (
    DISSIPATION_SLACK,
    FD_SMOOTH_ATOL,
    FD_SMOOTH_RTOL,
    FD_STEP,
    FLOAT32_ATOL,
    FLOAT32_RTOL,
    FLOAT32_SUM_ATOL,
    FLOAT32_SUM_RTOL,
    FLOAT64_RTOL,
    FLOAT64_STEPS_RTOL,
    FORCE_ATOL,
    STICK_FRICTION_RTOL,
)

# The incline, SI units: a rigid block of 1 kg on three contact nodes 0.25 m
# apart, normal and stick stiffness 1e4 N/m per node, g = 9.81 m/s^2.
GRAVITY = 9.81
MASS = 1.0
K_N = K_T = 1.0e4
DT = 1.0e-3
STEPS = 1000
OFFSETS = np.array([-0.25, 0.0, 0.25])
# Master nodes at these arc lengths along the incline: one segment, or seven.
ARCS = np.array([-3.0, -2.1, -1.3, -0.2, 0.05, 0.9, 2.2, 3.0])


def incline(theta, split: bool):
    """The incline as a surface of 8 nodes and 7 segments (or one, the rest masked).

    Segments run down the slope, so their outward normal points up from it.
    """
    up = jnp.stack([jnp.cos(theta), jnp.sin(theta)])
    nodes = jnp.asarray(ARCS)[:, None] * up[None, :]
    if split:
        segments, mask = np.stack([np.arange(1, 8), np.arange(7)], -1), np.ones(7, bool)
    else:
        segments = np.array([[7, 0]] + [[-1, -1]] * 6)
        mask = np.arange(7) == 0
    return Surface(nodes, jnp.asarray(segments, jnp.int32), jnp.asarray(mask))


@functools.partial(jax.jit, static_argnames="split")
def slide(theta, mu, split: bool = False):
    """Positions along the slope (m) and the friction force on the block (N), per step."""
    surface = incline(theta, split)
    up = jnp.stack([jnp.cos(theta), jnp.sin(theta)])
    normal = jnp.stack([-jnp.sin(theta), jnp.cos(theta)])
    # Start at rest, at the normal penalty's equilibrium depth.
    depth = MASS * GRAVITY * jnp.cos(theta) / (3 * K_N)
    start = -depth * normal
    search = Search(radius=0.05, method="exhaustive", track=True)
    offsets = jnp.asarray(OFFSETS)[:, None] * up[None, :]
    state = search.init(jnp.zeros((3, 2)), surface, sizes=None)  # inside jit: no allocate
    # The block rests on the incline before the first step: its contact is history.
    _, state = search.closest(state, start[None, :] + offsets, surface)

    def step(carry, _):
        centre, velocity, state, friction = carry
        x = centre[None, :] + offsets
        contact, state = search.closest(state, x, surface)
        forces, friction = coulomb(
            contact, state.slip, friction, surface, stiffness=K_N, tangent_stiffness=K_T, mu=mu
        )
        total = forces.on_slaves.sum(0) + jnp.array([0.0, -MASS * GRAVITY])
        velocity = velocity + DT * total / MASS
        return (centre + DT * velocity, velocity, state, friction), (
            jnp.dot(centre - start, up),
            jnp.dot(friction.traction.sum(0), up),
        )

    carry = (start, jnp.zeros(2), state, Friction.zeros(3, start.dtype))
    return jax.lax.scan(step, carry, None, length=STEPS)[1]


@pytest.mark.x64
def test_a_block_sticks_below_the_friction_angle_and_slides_above_it():
    mu = 0.3  # tan(theta) = mu at 16.7 degrees
    thetas = jnp.radians(jnp.array([10.0, 25.0]))
    travel, friction = jax.vmap(slide, in_axes=(0, None))(thetas, mu)
    # Sticking: the stick springs stretch by m g sin(theta) / (3 K_T) ~ 6e-5 m, overshoot
    # to twice that.
    stretch = MASS * GRAVITY * np.sin(np.radians(10.0)) / (3 * K_T)
    assert np.abs(np.asarray(travel[0])).max() < 2.5 * stretch
    # The undamped stick springs oscillate about the static friction m g sin(theta).
    np.testing.assert_allclose(
        float(friction[0].mean()), MASS * GRAVITY * np.sin(thetas[0]), rtol=STICK_FRICTION_RTOL
    )
    # Sliding: once the stick springs have loaded (a few steps), the block accelerates
    # down the slope at a = g (sin(theta) - mu cos(theta)), friction at its cap mu m g cos(theta).
    accel = GRAVITY * (np.sin(np.radians(25.0)) - mu * np.cos(np.radians(25.0)))
    measured = np.diff(np.asarray(travel[1]), 2) / DT**2
    np.testing.assert_allclose(measured[20:], -accel, rtol=FLOAT32_RTOL)
    assert float(travel[1, -1]) < -0.5 * accel * (STEPS * DT) ** 2 * 0.95
    np.testing.assert_allclose(
        np.asarray(friction[1, 20:]),
        mu * MASS * GRAVITY * np.cos(np.radians(25.0)),
        rtol=FLOAT32_RTOL,
    )


@pytest.mark.x64
def test_a_sliding_block_does_not_depend_on_how_the_master_is_split():
    theta, mu = jnp.radians(25.0), 0.3
    whole = slide(theta, mu, split=False)
    split = slide(theta, mu, split=True)
    assert float(whole[0][-1]) < -0.5  # it slid across several of the split's vertices
    np.testing.assert_allclose(
        np.asarray(split[0]), np.asarray(whole[0]), rtol=FLOAT64_STEPS_RTOL, atol=FLOAT64_RTOL
    )
    np.testing.assert_allclose(
        np.asarray(split[1]), np.asarray(whole[1]), rtol=FLOAT64_STEPS_RTOL, atol=FORCE_ATOL
    )


def wavy_master(dtype, shift):
    """A wavy floor of 10 segments (right to left: normals up), nudged by ``shift``."""
    s = np.linspace(0.0, 3.0, 11)
    nodes = np.stack([s, 0.1 * np.sin(3 * s)], -1) + shift
    segments = np.stack([np.arange(1, 11), np.arange(10)], -1).astype(np.int32)
    return Surface(jnp.asarray(nodes, dtype), jnp.asarray(segments))


def test_friction_never_adds_energy_over_a_random_run():
    rng = np.random.default_rng(1)
    dtype = FLOAT
    k_n, k_t, mu = 100.0, 50.0, 0.4
    search = Search(radius=0.2, method="unbinned", track=True)
    along = rng.uniform(0.3, 2.7, 6)
    x = np.stack([along, 0.1 * np.sin(3 * along) - 0.01], -1)
    state = search.allocate(jnp.asarray(x, dtype), wavy_master(dtype, 0.0))
    friction = Friction.zeros(6, dtype)
    step = jax.jit(search.closest)
    total, slid, stuck, slipping = 0.0, 0.0, 0, 0
    for _ in range(40):
        along = np.clip(along + rng.normal(0, 0.05, 6), 0.3, 2.7)
        x = np.stack([along, 0.1 * np.sin(3 * along) - rng.uniform(-0.005, 0.02, 6)], -1)
        surface = wavy_master(dtype, rng.normal(0, 0.01, (11, 2)))
        contact, state = step(state, jnp.asarray(x, dtype), surface)
        slip = state.slip
        last = np.asarray(friction.traction, np.float64)
        forces, friction = coulomb(
            contact, slip, friction, surface, stiffness=k_n, tangent_stiffness=k_t, mu=mu
        )
        # Independently: the work friction took from the slip, less the change in stored energy.
        normal = np.asarray(contact.normal, np.float64)
        tangent = np.stack([-normal[:, 1], normal[:, 0]], -1)
        traction = np.asarray(friction.traction, np.float64)
        f_t = np.sum(traction * tangent, -1)
        stored = (np.sum(traction**2, -1) - np.sum(last**2, -1)) / (2 * k_t)
        persisted = np.asarray(slip.persisted)
        dissipated = np.where(persisted, -f_t * np.asarray(slip.slip) - stored, 0)
        assert dissipated.min() >= -DISSIPATION_SLACK * k_t * 0.05**2, dissipated
        # What sliding dissipated: none while sticking, at most the total.
        sliding = np.asarray(friction.dissipated, np.float64)
        is_stuck = np.asarray(friction.stuck)
        assert sliding.min() >= 0 and not sliding[is_stuck].any()
        assert (sliding[persisted] <= dissipated[persisted] + 1e-5).all()
        total += dissipated.sum()
        stuck += int((persisted & is_stuck).sum())
        slipping += int((persisted & ~is_stuck).sum())
        slid += sliding.sum()
    assert total > 0 and slid > 0 and stuck > 0 and slipping > 0  # both regimes exercised


def two_blocks(dtype, depth=0.01):
    """The facing sides of two deformable blocks, every node a slave.

    The upper block's bottom (nodes 0-4, body 0, segments left to right:
    normals down) sits ``depth`` into the lower block's top (nodes 5-9,
    body 1, right to left: normals up).
    """
    xs = np.linspace(0.0, 1.0, 5)
    nodes = np.concatenate([np.stack([xs, -depth + 0 * xs], -1), np.stack([xs, 0 * xs], -1)])
    segments = np.concatenate(
        [
            np.stack([np.arange(4), np.arange(1, 5)], -1),
            5 + np.stack([np.arange(1, 5), np.arange(4)], -1),
        ]
    ).astype(np.int32)
    body = np.repeat(np.int32([0, 1]), 4)
    surface = Surface(jnp.asarray(nodes, dtype), jnp.asarray(segments), body=jnp.asarray(body))
    return surface, np.arange(10, dtype=np.int32), np.repeat(np.int32([0, 1]), 5)


def test_two_pass_counts_each_contact_once_and_balances():
    depth, k = 0.01, 100.0
    surface, slave_node, slave_body = two_blocks(FLOAT, depth)
    keywords = dict(radius=0.05, pairs=Pairs(slave_node, slave_body))
    contact = all_to_all(surface.nodes, surface, **keywords)
    assert bool(contact.active.all())  # both passes find every node
    forces = penalty(contact, surface, k, two_pass=True)
    nodal = np.asarray(forces.on_slaves + forces.on_master)  # slaves are the master's nodes
    upper, lower = nodal[:5].sum(0), nodal[5:].sum(0)
    np.testing.assert_allclose(upper, -lower, atol=FLOAT32_ATOL)
    # One pass (the upper block's nodes against the lower block) gives the same total.
    one = all_to_all(
        surface.nodes[:5], surface._replace(body=None, mask=np.arange(8) >= 4), radius=0.05
    )
    np.testing.assert_allclose(
        upper, np.asarray(penalty(one, surface, k).on_slaves.sum(0)), rtol=FLOAT32_SUM_RTOL
    )
    np.testing.assert_allclose(upper, [0.0, 5 * k * depth], rtol=FLOAT32_SUM_RTOL, atol=FORCE_ATOL)
    # Without two_pass every contact counts twice.
    twice = penalty(contact, surface, k)
    np.testing.assert_allclose(
        np.asarray(twice.on_slaves + twice.on_master)[:5].sum(0), 2 * upper, rtol=FLOAT32_SUM_RTOL
    )
    # The compact form gives the same forces.
    entries = bucket_sort(surface.nodes, surface, compact=True, **keywords)
    assert isinstance(entries, ContactList)
    compact = penalty(entries, surface, k, num_slaves=10, two_pass=True)
    np.testing.assert_allclose(
        np.asarray(compact.on_slaves), np.asarray(forces.on_slaves), atol=FLOAT32_ATOL
    )
    np.testing.assert_allclose(
        np.asarray(compact.on_master), np.asarray(forces.on_master), atol=FLOAT32_ATOL
    )


def test_penalty_shares_the_reaction_by_the_segment_basis():
    floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]], FLOAT), jnp.array([[0, 1]]))
    contact = all_to_all(jnp.array([[0.25, -0.5], [0.5, 0.3]], FLOAT), floor, radius=1.0)
    forces = penalty(contact, floor, jnp.array([10.0, 7.0], FLOAT))
    np.testing.assert_allclose(np.asarray(forces.on_slaves), [[0.0, 5.0], [0.0, 0.0]])
    np.testing.assert_allclose(np.asarray(forces.on_master), [[0.0, -1.25], [0.0, -3.75]])
    assert isinstance(forces, Forces)


@pytest.mark.x64
def test_gradients_of_a_frictional_penalty_energy_match_finite_differences():
    dtype = jnp.float64
    floor = wavy_master(dtype, 0.0)
    along = np.array([0.5, 1.2, 2.1, 2.6])
    last_x = jnp.asarray(np.stack([along, 0.1 * np.sin(3 * along) - 0.02], -1), dtype)
    x = last_x + jnp.asarray([[0.01, 0.0], [0.2, 0.001], [-0.003, 0.0], [-0.15, 0.002]], dtype)
    last = all_to_all(last_x, floor, radius=0.2)
    friction = Friction.zeros(4, dtype)._replace(
        traction=jnp.asarray([[0.1, 0.0], [-0.1, 0.0], [0.05, 0.0], [0.0, 0.0]], dtype)
    )

    def energy(x, nodes):
        surface = floor._replace(nodes=nodes)
        contact = all_to_all(x, surface, radius=0.2)
        slip = track(last, contact, surface)
        forces, after = coulomb(
            contact, slip, friction, surface, stiffness=100.0, tangent_stiffness=50.0, mu=0.4
        )
        depth = jnp.where(contact.active, -contact.gap, 0)
        return jnp.sum(50.0 * depth**2) + jnp.sum(after.traction**2) / (2 * 50.0)

    _, after = coulomb(
        all_to_all(x, floor, radius=0.2),
        track(last, all_to_all(x, floor, radius=0.2), floor),
        friction,
        floor,
        stiffness=100.0,
        tangent_stiffness=50.0,
        mu=0.4,
    )
    assert bool(after.stuck.any()) and not bool(after.stuck.all())  # both regimes
    check_grads(
        energy,
        (x, floor.nodes),
        order=1,
        modes=["rev"],
        atol=FD_SMOOTH_ATOL,
        rtol=FD_SMOOTH_RTOL,
        eps=FD_STEP,
    )


def test_bad_force_inputs_are_named():
    floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]], FLOAT), jnp.array([[0, 1]]))
    contact = all_to_all(jnp.array([[0.25, -0.5]], FLOAT), floor, radius=1.0)
    with pytest.raises(ValueError, match=r"stiffness must be a scalar or have shape \(1,\)"):
        penalty(contact, floor, jnp.ones(3))
    entries = bucket_sort(jnp.array([[0.25, -0.5]], FLOAT), floor, radius=1.0, compact=True)
    with pytest.raises(ValueError, match="num_slaves"):
        penalty(entries, floor, 1.0)
    slip = track(contact, contact, floor)
    with pytest.raises(ValueError, match="friction must hold 1 rows"):
        coulomb(
            contact, slip, Friction.zeros(2), floor, stiffness=1.0, tangent_stiffness=1.0, mu=0.1
        )
    with pytest.raises(ValueError, match="two_pass must be a bool"):
        penalty(contact, floor, 1.0, two_pass=2)
    keywords = dict(stiffness=1.0, tangent_stiffness=1.0, mu=0.1)
    for name, value in (("mu", -0.3), ("tangent_stiffness", 0.0), ("stiffness", -1.0)):
        with pytest.raises(ValueError, match=f"{name} must be finite and"):
            coulomb(contact, slip, Friction.zeros(1), floor, **{**keywords, name: value})
    two = all_to_all(jnp.array([[0.25, -0.5], [0.5, -0.1]], FLOAT), floor, radius=1.0)
    with pytest.raises(ValueError, match="contact has 2 rows; slip has 1"):
        coulomb(two, slip, Friction.zeros(1), floor, **keywords)
    with pytest.raises(ValueError, match="last must be a Contact or a History"):
        track(entries, entries, floor)


def test_coulomb_without_a_tracked_search_names_track_true():
    floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]], FLOAT), jnp.array([[0, 1]]))
    x = jnp.array([[0.25, -0.05]], FLOAT)
    search = Search(radius=0.1, method="exhaustive")  # no track=True: no slip kept
    contact, state = search.closest(search.allocate(x, floor), x, floor)
    assert state.slip is None
    keywords = dict(stiffness=1.0, tangent_stiffness=1.0, mu=0.1)
    with pytest.raises(ValueError, match=r"slip is None: .*Search\(track=True\)"):
        coulomb(contact, state.slip, Friction.zeros(1), floor, **keywords)
    with pytest.raises(ValueError, match="slip must be a jaxcontact.Slip .* got SearchState"):
        coulomb(contact, state, Friction.zeros(1), floor, **keywords)
    slip = track(contact, contact, floor)
    with pytest.raises(ValueError, match=r"friction must be a .*zeros\(N\).* got NoneType"):
        coulomb(contact, slip, None, floor, **keywords)


def test_penalty_refuses_a_negative_stiffness_it_can_see():
    floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]], FLOAT), jnp.array([[0, 1]]))
    x = jnp.array([[0.25, -0.5], [0.75, -0.25]], FLOAT)
    contact = all_to_all(x, floor, radius=1.0)
    for stiffness in (-10.0, np.array([10.0, -1.0]), float("nan")):
        with pytest.raises(ValueError, match=r"stiffness must be finite and >= 0; got"):
            penalty(contact, floor, stiffness)
    pushed = penalty(contact, floor, np.array([10.0, 0.0]))  # zero is allowed: no force
    np.testing.assert_array_equal(np.asarray(pushed.on_slaves[:, 1]), [5.0, 0.0])
    # Traced, its sign is not known when the program is built: the docstring says so.
    pulled = jax.jit(lambda k: penalty(contact, floor, k))(-10.0)
    assert float(pulled.on_slaves[0, 1]) < 0


@pytest.mark.parametrize("dtype", [FLOAT, np.float32])
def test_friction_zeros_follows_the_default_float_in_a_scan(dtype):
    assert Friction.zeros(3).traction.dtype == jnp.zeros(()).dtype == FLOAT
    assert Friction.zeros(3).dissipated.dtype == FLOAT
    assert Friction.zeros(3, jnp.float32).traction.dtype == jnp.float32
    floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]], dtype), jnp.array([[0, 1]]))
    search = Search(radius=0.1, method="exhaustive", track=True)
    x0 = jnp.array([[0.25, -0.01]], dtype)

    def step(carry, shift):
        state, friction = carry
        contact, state = search.closest(state, x0.at[0, 0].add(shift), floor)
        forces, friction = coulomb(
            contact, state.slip, friction, floor, stiffness=100.0, tangent_stiffness=100.0, mu=0.5
        )
        return (state, friction), forces.on_slaves

    # The carry's dtype must not change over the scan: the state stays in the default
    # float (float64 with x64, float32 slaves too); the forces are in the slaves' dtype.
    start = (search.allocate(x0, floor), Friction.zeros(1))
    (_, friction), on_slaves = jax.lax.scan(step, start, jnp.array([0.0, 0.001, 0.002], dtype))
    assert on_slaves.dtype == dtype
    assert friction.traction.dtype == friction.dissipated.dtype == FLOAT
    assert float(friction.traction[0, 0]) < 0  # it opposes the slide along +x


def test_compact_and_dense_searches_give_the_same_frictional_forces_under_vmap():
    """Search(track=True, normals=Smooth()) + coulomb: the dense Contact (two
    scenes under vmap) and the compact ContactList (scene by scene, with the
    gradient of the master's load) give the same forces over a 4-step scan."""
    dtype = FLOAT
    rng = np.random.default_rng(2)
    along = rng.uniform(0.3, 2.7, (2, 6))
    x0 = jnp.asarray(np.stack([along, 0.1 * np.sin(3 * along) - 0.01], -1), dtype)
    floor = wavy_master(dtype, 0.0)
    moves = jnp.asarray(rng.normal(0, 0.03, (4, 2, 6, 2)) * [1.0, 0.1], dtype)

    def run(search, state, x, moves):
        def step(carry, move):
            state, friction, x = carry
            x = x + move
            contact, state = search.closest(state, x, floor)
            forces, friction = coulomb(
                contact,
                state.slip,
                friction,
                floor,
                stiffness=100.0,
                tangent_stiffness=50.0,
                mu=0.4,
            )
            return (state, friction, x), forces

        return jax.lax.scan(step, (state, Friction.zeros(6, dtype), x), moves)[1]

    searches = [
        Search(radius=0.2, method="unbinned", compact=compact, track=True, normals=Smooth())
        for compact in (False, True)
    ]
    states = [search.allocate(x0, floor) for search in searches]
    dense = jax.vmap(functools.partial(run, searches[0]), in_axes=(0, 0, 1))(states[0], x0, moves)
    assert float(jnp.abs(dense.on_slaves).sum()) > 0

    def load(x, state, moves):
        forces = run(searches[1], state, x, moves)
        return forces.on_master.sum(), forces

    load = jax.jit(jax.value_and_grad(load, has_aux=True))
    for scene in range(2):
        state = jax.tree.map(lambda values, scene=scene: values[scene], states[1])
        (_, compact), grad = load(x0[scene], state, moves[:, scene])
        assert bool(jnp.isfinite(grad).all())
        for field in ("on_slaves", "on_master"):
            np.testing.assert_allclose(
                np.asarray(getattr(compact, field)),
                np.asarray(getattr(dense, field)[scene]),
                atol=FLOAT32_SUM_ATOL,
            )
