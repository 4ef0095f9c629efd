"""Masked segments are padding: their indices may hold anything (issue 14).

Meshing and padding code write ``-1`` (or the node count, or the largest
int32) into the segments it pads. Such a segment, masked, must change no real
row's result in any path (plain, ``jit``, ``vmap``, ``grad``; every detector,
``Search``, ``validate``, ``jax.shard_map``), and must not make a plain call raise;
a real segment's index out of range still raises where it is concrete.

Each padded scene is compared with the same scene without the padding
segment. The padding row is adversarial: a sentinel clamped into range reads
node 0 or the far node 4, so ``[1, -1]`` read unmasked would be segment 0
reversed, and ``[-1, 2]`` a segment under the slaves.
"""

import functools
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import (
    Contact,
    Search,
    Surface,
    all_to_all,
    bucket_sort,
    bucket_swept,
    swept,
    validate,
)
from jaxcontact._pipeline.candidates import Candidates
from jaxcontact._pipeline.sizes import measure
from tests.support.helpers import FLOAT, local_atol, penalty_total

RADIUS = 0.25
# A floor listed right to left (normals up) with two corners, and node 4,
# far away, that no real segment uses.
NODES = np.array([[3.0, 0.5], [2.0, 0.0], [1.0, 0.0], [0.0, 0.3], [50.0, 40.0]])
REAL = np.array([[0, 1], [1, 2], [2, 3]], np.int32)
# Outside, penetrating, near the vertex at node 1, out of reach, near
# segment 0, under segment 2.
X = np.array([[1.5, 0.05], [1.2, -0.1], [2.0, 0.1], [0.5, 3.0], [2.6, 0.2], [0.5, 0.1]])
X_PREV = X + np.array([0.05, 0.3])

SENTINELS = {"minus_one": -1, "num_nodes": len(NODES), "int32_max": 2**31 - 1}
WHERE = ("end", "middle")
TRANSFORMS = ("plain", "jit")
DETECTORS = ("all_to_all", "swept", "bucket_sort", "bucket_swept")
# Fields that hold a segment index, renumbered when padding sits in the middle.
INDEX_FIELDS = ("segment",)


def padded_rows(sentinel: int, where: str, real=REAL):
    """(i32[M + 1, 2] segments, bool[M + 1] mask, i32[M] where each real segment went)."""
    if where == "end":
        rows = [*real, [sentinel, 2]]
        return np.array(rows), np.array([True] * len(real) + [False]), np.arange(len(real))
    rows = [real[0], [1, sentinel], *real[1:]]
    mask = np.array([True, False] + [True] * (len(real) - 1))
    return np.array(rows), mask, np.array([0] + list(range(2, len(real) + 1)))


def padded(sentinel: int, where: str, dtype=FLOAT):
    """The floor with one masked padding segment; and where the real ones went."""
    segments, mask, moved = padded_rows(sentinel, where)
    surface = Surface(
        jnp.asarray(NODES, dtype), jnp.asarray(segments, jnp.int32), jnp.asarray(mask)
    )
    return surface, moved


def unpadded(dtype=FLOAT) -> Surface:
    return Surface(jnp.asarray(NODES, dtype), jnp.asarray(REAL))


def renumbered(segment, moved):
    """A result's segment indices in the unpadded scene, as in the padded one."""
    segment = np.asarray(segment)
    return np.where(segment >= 0, moved[np.maximum(segment, 0)], -1)


def assert_same_rows(got, want, moved, dtype=FLOAT):
    """Every field of ``got`` (padded) is ``want``'s (unpadded), and finite."""
    for field, value in zip(got._fields, got, strict=True):
        value, expected = np.asarray(value), np.asarray(getattr(want, field))
        assert np.isfinite(value.astype(np.float64)).all(), field
        if field in INDEX_FIELDS:
            expected = renumbered(expected, moved)
        if value.dtype.kind == "f":
            np.testing.assert_allclose(
                value, expected, rtol=0, atol=local_atol(dtype), err_msg=field
            )
        else:
            np.testing.assert_array_equal(value, expected, err_msg=field)


