"""Per-dtype tolerances and the field-by-field comparison with the oracle.

Every tolerance in the suite comes from tests/support/tolerances.py (re-exported
here). The detectors' geometry bounds below are built from its first group,
counted in units in the last place (ulps) of a length that the test names:

- ``scale``: the size of the local geometry (segment lengths, slave-to-segment
  distances). Gaps, projection coordinates and crossing times are computed
  from differences of nearby inputs, so their error is a few ulps of this.
- ``offset``: the magnitude of the coordinates themselves. A point is a
  coordinate, so it cannot be closer to the exact answer than its own rounding
  to the dtype: half an ulp of ``offset``, plus the local error.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

import jaxcontact
from jaxcontact._detect import at_sizes
from jaxcontact._query.closest import CLOSEST
from jaxcontact._query.swept import SWEPT
from jaxcontact.forces import penalty
from tests.support.oracle import OracleContact, OracleCrossing, oracle_contact, oracle_crossing
from tests.support.tolerances import *  # noqa: F403 (the table, re-exported)
from tests.support.tolerances import BINNED_ULPS, GRADIENT_EPS, LOCAL_ULPS

FLOAT_DTYPES = (np.float32, np.float64)

# The widest float of the suite's mode (tests/conftest.py): float64 with x64
# on, float32 with it off, as NumPy float64 inputs are then computed. Tests
# that ask for precision rather than for a dtype use this one, so they run in
# both modes.
FLOAT = np.dtype(jax.dtypes.canonicalize_dtype(np.float64)).type
X64 = FLOAT is np.float64
# The float dtypes this mode computes in: what hypothesis draws from.
MODE_DTYPES = FLOAT_DTYPES if X64 else (np.float32,)


def eps(dtype) -> float:
    return float(np.finfo(np.dtype(dtype)).eps)


# XLA's default CPU code generation, as users compile (``jax.jit(...,
# compiler_options=XLA_DEFAULTS)``), for the few tests whose checks need it:
# the suite compiles without LLVM's optimisation (tests/conftest.py), where
# LLVM's fast instruction selector leaves part of a loop to the full one, and
# only the full one contracts a*b+c into a fused multiply-add, so the same
# numbers can round two ways in one program.
XLA_DEFAULTS = {"xla_backend_optimization_level": 3, "xla_cpu_use_fusion_emitters": True}


def local_atol(dtype, scale: float = 1.0) -> float:
    """Absolute tolerance for a value of size ``scale`` computed in ``dtype``."""
    return LOCAL_ULPS[np.dtype(dtype)] * eps(dtype) * scale


def gradient_atol(dtype) -> float:
    """Gradients of the same pair from two compiled programs (a detector and
    the dense one), which contract into fused multiply-adds differently:
    ``GRADIENT_EPS`` eps, 1e-12 in float64."""
    return GRADIENT_EPS * eps(dtype)


def coordinate_ulp(dtype, offset: float) -> float:
    """One ulp of a coordinate of magnitude ``offset`` in ``dtype`` (0 at the origin)."""
    return float(np.spacing(np.asarray(abs(offset), dtype))) if offset else 0.0


def _assert_close(name, actual, expected, atol):
    error = np.abs(np.asarray(actual, np.float64) - np.asarray(expected, np.float64))
    worst = float(error.max()) if error.size else 0.0
    assert worst <= atol, f"{name}: max error {worst:.3g} > tolerance {atol:.3g}"


def _assert_dtypes(result, dtype, float_fields, int_fields, bool_fields):
    for field in float_fields:
        assert getattr(result, field).dtype == np.dtype(dtype), (
            field,
            getattr(result, field).dtype,
        )
    for field in int_fields:
        assert getattr(result, field).dtype == np.int32, (field, getattr(result, field).dtype)
    for field in bool_fields:
        assert getattr(result, field).dtype == np.bool_, (field, getattr(result, field).dtype)


def assert_all_finite(result):
    for field, value in result._asdict().items():
        value = np.asarray(value)
        if value.dtype.kind == "f":
            assert np.all(np.isfinite(value)), f"{field} has non-finite values: {value}"


def assert_contact_matches(
    contact, expected: OracleContact, dtype, *, scale: float = 1.0, offset: float = 0.0
):
    """Every field of ``contact`` (one scene, unbatched) against the oracle."""
    _assert_dtypes(
        contact,
        dtype,
        ("gap", "xi", "point", "normal"),
        ("segment",),
        ("found", "active", "overflow"),
    )
    assert contact.gap.shape == expected.gap.shape
    assert contact.point.shape == expected.point.shape
    assert_all_finite(contact)
    assert not bool(contact.overflow)
    np.testing.assert_array_equal(np.asarray(contact.segment), expected.segment, "segment")
    np.testing.assert_array_equal(np.asarray(contact.found), expected.found, "found")
    np.testing.assert_array_equal(np.asarray(contact.active), expected.active, "active")
    atol = local_atol(dtype, scale)
    _assert_close("gap", contact.gap, expected.gap, atol)
    _assert_close("xi", contact.xi, expected.xi, local_atol(dtype))
    _assert_close("normal", contact.normal, expected.normal, local_atol(dtype))
    _assert_close("point", contact.point, expected.point, atol + coordinate_ulp(dtype, offset))


def assert_crossing_matches(
    crossing, expected: OracleCrossing, dtype, *, scale: float = 1.0, offset: float = 0.0
):
    """Every field of ``crossing`` (one scene, unbatched) against the oracle.

    ``scale`` here is the ratio of the local geometry to the path length, the
    conditioning of ``t``.
    """
    _assert_dtypes(crossing, dtype, ("t", "point"), ("segment",), ("crossed", "overflow"))
    assert crossing.t.shape == expected.t.shape
    assert crossing.point.shape == expected.point.shape
    assert_all_finite(crossing)
    assert not bool(crossing.overflow)
    np.testing.assert_array_equal(np.asarray(crossing.segment), expected.segment, "segment")
    np.testing.assert_array_equal(np.asarray(crossing.crossed), expected.crossed, "crossed")
    _assert_close("t", crossing.t, expected.t, local_atol(dtype, scale))
    _assert_close(
        "point",
        crossing.point,
        expected.point,
        local_atol(dtype, scale) + coordinate_ulp(dtype, offset),
    )


class Scene(NamedTuple):
    """The suite's one scene type: NumPy, already in its dtype; masks may be None.

    The library's ``jaxcontact.scenes.Scene`` holds a ``Surface`` of device
    arrays and no slave mask; the oracle and the checks read NumPy rows.
    """

    x_prev: np.ndarray  # f[N, 2]
    x: np.ndarray  # f[N, 2]
    nodes: np.ndarray  # f[P, 2]
    segments: np.ndarray  # i32[M, 2]
    seg_mask: np.ndarray | None  # bool[M]
    slave_mask: np.ndarray | None  # bool[N]
    radius: float


def random_scene(
    seed: int,
    num_slaves: int,
    num_segments: int,
    dtype=FLOAT,
    *,
    masked: bool = False,
    offset: float = 0.0,
    scale: float = 1.0,
) -> Scene:
    """Slaves scattered around random segments, some of them chained.

    About half the segments start where the previous one ended (so vertices
    are shared and vertex ties occur); the others start afresh. There are
    always ``2 * num_segments + 1`` nodes, so scenes of the same sizes stack
    into a batch; nodes no segment uses are harmless padding. The geometry
    lives in a box of half-width ``scale`` centred at ``(offset, offset)``;
    coordinates are drawn in float64 and rounded once to ``dtype``.
    """
    rng = np.random.default_rng(seed)
    nodes = rng.uniform(-1, 1, (2 * num_segments + 1, 2))
    segments, last = [], 0
    for _ in range(num_segments):
        start = last if rng.uniform() < 0.5 else last + 1
        last = start + 1
        segments.append([start, last])
    x = rng.uniform(-1.2, 1.2, (num_slaves, 2))
    x_prev = x + rng.uniform(-1.0, 1.0, (num_slaves, 2))

    def place(points):
        return (np.asarray(points, np.float64).reshape(-1, 2) * scale + offset).astype(dtype)

    return Scene(
        x_prev=place(x_prev),
        x=place(x),
        nodes=place(nodes),
        segments=np.asarray(segments, np.int32).reshape(-1, 2),
        seg_mask=rng.uniform(size=num_segments) < 0.8 if masked else None,
        slave_mask=rng.uniform(size=num_slaves) < 0.8 if masked else None,
        radius=0.3 * scale,
    )


def surface_of(scene: Scene) -> jaxcontact.Surface:
    mask = None if scene.seg_mask is None else jnp.asarray(scene.seg_mask)
    return jaxcontact.Surface(jnp.asarray(scene.nodes), jnp.asarray(scene.segments), mask)


def slave_mask_of(scene: Scene):
    return None if scene.slave_mask is None else jnp.asarray(scene.slave_mask)


def contact_oracle(scene: Scene) -> OracleContact:
    return oracle_contact(
        scene.x, scene.nodes, scene.segments, scene.seg_mask, scene.slave_mask, scene.radius
    )


def crossing_oracle(scene: Scene) -> OracleCrossing:
    return oracle_crossing(
        scene.x_prev, scene.x, scene.nodes, scene.segments, scene.seg_mask, scene.slave_mask
    )


def pad_scene(scene: Scene, fill: float):
    """``scene`` with padding slaves, nodes and segments filled with ``fill``.

    Returns the padded scene and, for each real slave and segment, its row in
    the padded arrays. Padding segments sit between real ones and use padding
    nodes only, or a real node and a padding node.
    """
    dtype = scene.x.dtype
    num_slaves, num_segments, num_nodes = len(scene.x), len(scene.segments), len(scene.nodes)
    slave_rows = np.arange(num_slaves) * 2 + 1  # a padding slave before each real one
    x = np.full((2 * num_slaves + 1, 2), fill, dtype)
    x_prev = np.full_like(x, fill)
    x[slave_rows], x_prev[slave_rows] = scene.x, scene.x_prev
    slave_mask = np.zeros(len(x), bool)
    slave_mask[slave_rows] = True if scene.slave_mask is None else scene.slave_mask
    nodes = np.concatenate([scene.nodes, np.full((2, 2), fill, dtype)])
    segment_rows = np.arange(num_segments) * 2 + 1
    segments = np.tile(np.array([[num_nodes, num_nodes + 1]], np.int32), (2 * num_segments + 1, 1))
    segments[0] = [0, num_nodes]  # a real node and a padding node
    segments[segment_rows] = scene.segments
    seg_mask = np.zeros(len(segments), bool)
    seg_mask[segment_rows] = True if scene.seg_mask is None else scene.seg_mask
    padded = scene._replace(
        x_prev=x_prev, x=x, nodes=nodes, segments=segments, seg_mask=seg_mask, slave_mask=slave_mask
    )
    return padded, slave_rows, segment_rows


def everything_masked(masked: str) -> Scene:
    """A random scene with every slave (``"slaves"``) or segment (``"segments"``) masked."""
    scene = random_scene(3, 9, 5, masked=True)
    if masked == "slaves":
        return scene._replace(slave_mask=np.zeros(9, bool))
    return scene._replace(seg_mask=np.zeros(5, bool))


def assert_padding_leaves_real_rows_unchanged(checked_scene, fill: float, fields, flag: str):
    """Padding a random scene with ``fill`` rows changes none of its real rows.

    ``checked_scene`` runs a detector on a scene and checks it against the
    oracle (and that every output is finite); ``fields`` are compared row by
    row, segments through the padding's renumbering; padded rows must have
    ``flag`` False and segment -1. Some real slaves and segments are masked
    too (finite, as real data).
    """
    scene = random_scene(5, 9, 5, masked=True)
    plain = checked_scene(scene)
    padded_scene, slave_rows, segment_rows = pad_scene(scene, fill)
    padded = checked_scene(padded_scene)
    segment = np.asarray(plain.segment)
    mapped = np.where(segment >= 0, segment_rows[np.maximum(segment, 0)], -1)
    np.testing.assert_array_equal(padded.segment[slave_rows], mapped)
    for field in fields:
        np.testing.assert_array_equal(getattr(padded, field)[slave_rows], getattr(plain, field))
    padding = np.ones(len(padded_scene.x), bool)
    padding[slave_rows] = False
    assert not getattr(padded, flag)[padding].any()
    np.testing.assert_array_equal(padded.segment[padding], -1)


# Every hand-made scene of the special-case tests is padded to this one
# capacity (slaves, nodes, segments), so that they all share one compiled
# program per dtype: each distinct shape costs the suite about a second of XLA
# compilation. The padding rows come after the real ones and are masked; that
# padding never changes a real row is part of the contract, tested on its own.
CAPACITY = (6, 8, 5)


def padded_scene(x_prev, x, nodes, segments, *, radius=0.0, dtype=FLOAT) -> Scene:
    """A hand-made scene padded to ``CAPACITY`` with masked rows after the real ones."""
    x_prev = np.asarray(x_prev, dtype).reshape(-1, 2)
    x = np.asarray(x, dtype).reshape(-1, 2)
    nodes = np.asarray(nodes, dtype).reshape(-1, 2)
    segments = np.asarray(segments, np.int32).reshape(-1, 2)
    num_slaves, num_nodes, num_segments = len(x), len(nodes), len(segments)
    assert num_slaves <= CAPACITY[0] and num_nodes <= CAPACITY[1] and num_segments <= CAPACITY[2]

    def fill(rows, capacity):
        padded = np.zeros((capacity,) + rows.shape[1:], rows.dtype)
        padded[: len(rows)] = rows
        return padded

    return Scene(
        x_prev=fill(x_prev, CAPACITY[0]),
        x=fill(x, CAPACITY[0]),
        nodes=fill(nodes, CAPACITY[1]),
        segments=fill(segments, CAPACITY[2]),
        seg_mask=np.arange(CAPACITY[2]) < num_segments,
        slave_mask=np.arange(CAPACITY[0]) < num_slaves,
        radius=radius,
    )


def shared_vertices(scene: Scene) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``(vertex, previous node, next node)`` where segment k ends and segment k + 1 starts."""
    corners = []
    for (a, v), (w, b) in zip(scene.segments[:-1], scene.segments[1:], strict=True):
        if v == w and scene.nodes[a].tolist() != scene.nodes[v].tolist() != scene.nodes[b].tolist():
            corners.append((scene.nodes[v], scene.nodes[a], scene.nodes[b]))
    return corners


