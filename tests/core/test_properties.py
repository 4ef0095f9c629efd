"""Property tests: every public detector against the exact oracle, at the hard places.

Scenes are drawn by hypothesis and padded to ONE fixed shape (``NUM_SLAVES``
slaves, ``NUM_SEGMENTS`` segments, masked padding), so each detector compiles
once per dtype. Slaves are placed where contact codes fail: on vertices and
segments, on the bisectors of corners, at ``radius +- eps``, nearly collinear
with a segment, beside a segment 1e-9 long, far from the origin; paths graze
an end point, run parallel to or along a segment, stop on it or do not move.

Every row is checked against the exact oracle within the bounds stated in
tests/exact_checks.py. Hypothesis settings come from the profile in tests/conftest.py.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import jaxcontact
from jaxcontact import Sizes, Surface
from tests.support import oracle
from tests.support.exact_checks import ULPS, check_contact, check_crossing
from tests.support.helpers import (
    Scene,
    assert_all_finite,
    blind_spot,
    sized_bucket_sort,
    sized_bucket_swept,
    surface_of,
)

NUM_SLAVES = 16
NUM_SEGMENTS = 56  # above the 48 where bucket_sort's own sizes switch to cells
NUM_NODES = NUM_SEGMENTS + 1


def _sizes(use_cells: bool, for_paths: bool) -> Sizes:
    """Sizes that cannot overflow at the fixed shape: every block, every segment per cell."""
    return Sizes(
        num_slaves=NUM_SLAVES,
        block_size=8,
        block_capacity=NUM_SLAVES // 8,
        for_paths=for_paths,
        use_cells=use_cells,
        grid_shape=(8, 8) if use_cells else (1, 1),
        cell_size=0.5 if use_cells else 0.0,
        span=(8, 8) if use_cells else (1, 1),
        cell_capacity=NUM_SEGMENTS if use_cells else 1,
    )


def _bucket_sort(cells):
    sizes = _sizes(cells, for_paths=False)
    return jax.jit(lambda x, s, r, m: sized_bucket_sort(x, s, radius=r, mask=m, sizes=sizes))


def _bucket_swept(cells):
    sizes = _sizes(cells, for_paths=True)
    return jax.jit(lambda p, x, s, m: sized_bucket_swept(p, x, s, mask=m, sizes=sizes))


# One jitted function per detector, shared by every example (one compilation per dtype).
CONTACT_DETECTORS = {
    "all_to_all": jax.jit(lambda x, s, r, m: jaxcontact.all_to_all(x, s, radius=r, mask=m)),
    "bucket_sort": _bucket_sort(False),
    "bucket_sort_cells": _bucket_sort(True),
}
CROSSING_DETECTORS = {
    "swept": jax.jit(lambda p, x, s, m: jaxcontact.swept(p, x, s, mask=m)),
    "bucket_swept": _bucket_swept(False),
    "bucket_swept_cells": _bucket_swept(True),
}


def _unit(v):
    return v / np.linalg.norm(v)


# Where slaves go, relative to a segment (a, b) and its neighbour c after b;
# ``s`` in [0, 1] and ``h`` a signed offset scale are drawn.
def _place(kind, a, b, c, s, h, tiny):
    d = b - a
    normal = np.array([d[1], -d[0]]) / max(np.linalg.norm(d), 1e-300)
    if kind == "vertex":
        return b
    # blind_spot divides by these norms: a neighbour whose length underflows has no bisector.
    if kind.startswith("bisector") and 0 in (np.linalg.norm(a - b), np.linalg.norm(c - b)):
        kind = "near"  # a zero-length neighbour has no bisector
    if kind == "on_segment":
        return a + s * d
    if kind == "bisector_out":
        return blind_spot(b, a, c, abs(h) + 1e-3)
    if kind == "bisector_in":
        return 2 * b - blind_spot(b, a, c, abs(h) + 1e-3)
    if kind == "nearly_collinear":
        return a + s * d + tiny * normal
    if kind == "beyond_end":  # on the segment's line, past its end
        return b + (0.5 + s) * d
    return a + s * d + h * normal  # "near"


SLAVE_KINDS = (
    "vertex",
    "on_segment",
    "bisector_out",
    "bisector_in",
    "nearly_collinear",
    "beyond_end",
    "near",
)
PATH_KINDS = ("random", "graze_vertex", "parallel", "along", "stop_on", "still")


def _path_start(kind, x, a, b, move):
    if kind == "graze_vertex":  # through b, at t = 1/2 in exact arithmetic
        return 2 * b - x
    if kind == "parallel":
        return x - (b - a) * (1 + move[0])
    if kind == "along":
        return a - (b - a) * move[0]
    if kind == "stop_on":  # ends on the segment; x itself moves onto it below
        return x + move
    if kind == "still":
        return x
    return x + 2 * move


@st.composite
def scenes(draw, dtype):
    """A polyline (grid or free coordinates, maybe closed, maybe with a 1e-9 segment)
    and slaves and paths at its hard places."""
    grid = draw(st.booleans())
    num_nodes = draw(st.integers(2, 8))
    if grid:
        # Multiples of 1/8: orientations of such points are exact in both dtypes.
        nodes = np.array(draw(st.lists(st.tuples(*[st.integers(-24, 24)] * 2), min_size=num_nodes,
                                       max_size=num_nodes)), np.float64) / 8  # fmt: skip
    else:
        coordinate = st.floats(-3, 3, allow_nan=False, allow_infinity=False)
        nodes = np.array(draw(st.lists(st.tuples(coordinate, coordinate), min_size=num_nodes,
                                       max_size=num_nodes)), np.float64)  # fmt: skip
    if draw(st.booleans()):  # a segment 1e-9 long after the first node
        direction = _unit(np.array(draw(st.sampled_from([(1.0, 0.0), (0.6, 0.8), (-0.28, 0.96)]))))
        nodes = np.concatenate([nodes[:1], nodes[:1] + 1e-9 * direction, nodes[1:]])
    nodes = nodes[:NUM_NODES]
    # Flushed as the placed scene is below, before slaves are placed from it:
    # a drawn 7e-167 made |b - a| underflow to 0 in blind_spot (a division by zero).
    nodes[np.abs(nodes) < np.sqrt(np.finfo(dtype).tiny)] = 0
    count = len(nodes)
    segments = [[k, k + 1] for k in range(count - 1)]
    if count > 2 and draw(st.booleans()):
        segments.append([count - 1, 0])
    offset = draw(st.sampled_from([0.0, 0.0, 1024.0, 1e6 if dtype == np.float64 else 2.0**20]))

    slaves, starts = [], []
    for _ in range(NUM_SLAVES):
        k = draw(st.integers(0, len(segments) - 1))
        a, b = nodes[segments[k][0]], nodes[segments[k][1]]
        following = [j for j in segments if j[0] == segments[k][1]]
        c = nodes[following[0][1]] if following else b + (b - a)
        s = draw(st.sampled_from([0.0, 0.25, 0.5, 1.0]) | st.floats(0, 1))
        h = draw(st.sampled_from([0.0, 0.125, -0.125]) | st.floats(-1, 1))
        tiny = draw(st.sampled_from([1e-7, -1e-7, 1e-12, -1e-12]))
        x = _place(draw(st.sampled_from(SLAVE_KINDS)), a, b, c, s, h, tiny)
        move = np.array(draw(st.tuples(st.floats(-1, 1), st.floats(-1, 1))))
        path = draw(st.sampled_from(PATH_KINDS))
        start = _path_start(path, x, a, b, move)
        if path == "stop_on":
            x = a + s * (b - a)
        slaves.append(x)
        starts.append(start)

    def place(points, rows):
        padded = np.zeros((rows, 2))
        padded[: len(points)] = np.asarray(points).reshape(-1, 2)
        placed = (padded + offset).astype(dtype)
        # XLA on the CPU flushes subnormal results to zero, so coordinates
        # whose products would be subnormal (below sqrt(tiny), 1e-19 in
        # float32) are outside what any JAX program can resolve: zero them.
        placed[np.abs(placed) < np.sqrt(np.finfo(dtype).tiny)] = 0
        return placed

    padded_segments = np.zeros((NUM_SEGMENTS, 2), np.int32)
    padded_segments[: len(segments)] = segments
    scene = Scene(
        x_prev=place(starts, NUM_SLAVES),
        x=place(slaves, NUM_SLAVES),
        nodes=place(nodes, NUM_NODES),
        segments=padded_segments,
        seg_mask=np.arange(NUM_SEGMENTS) < len(segments),
        slave_mask=None,
        radius=0.0,
    )
    # The radius: a round number, or the exact distance of one slave +- a few
    # eps of it, which puts that slave at the hard place radius +- eps.
    which = draw(st.integers(0, NUM_SLAVES - 1))
    pairs = oracle.exact_pairs(scene.x[which], scene.nodes, scene.segments, scene.seg_mask)
    nearest = math.sqrt(min(float(p.distance_squared) for p in pairs)) if pairs else 0.0
    bump = draw(st.sampled_from([0, 1, -1, 4 * ULPS, -4 * ULPS])) * np.finfo(dtype).eps
    radius = draw(st.sampled_from([0.0, 0.125, 0.5, 2.0]) | st.just(nearest * (1 + bump)))
    return scene._replace(radius=max(radius, 0.0))


def _with_bad_rows(values: np.ndarray, rows, fill) -> np.ndarray:
    bad = values.copy()
    bad[list(rows)] = fill
    return bad


def check_bad_rows_ignored(run, clean, rows, flag):
    """A NaN or inf row is not found and changes no other row: ``run(rows)`` vs ``clean``."""
    result = run(rows)
    assert_all_finite(result)
    keep = np.ones(NUM_SLAVES, bool)
    keep[list(rows)] = False
    assert not np.asarray(getattr(result, flag))[~keep].any()
    assert (np.asarray(result.segment)[~keep] == -1).all()
    for field, value in result._asdict().items():
        if np.ndim(value):
            np.testing.assert_array_equal(
                np.asarray(value)[keep], np.asarray(getattr(clean, field))[keep], field
            )


DTYPES = pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["float32", "float64"])
BAD_ROWS = st.sets(st.integers(0, NUM_SLAVES - 1), max_size=3)
FILLS = st.sampled_from([np.nan, np.inf, -np.inf])


@DTYPES
@pytest.mark.parametrize("name", sorted(CONTACT_DETECTORS))
@given(data=st.data())
def test_contact_matches_exact_oracle_at_hard_places(name, dtype, data):
    scene = data.draw(scenes(dtype))
    detect = CONTACT_DETECTORS[name]
    surface = surface_of(scene)
    radius = jnp.asarray(scene.radius, dtype)
    mask = jnp.ones(NUM_SLAVES, bool)
    contact = detect(jnp.asarray(scene.x), surface, radius, mask)
    check_contact(contact, scene, dtype)
    rows, fill = data.draw(BAD_ROWS), data.draw(FILLS)

    def run(rows):
        return detect(jnp.asarray(_with_bad_rows(scene.x, rows, fill)), surface, radius, mask)

    check_bad_rows_ignored(run, contact, rows, "found")


@DTYPES
@pytest.mark.parametrize("name", sorted(CROSSING_DETECTORS))
@given(data=st.data())
def test_crossing_matches_exact_oracle_at_hard_places(name, dtype, data):
    scene = data.draw(scenes(dtype))
    detect = CROSSING_DETECTORS[name]
    surface = surface_of(scene)
    mask = jnp.ones(NUM_SLAVES, bool)
    crossing = detect(jnp.asarray(scene.x_prev), jnp.asarray(scene.x), surface, mask)
    check_crossing(crossing, scene, dtype)
    rows, fill = data.draw(BAD_ROWS), data.draw(FILLS)
    at_start = data.draw(st.booleans())

    def run(rows):
        x_prev = _with_bad_rows(scene.x_prev, rows if at_start else (), fill)
        x = _with_bad_rows(scene.x, () if at_start else rows, fill)
        return detect(jnp.asarray(x_prev), jnp.asarray(x), surface, mask)

    check_bad_rows_ignored(run, crossing, rows, "crossed")


@pytest.mark.x64  # checked as float64 scenes
def test_plain_bucket_calls_measure_their_sizes_with_and_without_cells():
    # The one-call bucket detectors measure their own sizes: with NUM_SEGMENTS
    # (> 48) segments those bin them in cells, with a few they do not.
    scene = Scene(
        x_prev=np.zeros((NUM_SLAVES, 2)),
        x=np.linspace([-1.0, -0.5], [2.0, 0.75], NUM_SLAVES),
        nodes=np.stack([np.linspace(-1, 2, NUM_NODES), np.sin(np.arange(NUM_NODES))], -1) / 2,
        segments=np.stack([np.arange(NUM_SEGMENTS), np.arange(1, NUM_NODES)], -1).astype(np.int32),
        seg_mask=np.ones(NUM_SEGMENTS, bool),
        slave_mask=None,
        radius=0.25,
    )
    for count in (4, NUM_SEGMENTS):
        few = scene._replace(seg_mask=np.arange(NUM_SEGMENTS) < count)
        surface = Surface(jnp.asarray(few.nodes), jnp.asarray(few.segments[:count]))
        contact = jaxcontact.bucket_sort(jnp.asarray(few.x), surface, radius=few.radius)
        check_contact(contact, few, np.float64)
        crossing = jaxcontact.bucket_swept(jnp.asarray(few.x_prev), jnp.asarray(few.x), surface)
        check_crossing(crossing, few, np.float64)
        assert contact.found.any() and crossing.crossed.any()


def test_slaves_are_placed_beside_a_segment_whose_length_underflows():
    # Regression (found by CI): nodes (0, 0) and (0, 7e-167), whose distance
    # squares to 0, made the bisector placement divide by zero.
    a, b = np.zeros(2), np.array([0.0, 7.31496951e-167])
    for kind in ("bisector_out", "bisector_in"):
        assert np.all(np.isfinite(_place(kind, a, b, a, 0.5, 0.125, 1e-7)))
