"""Slip history: ``Search(track=True)`` and ``jaxcontact.track`` against analytic sliding.

Slaves slide along two outlines (an open zigzag with convex and concave
vertices, and a closed 40-gon) listed in shuffled order with padding
segments, by known arc lengths per step: within a segment, across one and
several vertices, and past more than ``_track.WALK`` segments; some stay at
rest. The master and the slaves together translate and rotate every step,
which must add no slip. The expected slip is the arc length slid, the
expected anchor last step's material point carried by the master's motion.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import Search, Surface, all_to_all
from jaxcontact._track import WALK
from tests.support.tolerances import FLOAT32_ATOL, SLIP_ATOL

DEPTH = 0.01  # slaves sit this far inside the outline: in contact
RADIUS = 0.05


class Outline:
    """An outline in arc length: ``at(s)`` gives the point and outward normal."""

    def __init__(self, nodes: np.ndarray, closed: bool):
        self.nodes = nodes
        self.closed = closed
        ends = np.concatenate([nodes[1:], nodes[:1]]) if closed else nodes[1:]
        self.start, self.end = nodes[: len(ends)], ends
        self.length = np.linalg.norm(self.end - self.start, axis=1)
        self.arc = np.concatenate([[0.0], np.cumsum(self.length)])

    def at(self, s: float):
        if self.closed:
            s = s % self.arc[-1]
        k = min(np.searchsorted(self.arc, s, side="right") - 1, len(self.length) - 1)
        t = (s - self.arc[k]) / self.length[k]
        direction = (self.end[k] - self.start[k]) / self.length[k]
        normal = np.array([direction[1], -direction[0]])
        return self.start[k] + t * (self.end[k] - self.start[k]), normal, t


def outlines():
    zigzag = np.array(
        [[0.0, 0.0], [1.0, 0.3], [2.0, -0.2], [2.6, 0.5], [3.5, 0.4], [4.2, 1.2], [5.0, 1.0]]
    )
    angle = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    ring = np.stack([2.0 + 1.5 * np.cos(angle), 4.0 + 1.5 * np.sin(angle)], -1)
    return Outline(zigzag, closed=False), Outline(ring, closed=True)


# Per slave: (outline, arc length at the start, arc length slid per step).
# The ring's segments are 0.2355 long: 3.0 per step crosses 12 > WALK of them.
SLIDES = [
    (0, 0.40, 0.05),  # within a segment, then across the zigzag's vertices
    (0, 1.50, 0.30),  # across a convex and a concave vertex
    (0, 3.70, -0.25),  # backwards
    (0, 2.80, 0.0),  # at rest on the moving master
    (1, 0.10, 0.52),  # across 2-3 vertices of the ring each step
    (1, 5.00, -0.30),
    (1, 8.90, 3.0),  # more than WALK segments, and across where the ring starts
    (1, 2.00, 0.0),
]
STEPS = 5


def safe(outline: Outline, s: float) -> float:
    """``s`` moved into the middle 60 % of its segment: the closest point lies on a face."""
    wraps = outline.arc[-1] * np.floor(s / outline.arc[-1]) if outline.closed else 0.0
    local = s - wraps
    k = min(np.searchsorted(outline.arc, local, side="right") - 1, len(outline.length) - 1)
    low, high = (
        outline.arc[k] + 0.2 * outline.length[k],
        outline.arc[k + 1] - 0.2 * outline.length[k],
    )
    return wraps + min(max(local, low), high)


def motion(step: int):
    """The rigid motion of the whole scene at ``step``: rotation, translation."""
    angle = 0.15 * step
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    return rotation, np.array([0.3 * step, -0.2 * step])


def scene(dtype):
    """The surface per step (shuffled, padded), slaves per step, expected slips and anchors."""
    zigzag, ring = outlines()
    shapes = [zigzag, ring]
    nodes = np.concatenate([zigzag.nodes, ring.nodes])
    segments = np.concatenate(
        [
            np.stack([np.arange(6), np.arange(1, 7)], -1),
            7 + np.stack([np.arange(40), (np.arange(40) + 1) % 40], -1),
        ]
    )
    rng = np.random.default_rng(0)
    order = rng.permutation(len(segments))
    segments = np.concatenate([segments[order], [[-1, 99], [3, 3]]]).astype(np.int32)
    mask = np.arange(len(segments)) < len(order)
    arcs = np.zeros((STEPS, len(SLIDES)))
    for j, (which, start, per_step) in enumerate(SLIDES):
        arcs[:, j] = [safe(shapes[which], start + per_step * t) for t in range(STEPS)]
    xs, all_nodes, material = [], [], []
    for t in range(STEPS):
        rotation, shift = motion(t)
        here, points = [], []
        for j, (which, _, _) in enumerate(SLIDES):
            point, normal, _ = shapes[which].at(arcs[t, j])
            here.append(point - DEPTH * normal)
            points.append(point)
        xs.append(np.array(here) @ rotation.T + shift)
        all_nodes.append(nodes @ rotation.T + shift)
        material.append(np.array(points))
    slips = np.diff(arcs, axis=0)
    for j, (which, _, _) in enumerate(SLIDES):
        if shapes[which].closed:  # the shorter way round
            loop = shapes[which].arc[-1]
            slips[:, j] = slips[:, j] - loop * np.round(slips[:, j] / loop)
    # Last step's material point, carried by this step's motion.
    anchors = [material[t - 1] @ motion(t)[0].T + motion(t)[1] for t in range(1, STEPS)]
    as_array = lambda values: jnp.asarray(np.array(values), dtype)  # noqa: E731
    surface = Surface(as_array(all_nodes), jnp.asarray(segments), jnp.asarray(mask))
    return as_array(xs), surface, slips, np.array(anchors)


def tracked_run(search: Search, xs, surfaces):
    """Slips of every step after the first, in one ``lax.scan``."""
    first = Surface(surfaces.nodes[0], surfaces.segments, surfaces.mask)
    state = search.allocate(xs[0], first)

    def step(state, inputs):
        x, nodes = inputs
        contact, state = search.closest(state, x, first._replace(nodes=nodes))
        slip = state.slip
        if isinstance(contact, jaxcontact.ContactList):
            contact = contact.to_contact(x.shape[0])
        return state, (slip, contact.active)

    _, (slip, active) = jax.lax.scan(jax.jit(step), state, (xs, surfaces.nodes))
    return slip, active


@pytest.mark.parametrize(
    "dtype, method, compact",
    [
        (jnp.float64, "exhaustive", False),
        (jnp.float64, "unbinned", True),
        (jnp.float32, "binned", False),
    ],
)
def test_slip_is_the_arc_length_slid_along_the_moving_master(dtype, method, compact):
    if dtype == jnp.float64 and not jax.config.jax_enable_x64:
        pytest.skip("needs x64")
    xs, surfaces, slips, anchors = scene(dtype)
    search = Search(radius=RADIUS, skin=0.0, method=method, compact=compact, track=True)
    slip, active = tracked_run(search, xs, surfaces)
    assert bool(active.all()), "every slave is in contact at every step"
    assert not bool(slip.persisted[0].any()), "nothing persists at the first step"
    assert bool(slip.persisted[1:].all())
    atol = 1e-9 if dtype == jnp.float64 else 2e-5
    np.testing.assert_allclose(np.asarray(slip.slip[1:]), slips, atol=atol)
    np.testing.assert_allclose(np.asarray(slip.anchor[1:]), anchors, atol=atol * 10)
    # The scene does walk across vertices and past WALK segments.
    assert np.abs(slips).max() > WALK * 0.2355
    assert (np.abs(slips) == 0).sum() == 2 * (STEPS - 1)


def test_plain_track_equals_the_search_and_forget_drops_rows():
    xs, surfaces, slips, _ = scene(jnp.float32)
    one = lambda t: Surface(surfaces.nodes[t], surfaces.segments, surfaces.mask)  # noqa: E731
    last = all_to_all(xs[0], one(0), radius=RADIUS)
    now = all_to_all(xs[1], one(1), radius=RADIUS)
    plain = jaxcontact.track(last, now, one(1))
    np.testing.assert_allclose(np.asarray(plain.slip), slips[0], atol=SLIP_ATOL)
    search = Search(radius=RADIUS, method="exhaustive", track=True)
    state = search.allocate(xs[0], one(0))
    # Before the first step the state's slip is zeros, nothing persisted.
    before = state.slip
    assert before.slip.shape == (len(SLIDES),) and before.anchor.shape == (len(SLIDES), 2)
    assert not bool(before.persisted.any()) and not np.asarray(before.anchor).any()
    np.testing.assert_array_equal(np.asarray(before.slip), 0)
    assert Search(radius=RADIUS, method="exhaustive").allocate(xs[0], one(0)).slip is None
    _, state = search.closest(state, xs[0], one(0))
    rows = jnp.arange(len(SLIDES)) % 2 == 0
    state = state.forget(rows)
    _, state = search.closest(state, xs[1], one(1))
    slip = state.slip
    assert not bool(slip.persisted[rows].any()) and bool(slip.persisted[~rows].all())
    np.testing.assert_array_equal(np.asarray(slip.slip[rows]), 0)
    np.testing.assert_allclose(
        np.asarray(slip.slip[~rows]), slips[0][~np.asarray(rows)], atol=SLIP_ATOL
    )
    with pytest.raises(ValueError, match="rows must have shape"):
        state.forget(jnp.ones(3, bool))
    with pytest.raises(ValueError, match="no slip history"):
        Search(radius=RADIUS, method="exhaustive").allocate(xs[0], one(0)).forget(rows)


def test_rows_not_found_hold_zeros_and_batches_map():
    xs, surfaces, _, _ = scene(jnp.float32)
    one = Surface(surfaces.nodes[0], surfaces.segments, surfaces.mask)
    x_far = xs[0].at[0].add(10.0)  # slave 0 leaves contact
    search = Search(radius=RADIUS, method="unbinned", track=True)
    batch = jnp.stack([xs[0], xs[0]])
    state = search.allocate(batch, one)
    assert state.history.found.shape == batch.shape[:2]

    def two_steps(state, first, second):
        _, state = search.closest(state, first, one)
        return search.closest(state, second, one)[1].slip

    slip = jax.vmap(two_steps)(state, batch, jnp.stack([x_far, xs[0]]))
    assert not bool(slip.persisted[0, 0]) and bool(slip.persisted[1, 0])
    np.testing.assert_array_equal(np.asarray(slip.anchor[0, 0]), 0)
    assert float(slip.slip[0, 0]) == 0.0
    np.testing.assert_allclose(np.asarray(slip.slip[1]), 0, atol=FLOAT32_ATOL)  # nothing moved


def test_a_regrown_state_keeps_its_history_and_bad_states_are_refused():
    xs, surfaces, slips, _ = scene(jnp.float32)
    one = lambda t: Surface(surfaces.nodes[t], surfaces.segments, surfaces.mask)  # noqa: E731
    search = Search(radius=RADIUS, method="unbinned", track=True)
    state = search.allocate(xs[0], one(0))
    _, state = search.closest(state, xs[0], one(0))
    # Reallocated at larger sizes (as resumable_scan's grow does): the history stays.
    grown = Search(radius=RADIUS, method="unbinned", track=True, slack=3.0).allocate(
        xs[1], one(1), at_least=state
    )
    slip = search.closest(grown, xs[1], one(1))[1].slip
    assert bool(slip.persisted.all())
    np.testing.assert_allclose(np.asarray(slip.slip), slips[0], atol=SLIP_ATOL)
    with pytest.raises(ValueError, match="slip history has shape"):
        search.closest(state, xs[1][:5], one(1))
    with pytest.raises(ValueError, match="no slip history"):
        search.closest(
            Search(radius=RADIUS, method="unbinned").allocate(xs[0], one(0)), xs[0], one(0)
        )


@pytest.mark.parametrize("found_rows", ["few", "many"])
def test_many_rows_are_worked_on_compacted_or_all_alike(found_rows):
    """Above 1,024 rows, tracking and smoothing gather the found rows into a
    capacity of N / 16 (at least 1,024), or work on all rows when more are
    found: both give each row what the 8-row scene gives it."""
    from jaxcontact._pipeline.rows import capacity

    xs, surfaces, slips, _ = scene(jnp.float32)
    one = lambda t: Surface(surfaces.nodes[t], surfaces.segments, surfaces.mask)  # noqa: E731
    num_rows = 2048
    assert capacity(num_rows) == 1024
    copies = num_rows // len(SLIDES) if found_rows == "many" else 1
    far = jnp.full((num_rows, 2), 100.0, jnp.float32)
    last_x = far.at[: copies * len(SLIDES)].set(jnp.tile(xs[0], (copies, 1)))
    x = far.at[: copies * len(SLIDES)].set(jnp.tile(xs[1], (copies, 1)))
    last = all_to_all(last_x, one(0), radius=RADIUS)
    now = all_to_all(x, one(1), radius=RADIUS, normals=jaxcontact.Smooth())
    small = all_to_all(xs[1], one(1), radius=RADIUS, normals=jaxcontact.Smooth())
    assert (int(now.found.sum()) > 1024) == (found_rows == "many")
    slip = jaxcontact.track(last, now, one(1))
    expected = np.zeros(num_rows)
    expected[: copies * len(SLIDES)] = np.tile(slips[0], copies)
    np.testing.assert_allclose(np.asarray(slip.slip), expected, atol=SLIP_ATOL)
    assert int(slip.persisted.sum()) == copies * len(SLIDES)
    rows = slice(0, len(SLIDES))
    np.testing.assert_allclose(
        np.asarray(now.normal[rows]), np.asarray(small.normal), atol=FLOAT32_ATOL
    )
    np.testing.assert_allclose(np.asarray(now.gap[rows]), np.asarray(small.gap), atol=FLOAT32_ATOL)
    np.testing.assert_array_equal(np.asarray(now.normal[copies * len(SLIDES) :]), 0)


def test_slip_gradients_are_finite_with_padding_and_zero_length_segments():
    nodes = jnp.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 0.0]])
    segments = jnp.array([[2, 1], [1, 0], [-1, -1], [2, 3]])  # padding; a zero-length segment
    mask = jnp.array([True, True, False, True])

    def slid(nodes):
        surface = Surface(nodes, segments, mask)
        last = all_to_all(jnp.array([[1.2, -0.01]]), surface, radius=0.1)
        now = all_to_all(jnp.array([[0.7, -0.01]]), surface, radius=0.1)
        return jaxcontact.track(last, now, surface).slip[0]

    assert float(slid(nodes)) == pytest.approx(0.5, abs=FLOAT32_ATOL)
    grad = np.asarray(jax.grad(slid)(nodes))
    assert np.isfinite(grad).all() and np.abs(grad).sum() > 0