# Module-level functions, so that each is compiled once per shape.
def _contact(x_prev, x, surface):
    return all_to_all(x, surface, radius=RADIUS)


def _crossing(x_prev, x, surface):
    return swept(x_prev, x, surface)


@functools.partial(jax.jit, static_argnums=0)
def _closest_step(search, state, x, surface):
    return search.closest(state, x, surface)


@functools.partial(jax.jit, static_argnums=0)
def _swept_step(search, state, x_prev, x, surface):
    return search.swept(state, x_prev, x, surface)


JITTED = {"all_to_all": jax.jit(_contact), "swept": jax.jit(_crossing)}
BINNED = Search(radius=RADIUS, method="binned")
# Keeps candidates: its skin rule reads the segments' node indices.
SKIN = Search(radius=RADIUS, skin=0.1, method="binned")
PATHS = ("swept", "bucket_swept", "search_swept")


def detect(name: str, transform: str, surface: Surface, x_prev=X_PREV, x=X):
    """``name``'s result; the bucket detectors under jit are a ``Search``
    allocated outside (they measure their sizes on the host)."""
    if name in JITTED:
        plain = {"all_to_all": _contact, "swept": _crossing}[name]
        return (JITTED[name] if transform == "jit" else plain)(x_prev, x, surface)
    if transform == "plain":
        if name == "bucket_sort":
            return bucket_sort(x, surface, radius=RADIUS)
        return bucket_swept(x_prev, x, surface)
    state = BINNED.allocate(x, surface, x_prev=x_prev)
    if name == "bucket_sort":
        return _closest_step(BINNED, state, x, surface)[0]
    return _swept_step(BINNED, state, x_prev, x, surface)[0]


@functools.cache
def reference(name: str, dtype=FLOAT):
    """The exhaustive detector's result on the scene without padding: every
    detector returns what it returns (one compilation serves them all)."""
    x_prev, x, surface = X_PREV.astype(dtype), X.astype(dtype), unpadded(dtype)
    return detect("swept" if name in PATHS else "all_to_all", "plain", surface, x_prev, x)


def test_the_scene_finds_and_crosses_something():
    # Otherwise the comparisons below would compare rows of zeros.
    contact, crossing = reference("all_to_all"), reference("swept")
    assert 2 <= int(contact.found.sum()) < len(X) and bool(contact.active.any())
    assert 1 <= int(crossing.crossed.sum()) < len(X)
    assert {0, 1, 2} <= set(np.asarray(contact.segment).tolist())


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("sentinel", list(SENTINELS))
@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("name", DETECTORS)
def test_masked_sentinel_segment_changes_no_real_row(name, transform, sentinel, where):
    surface, moved = padded(SENTINELS[sentinel], where)
    got = detect(name, transform, surface)
    assert_same_rows(got, reference(name), moved)


def test_float32_masked_sentinel_segment_changes_no_real_row():
    x_prev, x = X_PREV.astype(np.float32), X.astype(np.float32)
    for name in ("all_to_all", "swept"):
        for sentinel in (-1, 2**31 - 1):
            surface, moved = padded(sentinel, "middle", np.float32)
            got = detect(name, "jit", surface, x_prev, x)
            assert_same_rows(got, reference(name, np.float32), moved, np.float32)
            assert got[0].dtype == np.float32


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("sentinel", list(SENTINELS))
def test_penalty_ignores_the_padding(sentinel, where):
    surface, _ = padded(SENTINELS[sentinel], where)
    got = penalty_total(detect("all_to_all", "plain", surface), surface, 10.0)
    want = penalty_total(reference("all_to_all"), unpadded(FLOAT), 10.0)
    for value, expected in zip(got, want, strict=True):
        np.testing.assert_array_equal(value, expected)


def _gap_and_point(contact):
    return jnp.sum(contact.gap) + jnp.sum(contact.point)


def _time_and_point(crossing):
    return jnp.sum(crossing.t) + jnp.sum(crossing.point)


