"""Contact between any outlines: bodies, self-contact, a radius per slave, the closest feature.

Every detector against the brute-force oracle (``tests/oracle.py``, which
applies the pair rule of docs/contract.md in exact arithmetic), on small
scenes whose programs the tests share.
"""

from __future__ import annotations

from fractions import Fraction

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import Pairs, Search, Surface, all_to_all, bucket_sort, bucket_swept, swept
from jaxcontact._pipeline.outline import chains
from jaxcontact._pipeline.segments import resolve_segments
from tests.support.helpers import FLOAT, local_atol
from tests.support.oracle import closest_point, oracle_chains, oracle_contact, oracle_crossing
from tests.support.tolerances import FD_ATOL, FD_RTOL, FD_STEP, FLOAT32_SUM_ATOL, FLOAT32_SUM_RTOL


def ring(count: int, radius: float, centre, phase: float = 0.0) -> np.ndarray:
    """f64[count, 2]: a regular polygon, counter-clockwise."""
    angle = phase + np.linspace(0, 2 * np.pi, count, endpoint=False)
    return np.stack([centre[0] + radius * np.cos(angle), centre[1] + radius * np.sin(angle)], -1)


def loop(count: int, first: int = 0) -> np.ndarray:
    """i32[count, 2]: the segments of a closed outline of ``count`` nodes from ``first``."""
    start = np.arange(count)
    return (first + np.stack([start, (start + 1) % count], -1)).astype(np.int32)


def two_rings(dtype=FLOAT, sizes=(24, 20)):
    """Two deformable bodies pressed into each other: every node is a slave.

    Returns ``(x, surface, slave_node, slave_body)``.
    """
    first, second = sizes
    nodes = np.concatenate([ring(first, 1.0, (0, 0), 0.1), ring(second, 0.7, (1.55, 0.2), 0.2)])
    segments = np.concatenate([loop(first), loop(second, first)])
    body = np.repeat(np.int32([0, 1]), [first, second])
    surface = Surface(jnp.asarray(nodes, dtype), jnp.asarray(segments), body=jnp.asarray(body))
    return jnp.asarray(nodes, dtype), surface, np.arange(first + second, dtype=np.int32), body


def oracle_of(x, surface, radius, **keywords):
    rule = keywords.pop("pairs", None)
    if rule is not None:
        keywords.update(slave_node=rule.slave_node, slave_body=rule.slave_body)
        keywords.update(self_contact=rule.self_contact)
    body = None if surface.body is None else np.asarray(surface.body)
    mask = None if surface.mask is None else np.asarray(surface.mask)
    return oracle_contact(
        np.asarray(x), np.asarray(surface.nodes), np.asarray(surface.segments), mask,
        keywords.pop("mask", None), radius, body=body, **keywords,
    )  # fmt: skip