def blind_spot(vertex, previous, following, distance: float) -> np.ndarray:
    """f64[2]: a point ``distance`` from ``vertex`` whose closest point on both of
    its segments is the vertex itself: opposite to both segment directions."""
    vertex, previous, following = (np.asarray(p, np.float64) for p in (vertex, previous, following))
    back = previous - vertex
    ahead = following - vertex
    away = -(back / np.linalg.norm(back) + ahead / np.linalg.norm(ahead))
    if np.linalg.norm(away) < 1e-3:  # straight through: any normal direction will do
        away = np.array([back[1], -back[0]])
    return vertex + distance * away / np.linalg.norm(away)


def binned_tolerance(dtype, points):
    """Rounding of the per-pair kernel: a few ulps of the coordinates' scale.

    XLA contracts a*b+c into fused multiply-adds differently in different
    fusions, so the same kernel on the same pair may round differently in the
    dense and the binned program.
    """
    return (
        BINNED_ULPS * float(jnp.finfo(dtype).eps) * (1 + float(jnp.max(jnp.abs(points), initial=0)))
    )


def assert_same_contact(binned, dense, radius=None, degenerate=False):
    """The same rows, up to rounding.

    Rows must choose the same segment, except where two segments lie at the
    same distance to within rounding (overlapping or touching segments), where
    either is correct and the gaps' magnitudes must agree; and ``found`` may
    differ only for a slave at the radius to within rounding.
    """
    assert not bool(binned.overflow)
    tol = binned_tolerance(dense.gap.dtype, dense.point)
    both = np.asarray(binned.found & dense.found)
    same = np.asarray(binned.segment == dense.segment)
    np.testing.assert_allclose(np.abs(binned.gap)[both], np.abs(dense.gap)[both], atol=tol)
    flipped = np.asarray(binned.found != dense.found)
    if flipped.any():
        assert radius is not None, "found differs and no radius to explain it"
        distance = np.where(binned.found, np.abs(binned.gap), np.abs(dense.gap))[flipped]
        np.testing.assert_allclose(distance, radius, atol=tol)
    agree = both & same
    for field in ("gap", "xi", "point", "normal"):
        got, want = np.asarray(getattr(binned, field)), np.asarray(getattr(dense, field))
        np.testing.assert_allclose(got[agree], want[agree], atol=tol)
    if not degenerate:
        # Rows that differ for rounding must be rare, never the rule.
        assert (both & ~same).sum() <= max(2, 0.01 * both.sum())