def _gradient(name: str, surface: Surface):
    """d(sum of the differentiable fields)/d(x, surface.nodes)."""
    state = BINNED.allocate(X, surface)

    def total(x, nodes):
        surface_now = surface._replace(nodes=nodes)
        if name == "all_to_all":
            return _gap_and_point(all_to_all(x, surface_now, radius=RADIUS))
        if name == "swept":
            return _time_and_point(swept(X_PREV, x, surface_now))
        return _gap_and_point(_closest_step(BINNED, state, x, surface_now)[0])

    return jax.grad(total, argnums=(0, 1))(jnp.asarray(X), surface.nodes)


GRADIENTS = ("all_to_all", "swept", "search_closest")


@functools.cache
def reference_gradient(name: str):
    """The exhaustive detector's gradient without padding (the searches' are its)."""
    return _gradient("swept" if name in PATHS else "all_to_all", unpadded())


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("sentinel", list(SENTINELS))
@pytest.mark.parametrize("name", GRADIENTS)
def test_gradients_are_finite_and_unchanged_by_the_padding(name, sentinel, where):
    surface, _ = padded(SENTINELS[sentinel], where)
    got, want = _gradient(name, surface), reference_gradient(name)
    for value, expected, argument in zip(got, want, ("x", "nodes"), strict=True):
        assert np.isfinite(np.asarray(value)).all(), argument
        np.testing.assert_allclose(value, expected, rtol=0, atol=local_atol(FLOAT))
    # The padding reads node 4 (or node 0); node 4 gets no gradient from it.
    assert not np.asarray(got[1])[4].any()


# A batch of two scenes, each padded with its own sentinel, the second moved.
SHIFT = np.array([0.1, 0.05])


def _batch():
    first, moved = padded(-1, "middle")
    second, _ = padded(2**31 - 1, "middle")
    stacked = jax.tree.map(lambda *leaves: jnp.stack(leaves), first, second)
    nodes = stacked.nodes.at[1].add(SHIFT)
    return stacked._replace(nodes=nodes), jnp.asarray(np.stack([X, X + SHIFT / 2])), moved


def _row(tree, index):
    return jax.tree.map(lambda v: v if v.ndim == 0 else v[index], tree)


@pytest.mark.parametrize("name", ["all_to_all", "swept", "search_closest"])
def test_vmap_over_scenes_with_different_sentinels(name):
    surface, x, moved = _batch()
    x_prev = x + jnp.asarray(X_PREV - X)[None]
    if name == "search_closest":
        state = SKIN.allocate(x, surface)
        got = jax.vmap(functools.partial(_closest_step, SKIN))(state, x, surface)[0]
    else:
        got = jax.vmap(JITTED[name])(x_prev, x, surface)
    for index in range(2):
        own = Surface(NODES + index * SHIFT, REAL)
        kind = "swept" if name in PATHS else "all_to_all"
        want = detect(kind, "plain", own, np.asarray(x_prev[index]), np.asarray(x[index]))
        assert_same_rows(_row(got, index), want, moved)


def test_search_with_a_skin_keeps_its_candidates_whatever_the_padding_holds():
    # The skin rule reads each segment's node indices (a segment joined to
    # other nodes expires the candidates): a masked one's must not count,
    # however it changes between steps.
    surface, moved = padded(-1, "middle")
    state = SKIN.allocate(X, surface)
    for sentinel in (2**31 - 1, len(NODES), -1):
        step, _ = padded(sentinel, "middle")
        contact, state = _closest_step(SKIN, state, X + 0.02, step)
        assert_same_rows(contact, reference_at(X + 0.02), moved)
    assert int(state.rebuilds) == 0 and not bool(state.overflow)
    # ... while a real segment joined to other nodes still expires them.
    rejoined = surface.segments.at[0].set(jnp.asarray([0, 2], jnp.int32))
    _, state = _closest_step(SKIN, state, X, surface._replace(segments=rejoined))
    assert int(state.rebuilds) == 1


def reference_at(x):
    return all_to_all(x, unpadded(), radius=RADIUS)