def assert_matches_oracle(contact, expected, x, surface, dtype):
    """Every field against the oracle; where two allowed segments tie to within
    rounding (symmetric neighbours), either segment is right."""
    atol = local_atol(dtype, 4.0)
    found = np.asarray(contact.found)
    np.testing.assert_array_equal(found, expected.found)
    np.testing.assert_array_equal(np.asarray(contact.active), expected.active)
    np.testing.assert_allclose(np.asarray(contact.gap), expected.gap, atol=atol)
    np.testing.assert_allclose(np.asarray(contact.point), expected.point, atol=atol)
    other = np.flatnonzero(np.asarray(contact.segment) != expected.segment)
    nodes, segments = np.asarray(surface.nodes, np.float64), np.asarray(surface.segments)
    for row in other:
        # The library's choice must be as near as the oracle's, to rounding.
        k = int(contact.segment[row])
        a, b = (tuple(map(Fraction, map(float, nodes[i]))) for i in segments[k])
        slave = tuple(map(Fraction, map(float, np.asarray(x)[row])))
        assert abs(float(closest_point(slave, a, b)[0]) ** 0.5 - abs(expected.gap[row])) <= atol
    assert len(other) <= max(2, found.sum() // 4)
    same = np.asarray(contact.segment) == expected.segment
    np.testing.assert_array_equal(np.asarray(contact.vertex)[same], expected.vertex[same])


ONE_CALL = {
    "all_to_all": all_to_all,
    "bucket_sort": bucket_sort,
    "bucket_sort compact": lambda *a, **k: bucket_sort(*a, compact=True, **k).to_contact(
        a[0].shape[0]
    ),
}


@pytest.mark.parametrize("detector", ONE_CALL)
def test_one_call_over_two_bodies_is_each_body_against_the_other_alone(detector):
    x, surface, slave_node, slave_body = two_rings()
    detect = ONE_CALL[detector]
    both = detect(x, surface, radius=0.3, pairs=Pairs(slave_node, slave_body))
    expected = oracle_of(x, surface, 0.3, slave_node=slave_node, slave_body=slave_body)
    assert_matches_oracle(both, expected, x, surface, FLOAT)
    assert 0 < int(both.active.sum()) < len(x)
    for own in (0, 1):
        rows = slave_body == own
        other_alone = surface._replace(mask=jnp.asarray(np.asarray(surface.body) != own))
        alone = detect(x, other_alone, radius=0.3, mask=jnp.asarray(rows))
        for field in ("segment", "vertex", "found", "active"):
            got, want = np.asarray(getattr(both, field)), np.asarray(getattr(alone, field))
            np.testing.assert_array_equal(got[rows], want[rows], field)
        np.testing.assert_allclose(np.asarray(both.gap)[rows], np.asarray(alone.gap)[rows])
    # Without labels, the other body's nodes see their own outline: false contact.
    unlabelled = detect(x, surface, radius=0.3, pairs=Pairs(slave_node))
    assert int(unlabelled.active.sum()) > int(both.active.sum())


def test_swept_over_two_bodies_and_self_contact_match_the_oracle():
    x, surface, slave_node, slave_body = two_rings()
    x_prev = x + jnp.asarray(np.random.default_rng(3).normal(0, 0.06, x.shape), x.dtype)
    body = np.asarray(surface.body)
    nodes, segments = np.asarray(surface.nodes), np.asarray(surface.segments)
    for keywords in (
        {"slave_node": slave_node, "slave_body": slave_body},
        {"slave_node": slave_node, "self_contact": True},
    ):
        expected = oracle_crossing(x_prev, x, nodes, segments, body=body, **keywords)
        for detect in (swept, bucket_swept):
            crossing = detect(x_prev, x, surface, pairs=Pairs(**keywords))
            np.testing.assert_array_equal(np.asarray(crossing.segment), expected.segment)
            np.testing.assert_allclose(crossing.t, expected.t, atol=local_atol(FLOAT, 40.0))
        assert expected.crossed.any()
    # A node's path ends on its own segments: never reported as crossing them.
    crossing = swept(x_prev, x, surface, pairs=Pairs(slave_node, self_contact=True))
    own = np.asarray(segments)[np.maximum(np.asarray(crossing.segment), 0)]
    assert not np.any(crossing.crossed & np.any(own == slave_node[:, None], axis=-1))
    plain = swept(x_prev, x, surface)  # without the rule, paths meet their own segments
    own = np.asarray(segments)[np.maximum(np.asarray(plain.segment), 0)]
    assert np.sum(plain.crossed & np.any(own == slave_node[:, None], axis=-1)) > len(x) // 4


def test_radius_per_slave_matches_the_oracle_in_every_detector():
    x, surface, slave_node, slave_body = two_rings(sizes=(30, 26))
    radius = np.where(np.arange(len(x)) % 3 == 0, 0.35, 0.08).astype(np.asarray(x).dtype)
    keywords = {"pairs": Pairs(slave_node, slave_body)}
    expected = oracle_of(x, surface, radius, **keywords)
    for detect in ONE_CALL.values():
        contact = detect(x, surface, radius=jnp.asarray(radius), **keywords)
        assert_matches_oracle(contact, expected, x, surface, FLOAT)
    # The radius decides: a larger one on every row finds more.
    wider = all_to_all(x, surface, radius=0.35, **keywords)
    assert int(wider.found.sum()) > int(expected.found.sum())


def test_radius_per_slave_in_a_search_is_traced_and_past_the_bound_overflows():
    x, surface, slave_node, slave_body = two_rings(sizes=(30, 26))
    keywords = {"pairs": Pairs(slave_node, slave_body)}
    search = Search(radius=0.35, skin=0.05, method="binned", compact=True)
    state = search.allocate(x, surface, **keywords)
    traces = []

    @jax.jit
    def step(state, radius):
        traces.append(1)
        return search.closest(state, x, surface, radius=radius, **keywords)

    rng = np.random.default_rng(0)
    for _ in range(3):
        radius = jnp.asarray(rng.uniform(0.05, 0.35, len(x)), x.dtype)
        contact, state = step(state, radius)
        assert not bool(contact.overflow)
        expected = all_to_all(x, surface, radius=radius, **keywords)
        np.testing.assert_array_equal(contact.to_contact(len(x)).segment, expected.segment)
    assert len(traces) == 1  # a new radius every step compiles nothing new
    contact, state = step(state, jnp.full(len(x), 0.36, x.dtype))
    assert bool(contact.overflow) and bool(state.overflow)


def test_vertex_is_decided_exactly_where_xi_rounds_to_one():
    """Slaves whose projection falls just inside a segment's end: xi rounds to
    exactly 1 for some, yet the closest point is on the face (vertex -1)."""
    dtype = FLOAT
    rng = np.random.default_rng(7)
    count = 64
    a = rng.uniform(-1, 1, (count, 2))
    b = a + rng.uniform(0.5, 1.5, (count, 2)) * rng.choice([-1, 1], (count, 2))
    nodes = np.concatenate([a, b]).astype(dtype)
    segments = np.stack([np.arange(count), count + np.arange(count)], -1).astype(np.int32)
    d = (nodes[count:] - nodes[:count]).astype(np.float64)
    normal = np.stack([d[:, 1], -d[:, 0]], -1) / np.linalg.norm(d, axis=-1, keepdims=True)
    along = 1 - rng.integers(0, 4, count) * float(np.finfo(dtype).eps) / 2
    x = (nodes[:count] + along[:, None] * d + 0.01 * normal).astype(dtype)
    hits = []
    for k in range(count):  # one slave against its own segment at a time
        surface = Surface(jnp.asarray(nodes), jnp.asarray(segments), jnp.arange(count) == k)
        expected = oracle_of(x[k : k + 1], surface, 0.1)
        contact = all_to_all(jnp.asarray(x[k : k + 1]), surface, radius=0.1)
        assert int(contact.vertex[0]) == int(expected.vertex[0]), k
        hits.append((float(contact.xi[0]), int(expected.vertex[0])))
    assert any(xi == 1.0 and vertex == -1 for xi, vertex in hits)  # xi alone would say "end"
    assert any(vertex == count + k for k, (_, vertex) in enumerate(hits))


def test_chains_give_arc_length_along_every_outline_in_any_order():
    """``_outline.chains`` against the oracle's walk: an open chain and two loops,
    segments shuffled, one masked (which cuts its loop open)."""
    rng = np.random.default_rng(1)
    nodes = np.concatenate([ring(7, 1.0, (0, 0)), ring(5, 0.5, (3, 0)), ring(4, 0.3, (0, 3))])
    segments = np.concatenate([loop(7), loop(5, 7), loop(4, 12)[:-1]])
    order = rng.permutation(len(segments))
    segments = segments[order]
    mask = np.ones(len(segments), bool)
    mask[np.flatnonzero(order == 3)] = False  # the first loop is cut open
    surface = Surface(jnp.asarray(nodes, FLOAT), jnp.asarray(segments), jnp.asarray(mask))
    got = chains(resolve_segments(surface))
    expected = oracle_chains(nodes, segments, mask)
    real = expected.real
    for i in np.flatnonzero(real):
        same = expected.chain[real] == expected.chain[i]
        np.testing.assert_array_equal(np.asarray(got.chain)[real] == int(got.chain[i]), same)
        # u runs from the chain's end: the oracle's s from its start.
        total = np.asarray(got.high)[real][same].max()
        np.testing.assert_allclose(
            total - float(got.high[i]), expected.s_start[i], atol=FLOAT32_SUM_ATOL
        )
    np.testing.assert_allclose(
        np.asarray(got.loop)[real], expected.loop[real], rtol=FLOAT32_SUM_RTOL
    )
    assert np.isinf(expected.loop[real]).sum() == 6 + 3  # the cut loop and the open chain


@pytest.mark.parametrize("self_contact", [False, True])
def test_gradients_with_both_bodies_deformable_are_finite_and_match_finite_differences(
    self_contact,
):
    from jax.test_util import check_grads

    x, surface, slave_node, slave_body = two_rings()
    segments, body = surface.segments, surface.body

    def energy(nodes):
        both = Surface(nodes, segments, body=body)
        contact = all_to_all(
            nodes, both, radius=0.3, pairs=Pairs(slave_node, slave_body, self_contact)
        )
        return jnp.sum(jnp.where(contact.active, contact.gap, 0) ** 2)

    grad = jax.grad(energy)(x)
    assert np.all(np.isfinite(np.asarray(grad))) and float(jnp.abs(grad).max()) > 0
    # Both bodies' nodes move the energy: as slaves and as ends of master segments.
    first = np.asarray(slave_body) == 0
    assert float(jnp.abs(grad[first]).max()) > 0 and float(jnp.abs(grad[~first]).max()) > 0
    if FLOAT is np.float64:
        check_grads(energy, (x,), order=1, modes=["rev"], eps=FD_STEP, atol=FD_ATOL, rtol=FD_RTOL)


def test_pair_keywords_under_vmap_and_lax_scan_in_a_search():
    """A batch of two scenes (shared slave nodes and bodies) searched with one
    allocation under vmap, and a scan of steps pressing the bodies together."""
    x, surface, slave_node, slave_body = two_rings()
    keywords = {"pairs": Pairs(slave_node, slave_body)}
    shifts = jnp.asarray(np.linspace(0.0, 0.1, 4), x.dtype)
    moving = jnp.stack([-jnp.asarray(slave_body == 1, x.dtype), jnp.zeros(x.shape[0], x.dtype)], -1)

    def at(shift):
        return x + shift * moving

    search = Search(radius=0.3, skin=0.05, method="binned", compact=True, slack=2.0)
    xs = jnp.stack([at(shifts[0]), at(shifts[-1])])
    surfaces = Surface(xs, surface.segments, body=surface.body)
    state = search.allocate(xs, surfaces, **keywords)
    axes = (0, 0, Surface(0, None, None, None))
    close = jax.vmap(lambda s, y, f: search.closest(s, y, f, **keywords), in_axes=axes)
    entries, _ = close(state, xs, surfaces)
    for b in range(2):
        one = jax.tree.map(lambda v, b=b: v[b], entries).to_contact(x.shape[0])
        expected = all_to_all(xs[b], surfaces._replace(nodes=xs[b]), radius=0.3, **keywords)
        np.testing.assert_array_equal(one.active, expected.active)

    single = jax.tree.map(lambda v: v[1], state)

    def step(state, shift):
        y = at(shift)
        entries, state = search.closest(
            state, y, Surface(y, surface.segments, body=surface.body), **keywords
        )
        return state, entries.to_contact(x.shape[0]).active

    final, active = jax.lax.scan(step, single, shifts)
    assert not bool(final.overflow)
    for t, shift in enumerate(shifts):
        y = at(shift)
        expected = all_to_all(y, surface._replace(nodes=y), radius=0.3, **keywords)
        np.testing.assert_array_equal(active[t], expected.active)
    assert int(active[-1].sum()) > int(active[0].sum())


def test_self_contact_needs_slave_node_and_bad_pair_inputs_are_named():
    x, surface, slave_node, slave_body = two_rings()
    cases = [
        ({"self_contact": True}, "self_contact=True) needs slave_node"),
        ({"slave_node": slave_node[:-1]}, "slave_node must have shape (N,) = (44,)"),
        ({"slave_node": slave_node.astype(np.float32)}, "an integer dtype"),
        ({"slave_body": slave_body[:, None]}, "slave_body must have shape"),
        ({"slave_node": np.full(44, 44, np.int32)}, "slave_node must be -1 or index"),
        ({"radius": np.ones(43)}, "radius must be a scalar or shape (44,)"),
        ({"radius": -np.ones(44)}, "radius must be finite and >= 0"),
        ({"self_contact": 1, "slave_node": slave_node}, "self_contact must be a bool"),
    ]
    for keywords, message in cases:
        rule = {
            k: keywords.pop(k)
            for k in ("slave_node", "slave_body", "self_contact")
            if k in keywords
        }
        keywords = {"radius": 0.1, **keywords}
        with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
            all_to_all(x, surface, pairs=Pairs(**rule), **keywords)
    bad_body = surface._replace(body=jnp.zeros(3, jnp.int32))
    with pytest.raises(ValueError, match=r"surface.body must have shape \(M,\) = \(44,\)"):
        bucket_sort(x, bad_body, radius=0.1)
    # Masked rows may hold anything, an out-of-range node included.
    node = slave_node.copy()
    node[0] = 1000
    mask = np.arange(44) > 0
    all_to_all(x, surface, radius=0.1, mask=mask, pairs=Pairs(node))
    # Under jit an out-of-range node is ignored, as an out-of-range segment index is.
    traced = jax.jit(lambda n: all_to_all(x, surface, radius=0.1, pairs=Pairs(n)))(node)
    alone = all_to_all(x, surface, radius=0.1, pairs=Pairs(np.where(node < 44, node, -1)))
    np.testing.assert_array_equal(traced.segment, alone.segment)


def test_the_version_is_the_package_metadata():
    import pathlib
    import re

    pyproject = pathlib.Path(__file__).resolve().parents[2] / "pyproject.toml"
    (version,) = re.findall(r'^version = "([^"]+)"$', pyproject.read_text(), flags=re.M)
    assert jaxcontact.__version__ == version


def three_outlines():
    """The corner outline, the folded U and a curling chip side by side, one
    surface (three chains), each slave with its own scene's radius: one
    program per detector for all three.

    Returns ``(x, surface, slave_node, radius, pressed, depth, rows)`` with
    ``rows`` the slice of each scene."""
    from jaxcontact.scenes import corner_outline, curling_chip, folded_u

    scenes = [corner_outline(dtype=FLOAT), folded_u(dtype=FLOAT), curling_chip(2_000, dtype=FLOAT)]
    nodes, segments, radius, pressed, depth, rows, first = [], [], [], [], [], [], 0
    for shift, scene in zip((0.0, 20.0, 40.0), scenes, strict=True):
        count = scene.x.shape[0]
        nodes.append(np.asarray(scene.x, np.float64) + [shift, 0.0])
        segments.append(np.asarray(scene.surface.segments) + first)
        radius.append(np.full(count, scene.radius))
        pressed.append(np.asarray(scene.pressed))
        depth.append(np.asarray(scene.depth, np.float64))
        rows.append(slice(first, first + count))
        first += count
    x = jnp.asarray(np.concatenate(nodes), FLOAT)
    surface = Surface(x, jnp.asarray(np.concatenate(segments)))
    slave_node = np.arange(first, dtype=np.int32)
    radius = jnp.asarray(np.concatenate(radius), FLOAT)
    return x, surface, slave_node, radius, np.concatenate(pressed), np.concatenate(depth), rows


def _search_self(x, surface, slave_node, radius):
    bound = float(jnp.max(radius))
    search = Search(radius=bound, skin=0.25 * bound, compact=True)
    rule = Pairs(slave_node, self_contact=True)
    state = search.allocate(x, surface, pairs=rule)
    entries, state = jax.jit(
        lambda state, x, r: search.closest(state, x, surface, radius=r, pairs=rule)
    )(state, x, radius)
    assert not bool(state.overflow)
    return entries.to_contact(x.shape[0])


SELF_CONTACT = {
    "all_to_all": lambda *scene: all_to_all(
        scene[0], scene[1], radius=scene[3], pairs=Pairs(scene[2], self_contact=True)
    ),
    "bucket_sort binned": lambda *scene: bucket_sort(
        scene[0], scene[1], radius=scene[3], pairs=Pairs(scene[2], self_contact=True)
    ),
    "Search compact": _search_self,
}


@pytest.mark.parametrize("detector", SELF_CONTACT)
def test_self_contact_reports_exactly_the_pressed_nodes_and_nothing_at_corners(detector):
    x, surface, slave_node, radius, pressed, depth, (corners, fold, chip) = three_outlines()
    contact = SELF_CONTACT[detector](x, surface, slave_node, radius)
    active = np.asarray(contact.active)
    # Convex and concave corners of 90 and 40 degrees, fine and coarse: nothing.
    assert not active[corners].any()
    # A folded U pressed into itself: exactly the pressed nodes, at their depth;
    # and a chip curling onto the machined surface, caught.
    np.testing.assert_array_equal(active, pressed)
    assert pressed[fold].sum() > 0 and pressed[chip].sum() > 0
    exact = pressed & np.isfinite(depth)
    gap = np.asarray(contact.gap)
    np.testing.assert_allclose(-gap[exact], depth[exact], atol=local_atol(FLOAT, 8.0))
    # The U's arms meet the other arm: its face's normal opposes their own face's.
    nodes, segments = np.asarray(surface.nodes), np.asarray(surface.segments)
    starting = np.full(len(nodes), -1)
    starting[segments[:, 0]] = np.arange(len(segments))
    own = nodes[segments[starting, 1]] - nodes[segments[starting, 0]]
    own_normal = np.stack([own[:, 1], -own[:, 0]], -1)
    facing = np.sum(np.asarray(contact.normal) * own_normal, axis=-1)
    assert np.all(facing[fold][pressed[fold]] < 0)
    if detector == "all_to_all":
        # Without the neighbourhood rule the corners report false contact.
        plain = all_to_all(x, surface, radius=radius, pairs=Pairs(slave_node))
        assert np.asarray(plain.active)[corners].sum() > 0