def assert_same_crossing(binned, dense, degenerate=False):
    """The same rows, up to rounding; an earliest-crossing tie may go either way."""
    assert not bool(binned.overflow)
    tol = binned_tolerance(dense.t.dtype, dense.point)
    np.testing.assert_array_equal(binned.crossed, dense.crossed)
    np.testing.assert_allclose(binned.t, dense.t, atol=tol)
    same = np.asarray(binned.segment == dense.segment)
    got, want = np.asarray(binned.point), np.asarray(dense.point)
    np.testing.assert_allclose(got[same], want[same], atol=tol)
    if not degenerate:
        assert (~same).sum() <= max(2, 0.01 * np.asarray(dense.crossed).sum())


# The bucket sort at sizes the test fixes. ``bucket_sort`` and ``bucket_swept``
# measure their own sizes from concrete data, and ``Search`` finds candidates
# first; tests of the pipeline itself (property tests at one compiled shape,
# starved sizes that must overflow, chunked searches) call the sized stages
# directly, with the input checks the public detectors make.


def penalty_total(contact, surface, stiffness, **keywords):
    """``(on_slaves, the master's total force)`` of ``forces.penalty``."""
    forces = penalty(contact, surface, stiffness, **keywords)
    return forces.on_slaves, jnp.sum(forces.on_master, axis=0)


def sized_bucket_sort(x, surface, *, radius, mask=None, sizes, candidates=None, pairs=None):
    """``bucket_sort`` at ``sizes``, inputs checked (``_detect.at_sizes``)."""
    return at_sizes(CLOSEST, (x,), surface, radius, mask, sizes, candidates, pairs)


def sized_bucket_swept(x_prev, x, surface, *, mask=None, sizes, pairs=None):
    """``bucket_swept`` at ``sizes``, inputs checked (``_detect.at_sizes``)."""
    return at_sizes(SWEPT, (x_prev, x), surface, None, mask, sizes, pairs=pairs)


ROOT = Path(__file__).resolve().parents[2]  # the repository: tests/support/helpers.py


def assert_pytest_passes_in_subprocess(args, env, timeout=900):
    """``python -m pytest -q args`` in a process of its own, its environment
    ``os.environ`` updated with ``env`` (what JAX fixes when it starts: the
    device count, the x64 mode), passes."""
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *args],
        cwd=ROOT,
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert done.returncode == 0, done.stdout[-6000:] + done.stderr[-3000:]
    assert " passed" in done.stdout