def test_search_init_under_jit_takes_padding():
    surface, moved = padded(2**31 - 1, "middle")
    sizes = SKIN.allocate(X, surface).sizes
    state = jax.jit(functools.partial(SKIN.init, sizes=sizes))(X, surface)
    assert isinstance(state.candidates, Candidates)
    assert_same_rows(_closest_step(SKIN, state, X, surface)[0], reference_at(X), moved)
    # Plainly too: init checks the surface as the detectors do.
    state = SKIN.init(X, surface, sizes=sizes)
    assert_same_rows(SKIN.closest(state, X, surface)[0], reference_at(X), moved)


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("sentinel", list(SENTINELS))
def test_sizes_ignore_what_padding_indices_read(sentinel, where):
    # A sentinel clamped into range reads node 4, far away: read unmasked it
    # would stretch the master's box, the grid and the segments' spans.
    surface, _ = padded(SENTINELS[sentinel], where)
    for query in ({"radius": RADIUS}, {"x_prev": X_PREV}):
        got = measure(X, surface, use_cells=True, **query)
        assert got == measure(X, unpadded(), use_cells=True, **query)


def test_a_detector_under_shard_map_takes_padding():
    # The route to many devices: the slaves split, the padded master
    # replicated, each device's detector tracing the sentinel segment.
    mesh = jax.make_mesh((1,), ("slaves",))
    surface, moved = padded(-1, "middle")
    split, whole = jax.sharding.PartitionSpec("slaves"), jax.sharding.PartitionSpec()
    fields = Contact(*[split] * len(Contact._fields))._replace(overflow=whole)
    mapped = jax.shard_map(
        lambda x, surface: all_to_all(x, surface, radius=RADIUS),
        mesh=mesh,
        in_specs=(split, whole),
        out_specs=fields,
        check_vma=False,  # the detectors' conds return constants (docs/guides/devices.md)
    )
    # Placed split as in_specs say (newer JAX refuses a sharding that differs).
    x = jax.device_put(X, jax.sharding.NamedSharding(mesh, split))
    assert_same_rows(jax.jit(mapped)(x, surface), reference("all_to_all"), moved)


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("sentinel", list(SENTINELS))
def test_validate_passes_masked_sentinels(sentinel, where):
    # Silently: a warning would be an error here (pyproject's filterwarnings).
    surface, _ = padded(SENTINELS[sentinel], where)
    validate(X, surface, radius=RADIUS, x_prev=X_PREV)
    segments, mask, _ = padded_rows(SENTINELS[sentinel], where)
    validate(X, Surface(NODES, segments.tolist(), mask.tolist()), mask=np.ones(len(X), bool))


def test_validate_still_names_a_real_segment_with_a_sentinel():
    segments, mask, _ = padded_rows(-1, "middle")
    surface = Surface(NODES, segments, np.ones_like(mask))
    with pytest.raises(
        ValueError, match=re.escape("surface.segments has indices outside [0, 4] in rows [1]")
    ):
        validate(X, surface)
    # Masked rows are not named, even next to a real one that is.
    segments[2] = [0, 5]
    mask[3] = False
    segments[3] = [7, 7]
    with pytest.raises(ValueError, match=re.escape("outside [0, 4] in rows [2]")):
        validate(X, Surface(NODES, segments, mask))


def test_padding_only_surface_without_nodes():
    # Every segment padding, no node at all: nothing to find, nothing to raise.
    surface = Surface(jnp.zeros((0, 2)), jnp.asarray([[-1, -1], [0, 3]]), jnp.zeros(2, bool))
    validate(X, surface, radius=RADIUS, x_prev=X_PREV)
    results = [detect(name, "plain", surface) for name in ("all_to_all", "swept", "bucket_sort")]
    # The skin rule reads the nodes the candidates were found at: none here.
    results += [_closest_step(SKIN, SKIN.allocate(X, surface), X, surface)[0]]
    for result in results:
        assert (np.asarray(result.segment) == -1).all() and not bool(result.overflow)


@functools.cache
def _allocated():
    return SKIN.allocate(X, unpadded(), x_prev=X_PREV)


def _plain_calls(surface: Surface):
    state = _allocated()
    return {
        **{name: functools.partial(detect, name, "plain", surface) for name in DETECTORS},
        "allocate": lambda: SKIN.allocate(X, surface, x_prev=X_PREV),
        "init": lambda: SKIN.init(X, surface, sizes=state.sizes),
        "closest": lambda: SKIN.closest(state, X, surface),
        "search_swept": lambda: SKIN.swept(state, X_PREV, X, surface),
        "measure": lambda: measure(X, surface, radius=RADIUS),
    }


