"""The ALE part (``sim.ale``): rezone, conservative remap, velocity remap, the schedule.

Checked against what a remap must do exactly: a uniform field stays uniform,
mass and every ``phi * mass`` are conserved, no motion changes nothing, the donor
cell translates a step as the binomial recurrence it reduces to on a uniform
strip (its diffusion, ``n c (1 - c)`` cells² of variance, predicted), van Leer
stays within the step's bounds and nearer the exact answer, a linear velocity
field is interpolated exactly, and the guard never lets an element's quality
fall below its own or the floor. Gradients through a remap and a rezone
against central differences.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact.sim import ale, materials
from jaxcontact.sim.elements import q4
from tests.support.tolerances import (
    FD_RTOL,
    FLOAT64_ATOL,
    FLOAT64_EXACT_ATOL,
    FLOAT64_RTOL,
)

pytestmark = pytest.mark.x64

DENSITY = materials.AISI_1045.density


def grid(nx=5, ny=4, width=5.0, height=4.0, wobble=0.15, seed=0):
    """An ``nx x ny`` grid, its interior nodes moved off the lattice by up to ``wobble`` of
    an element."""
    mesh = q4.grid_mesh(width, height, nx, ny, DENSITY, jnp.float64)
    x = np.asarray(mesh.nodes).copy()
    inside = (x[:, 0] > 0) & (x[:, 0] < width) & (x[:, 1] > 0) & (x[:, 1] < height)
    rng = np.random.default_rng(seed)
    x[inside] += rng.uniform(-wobble, wobble, (inside.sum(), 2)) * (width / nx)
    return mesh._replace(nodes=jnp.asarray(x)), inside


def moved(mesh, inside, size=0.2, seed=1):
    """The interior nodes moved at random by up to ``size`` of an element (the boundary kept)."""
    rng = np.random.default_rng(seed)
    shift = np.zeros(mesh.nodes.shape)
    shift[inside] = rng.uniform(-size, size, (inside.sum(), 2))
    return mesh.nodes + shift


def element_mass(mesh, x):
    return DENSITY * ale.areas(mesh, x)


def test_tables_of_a_grid():
    mesh = q4.grid_mesh(2.0, 2.0, 2, 2, DENSITY, jnp.float64)
    tables = ale.tables(mesh)
    assert tables.faces.shape == (12, 2)
    assert int((tables.right >= 0).sum()) == 4  # the four inner faces
    across = np.asarray(tables.across)
    for e in range(4):
        for k in range(4):
            other = across[e, k]
            if other >= 0:
                assert e in across[other]  # symmetric
    assert np.asarray(tables.neighbours)[4].tolist() == [1, 3, 5, 7]  # the centre node
    with pytest.raises(ValueError, match=r"quads.quads must be i32\[E, 4\]"):
        ale.tables(mesh._replace(quads=mesh.quads[:, :3]))


@pytest.mark.parametrize("order", [1, 2])
def test_uniform_field_remaps_exactly_and_sums_are_conserved(order):
    mesh, inside = grid()
    tables = ale.tables(mesh)
    x_new = moved(mesh, inside)
    mass = element_mass(mesh, mesh.nodes)
    uniform = {
        "t": jnp.full(mass.shape, 773.0),
        "s": jnp.tile(jnp.array([1.0, -2.0, 3.0, 0.5]), (mass.shape[0], 1)),
    }
    new_mass, new = ale.remap(tables, mesh, mesh.nodes, x_new, mass, uniform, order=order)
    np.testing.assert_allclose(new["t"], 773.0, rtol=FLOAT64_RTOL)
    np.testing.assert_allclose(new["s"], uniform["s"], rtol=FLOAT64_RTOL, atol=FLOAT64_ATOL)
    # A uniform density stays uniform: the swept areas add up to each element's new area.
    np.testing.assert_allclose(new_mass / ale.areas(mesh, x_new), DENSITY, rtol=FLOAT64_RTOL)
    # A varied field: mass and phi * mass conserved, to round-off.
    rng = np.random.default_rng(2)
    field = jnp.asarray(rng.uniform(0.0, 5.0, mass.shape))
    new_mass, new_field = ale.remap(tables, mesh, mesh.nodes, x_new, mass, field, order=order)
    assert float(new_mass.sum()) == pytest.approx(float(mass.sum()), rel=FLOAT64_RTOL)
    assert float((new_field * new_mass).sum()) == pytest.approx(
        float((field * mass).sum()), rel=FLOAT64_RTOL
    )
    # ... and a remapped value lies within the range of its donors (no new extremes).
    assert float(new_field.min()) >= float(field.min()) - FLOAT64_ATOL
    assert float(new_field.max()) <= float(field.max()) + FLOAT64_ATOL


def test_no_motion_is_the_identity():
    mesh, inside = grid()
    tables = ale.tables(mesh)
    rng = np.random.default_rng(3)
    mass = element_mass(mesh, mesh.nodes)
    points = materials.PointState(
        jnp.asarray(rng.normal(size=(mass.shape[0], 4, 4))),
        jnp.asarray(rng.uniform(size=(mass.shape[0], 4))),
        jnp.asarray(rng.uniform(300, 900, (mass.shape[0], 4))),
    )
    new_mass, new_points = ale.remap_points(tables, mesh, mesh.nodes, mesh.nodes, mass, points)
    np.testing.assert_array_equal(new_mass, mass)
    for got, want in zip(new_points, points, strict=True):
        np.testing.assert_allclose(got, want, rtol=0, atol=FLOAT64_EXACT_ATOL * 1e3)
    v = jnp.asarray(rng.normal(size=mesh.nodes.shape))
    np.testing.assert_array_equal(ale.remap_velocity(tables, mesh, mesh.nodes, mesh.nodes, v), v)
    nothing = jnp.zeros(mesh.nodes.shape[0], bool)
    along = jnp.full((mesh.nodes.shape[0], 2), -1, jnp.int32)
    np.testing.assert_array_equal(ale.rezone(tables, mesh, mesh.nodes, nothing, along), mesh.nodes)


def strip(cells=24):
    """A row of ``cells`` unit squares along x."""
    return q4.grid_mesh(float(cells), 1.0, cells, 1, DENSITY, jnp.float64)


def translate_step(order, times, courant):
    """A step (1 left of the middle, 0 right) remapped ``times`` times, the mesh moved
    ``courant`` of a cell to the right each time: the cell values after each."""
    mesh = strip()
    tables = ale.tables(mesh)
    cells = mesh.quads.shape[0]
    field = jnp.where(jnp.arange(cells) < cells // 2, 1.0, 0.0)
    x = mesh.nodes
    mass = element_mass(mesh, x)
    for _ in range(times):
        x_new = x + jnp.array([[courant, 0.0]])
        mass, field = ale.remap(tables, mesh, x, x_new, mass, field, order=order)
        x = x_new
    return np.asarray(field)


def test_donor_cell_diffuses_a_step_as_predicted():
    times, c = 6, 0.3
    got = translate_step(1, times, c)
    # On a uniform strip the donor cell is phi_i <- (1 - c) phi_i + c phi_(i+1) (the mesh
    # moves right, so each cell takes c of its right neighbour): the step convolved with
    # Binomial(times, c), whose variance is times c (1 - c) cells².
    cells = got.shape[0]
    want = np.where(np.arange(cells) < cells // 2, 1.0, 0.0)
    for _ in range(times):
        want = (1 - c) * want + c * np.append(want[1:], 0.0)
    np.testing.assert_allclose(got, want, rtol=0, atol=FLOAT64_ATOL)
    slope = -np.diff(got)  # the spread step: a probability distribution over the faces
    assert slope.sum() == pytest.approx(1.0, rel=FLOAT64_RTOL)
    mean = (np.arange(slope.shape[0]) * slope).sum()
    variance = ((np.arange(slope.shape[0]) - mean) ** 2 * slope).sum()
    assert variance == pytest.approx(times * c * (1 - c), rel=FLOAT64_RTOL)


def test_van_leer_keeps_a_step_within_bounds_and_sharper():
    times, c = 6, 0.3
    second = translate_step(2, times, c)
    first = translate_step(1, times, c)
    assert second.min() >= -FLOAT64_ATOL and second.max() <= 1 + FLOAT64_ATOL
    # The exact answer: the material stood still and the mesh moved times * c cells, so the
    # step sits times * c cells left of the middle in the new cells' numbering.
    cells = second.shape[0]
    edge = cells // 2 - times * c
    left = np.arange(cells, dtype=float)
    exact = np.clip(edge - left, 0.0, 1.0)
    error_second, error_first = np.abs(second - exact).sum(), np.abs(first - exact).sum()
    assert error_second < 0.6 * error_first


def test_linear_velocity_is_interpolated_exactly():
    mesh, inside = grid(wobble=0.0)  # bilinear maps of parallelograms reproduce linear fields
    tables = ale.tables(mesh)
    gradient, offset = jnp.array([[0.3, -1.2], [2.0, 0.7]]), jnp.array([[5.0, -1.0]])
    v = mesh.nodes @ gradient.T + offset
    x_new = moved(mesh, inside, size=0.3)
    got = ale.remap_velocity(tables, mesh, mesh.nodes, x_new, v)
    np.testing.assert_allclose(
        got, x_new @ gradient.T + offset, rtol=FLOAT64_RTOL, atol=FLOAT64_ATOL
    )


def sliding_plan(mesh):
    """Every node movable but the four corners; the edge nodes slide along their edge."""
    x = np.asarray(mesh.nodes)
    width, height = x[:, 0].max(), x[:, 1].max()
    nx = int(round(np.sum(x[:, 1] == 0))) - 1
    corner = np.isin(x[:, 0], [0, width]) & np.isin(x[:, 1], [0, height])
    along = np.full((x.shape[0], 2), -1, np.int32)
    for i, (px, py) in enumerate(x):
        if corner[i]:
            continue
        if py in (0, height):
            along[i] = (i - 1, i + 1)
        elif px in (0, width):
            along[i] = (i - (nx + 1), i + nx + 1)
    return jnp.asarray(~corner), jnp.asarray(along)


@pytest.mark.parametrize("floor", [0.5, 1.0])
def test_guard_never_lets_an_element_fall_below_itself_or_the_floor(floor):
    mesh, _ = grid(wobble=0.3, seed=4)
    # The boundary nodes bunched too: sliding brings them back along their edges.
    x = np.asarray(mesh.nodes).copy()
    x[1, 0] += 0.6
    x[6, 1] -= 0.5
    mesh = mesh._replace(nodes=jnp.asarray(x))
    tables = ale.tables(mesh)
    movable, along = sliding_plan(mesh)
    settings = ale.Settings(weight=1.0, sweeps=6, floor=floor)
    after = ale.rezone(tables, mesh, mesh.nodes, movable, along, settings)
    before_q, after_q = ale.quality(mesh, mesh.nodes), ale.quality(mesh, after)
    assert bool(jnp.all(after_q >= jnp.minimum(before_q, floor) - FLOAT64_ATOL))
    # Nor its area over its reference area (the mesh's own nodes here: 1 before).
    ratio = ale.areas(mesh, after) / ale.areas(mesh, mesh.nodes)
    assert bool(jnp.all(ratio >= floor - FLOAT64_ATOL))
    # The boundary kept its shape: edge nodes stayed on their edges.
    width, height = 5.0, 4.0
    was, now = np.asarray(mesh.nodes), np.asarray(after)
    for axis, ends in ((0, (0.0, width)), (1, (0.0, height))):
        on = np.isin(was[:, axis], ends)
        np.testing.assert_allclose(now[on, axis], was[on, axis], rtol=0, atol=FLOAT64_ATOL)
    if floor == 0.5:
        assert float(jnp.abs(after - mesh.nodes).max()) > 0.05  # it did move nodes
        # Smoothing a wobbled grid improves its worst element.
        assert float(after_q.min()) > float(before_q.min())


def test_guard_takes_back_a_move_that_would_fold():
    mesh = q4.grid_mesh(2.0, 1.0, 2, 1, DENSITY, jnp.float64)
    tables = ale.tables(mesh)
    # The middle bottom node pulled far right, past the corner: its edge-neighbour mean
    # lies where the right element would fold.
    x = mesh.nodes.at[1].set(jnp.array([1.9, 0.0]))
    x = x.at[4].set(jnp.array([1.95, 1.0]))
    movable = jnp.zeros(6, bool).at[4].set(True)
    along = jnp.full((6, 2), -1, jnp.int32)
    settings = ale.Settings(weight=1.0, sweeps=1, floor=0.5)
    after = ale.rezone(tables, mesh, x, movable, along, settings)
    before_q, after_q = ale.quality(mesh, x), ale.quality(mesh, after)
    target = ale.rezone(tables, mesh, x, movable, along, settings._replace(floor=-1.0))
    assert float(ale.quality(mesh, target).min()) < float(before_q.min())  # unguarded: worse
    assert bool(jnp.all(after_q >= jnp.minimum(before_q, 0.5) - FLOAT64_ATOL))


def test_one_failing_element_holds_only_the_nodes_around_it():
    # A 12 x 3 strip, its interior wobbled by up to 0.3 of an element over its
    # first four columns and 0.09 beyond: a floor of 1 (no element may get worse)
    # holds some nodes in the middle, and every node far from them still moves
    # a blend (1, 1/2, 1/4 or 1/8) of the way to its smoothed place, on both sides.
    mesh = q4.grid_mesh(12.0, 3.0, 12, 3, DENSITY, jnp.float64)
    x = np.asarray(mesh.nodes).copy()
    inside = (x[:, 0] > 0) & (x[:, 0] < 12) & (x[:, 1] > 0) & (x[:, 1] < 3)
    rng = np.random.default_rng(4)
    scale = np.where(x[inside, :1] < 4, 1.0, 0.3)
    x[inside] += rng.uniform(-0.3, 0.3, (inside.sum(), 2)) * scale
    x = jnp.asarray(x)
    tables, movable = ale.tables(mesh), jnp.asarray(inside)
    along = jnp.full((x.shape[0], 2), -1, jnp.int32)
    settings = ale.Settings(weight=1.0, sweeps=2, floor=1.0)
    after = np.asarray(ale.rezone(tables, mesh, x, movable, along, settings))
    free = np.asarray(ale.rezone(tables, mesh, x, movable, along, settings._replace(floor=-1.0)))
    was = np.asarray(x)
    held = inside & (np.abs(after - was).max(1) == 0) & (np.abs(free - was).max(1) > 0)
    column = np.asarray(mesh.nodes)[:, 0]
    assert held.any()  # an element failed
    far = inside & ((column < column[held].min() - 2) | (column > column[held].max() + 2))
    assert far.sum() >= 4
    step, full = after[far] - was[far], free[far] - was[far]
    blend = np.sum(step * full, 1) / np.sum(full * full, 1)
    blends = np.array([1, 0.5, 0.25, 0.125])
    nearest = blends[np.abs(blend[:, None] - blends).argmin(1)]
    np.testing.assert_allclose(blend, nearest, rtol=FLOAT64_RTOL, atol=0)
    np.testing.assert_allclose(step, nearest[:, None] * full, rtol=0, atol=FLOAT64_ATOL)
    before_q, after_q = ale.quality(mesh, x), ale.quality(mesh, jnp.asarray(after))
    assert bool(jnp.all(after_q >= jnp.minimum(before_q, 1.0) - FLOAT64_ATOL))


def test_gradients_through_rezone_and_remap_match_central_differences():
    mesh, inside = grid(nx=4, ny=3, width=4.0, height=3.0)
    tables = ale.tables(mesh)
    movable, along = sliding_plan(mesh)
    rng = np.random.default_rng(5)
    direction = jnp.asarray(np.where(inside[:, None], rng.normal(size=mesh.nodes.shape), 0.0))
    field = jnp.asarray(rng.uniform(1.0, 2.0, mesh.quads.shape[0]))
    weights = jnp.asarray(rng.uniform(size=mesh.quads.shape[0]))
    mass = element_mass(mesh, mesh.nodes)

    def objective(theta):
        x = mesh.nodes + 0.1 * theta * direction  # a Lagrangian motion of the nodes
        x_new = ale.rezone(tables, mesh, x, movable, along, ale.Settings(weight=0.4))
        new_mass, new = ale.remap(tables, mesh, x, x_new, mass * (1 + theta), field * theta)
        return jnp.sum(weights * new * new_mass)

    theta, h = 0.7, 1e-6
    grad = jax.grad(objective)(theta)
    central = (objective(theta + h) - objective(theta - h)) / (2 * h)
    assert np.isfinite(float(grad))
    assert float(grad) == pytest.approx(float(central), rel=FD_RTOL)


def test_cycles_adapts_every_k_steps():
    def step(carry):
        count, adapted = carry
        return (count + 1, adapted), count

    def adapt(carry):
        count, adapted = carry
        return count, adapted + 1

    (count, adapted), records = ale.cycles(step, adapt, (0, 0), length=12, every=4)
    assert int(count) == 12 and int(adapted) == 3
    np.testing.assert_array_equal(records, np.arange(12))
    with pytest.raises(ValueError, match="multiple of every"):
        ale.cycles(step, adapt, (0, 0), length=10, every=4)


def test_remap_under_jit_and_vmap():
    mesh, inside = grid()
    tables = ale.tables(mesh)
    mass = element_mass(mesh, mesh.nodes)
    targets = jnp.stack([moved(mesh, inside, seed=s) for s in (6, 7)])
    field = jnp.arange(mass.shape[0], dtype=jnp.float64)

    def one(x_new):
        return ale.remap(tables, mesh, mesh.nodes, x_new, mass, field)

    batched = jax.jit(jax.vmap(one))(targets)
    for b in range(2):
        single = one(targets[b])
        np.testing.assert_allclose(batched[1][b], single[1], rtol=FLOAT64_RTOL)
    with pytest.raises(ValueError, match="order must be 1"):
        ale.remap(tables, mesh, mesh.nodes, mesh.nodes, mass, field, order=3)