PLAIN_CALLS = (*DETECTORS, "allocate", "init", "closest", "search_swept", "measure")


@pytest.mark.parametrize("sentinel", list(SENTINELS))
@pytest.mark.parametrize("call", PLAIN_CALLS)
def test_a_real_segment_with_a_sentinel_still_raises(call, sentinel):
    value = SENTINELS[sentinel]
    segments, mask, _ = padded_rows(value, "middle")
    # Row 1 holds the sentinel and is made real; row 2, masked, holds 9,
    # which the message does not report.
    mask[1], mask[2] = True, False
    segments[2] = [9, 9]
    surface = Surface(jnp.asarray(NODES), jnp.asarray(segments, jnp.int32), jnp.asarray(mask))
    low, high = min(value, 0), max(value, 3)
    message = (
        "surface.segments must index surface.nodes, in [0, 4], where surface.mask is True; "
        f"got values in [{low}, {high}]"
    )
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        _plain_calls(surface)[call]()


def test_without_a_mask_every_segment_is_real():
    surface = Surface(jnp.asarray(NODES), jnp.asarray([[0, 1], [-1, 2]]))
    message = "surface.segments must index surface.nodes, in [0, 4]; got values in [-1, 2]"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        all_to_all(X, surface, radius=RADIUS)


@pytest.mark.x64
@pytest.mark.parametrize("sentinel", [-1, 2**31 - 1, 2**40])
def test_int64_and_list_segments(sentinel):
    # Tests run with x64: int64 stays int64 until the detectors narrow it.
    segments, mask, moved = padded_rows(sentinel, "end")
    wide = Surface(jnp.asarray(NODES), jnp.asarray(segments, jnp.int64), jnp.asarray(mask))
    listed = Surface(NODES.tolist(), segments.tolist(), mask.tolist())
    assert wide.segments.dtype == np.int64
    want = reference("all_to_all")
    for surface in (wide, listed):
        assert_same_rows(all_to_all(X, surface, radius=RADIUS), want, moved)
    assert_same_rows(JITTED["all_to_all"](X_PREV, X, wide), want, moved)
    validate(X, wide)
    validate(X, listed)


@pytest.mark.x64
def test_a_real_int64_index_past_int32_is_not_wrapped_onto_a_node():
    # 2**32 + 1 narrowed to int32 would be node 1: a made-up segment 1 -> 3
    # running just under the slaves. Plainly it raises; under jit the
    # segment is ignored, as any out-of-range one.
    bad = jnp.asarray([*REAL, [2**32 + 1, 3]], jnp.int64)
    surface = Surface(jnp.asarray(NODES), bad)
    with pytest.raises(ValueError, match=re.escape(f"got values in [0, {2**32 + 1}]")):
        all_to_all(X, surface, radius=RADIUS)
    got = JITTED["all_to_all"](X_PREV, X, surface)
    assert_same_rows(got, reference("all_to_all"), np.arange(3))
    got = JITTED["swept"](X_PREV, X, surface)
    assert_same_rows(got, reference("swept"), np.arange(3))
    # uint32's largest value, the sentinel of unsigned meshes, is -1 as int32.
    segments, mask, moved = padded_rows(2**32 - 1, "end")
    unsigned = Surface(NODES, segments.astype(np.uint32), mask)
    assert_same_rows(all_to_all(X, unsigned, radius=RADIUS), reference("all_to_all"), moved)


def test_list_segments_with_x64_off():
    # NumPy makes the list int64; with x64 off JAX would narrow it, 2**40 to 0.
    segments, mask, moved = padded_rows(2**40, "middle")
    with jax.enable_x64(False):
        surface = Surface(NODES, segments.tolist(), mask.tolist())
        validate(X, surface)
        got = all_to_all(X, surface, radius=RADIUS)
    assert got.gap.dtype == np.float32
    assert_same_rows(got, reference("all_to_all", np.float32), moved, np.float32)
