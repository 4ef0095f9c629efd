"""Bad inputs raise ``ValueError`` naming the argument, at trace time where they can."""

import functools
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import Search, Surface
from jaxcontact._pipeline.sizes import measure
from tests.support.helpers import X64

# All of this file runs again with x64 off (tests/test_x64_off.py).
pytestmark = pytest.mark.x64_off

X = np.array([[0.5, 0.25], [1.5, -0.5]])
NODES = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
SEGMENTS = np.array([[0, 1], [1, 2]], np.int32)
SURFACE = Surface(jnp.asarray(NODES), jnp.asarray(SEGMENTS))

# Shape and dtype errors must raise under jit too (they are known at trace time).
TRANSFORMS = pytest.mark.parametrize("transform", [lambda f: f, jax.jit], ids=["plain", "jit"])


def contact(x=X, surface=SURFACE, radius=0.5, mask=None):
    return jaxcontact.all_to_all(x, surface, radius=radius, mask=mask)


def crossing(x_prev=X, x=X, surface=SURFACE, mask=None):
    return jaxcontact.swept(x_prev, x, surface, mask=mask)


# (argument name as the message must start, bad call); each message must
# start with the name of the argument at fault.
BAD_SHAPES_AND_DTYPES = {
    "x_rank_1": ("x", lambda: contact(x=X[0])),
    "x_rank_3": ("x", lambda: contact(x=X[None])),
    "x_trailing_3": ("x", lambda: contact(x=np.zeros((2, 3)))),
    "x_integer": ("x", lambda: contact(x=X.astype(np.int32))),
    "x_complex": ("x", lambda: contact(x=X.astype(np.complex64))),
    "x_bool": ("x", lambda: contact(x=X > 0)),
    "nodes_rank_1": ("surface.nodes", lambda: contact(surface=SURFACE._replace(nodes=NODES[0]))),
    "nodes_trailing_3": (
        "surface.nodes",
        lambda: contact(surface=SURFACE._replace(nodes=np.zeros((3, 3)))),
    ),
    "nodes_float32_x_float64": (
        "surface.nodes",
        lambda: contact(surface=SURFACE._replace(nodes=NODES.astype(np.float32))),
    ),
    "nodes_float64_x_float32": ("surface.nodes", lambda: contact(x=X.astype(np.float32))),
    "nodes_integer": (
        "surface.nodes",
        lambda: contact(surface=SURFACE._replace(nodes=NODES.astype(np.int64))),
    ),
    "segments_float": (
        "surface.segments",
        lambda: contact(surface=SURFACE._replace(segments=SEGMENTS.astype(np.float64))),
    ),
    "segments_bool": (
        "surface.segments",
        lambda: contact(surface=SURFACE._replace(segments=SEGMENTS > 0)),
    ),
    "segments_rank_1": (
        "surface.segments",
        lambda: contact(surface=SURFACE._replace(segments=SEGMENTS[0])),
    ),
    "segments_trailing_3": (
        "surface.segments",
        lambda: contact(surface=SURFACE._replace(segments=np.zeros((2, 3), np.int32))),
    ),
    "surface_mask_wrong_length": (
        "surface.mask",
        lambda: contact(surface=SURFACE._replace(mask=np.ones(3, bool))),
    ),
    "surface_mask_integer": (
        "surface.mask",
        lambda: contact(surface=SURFACE._replace(mask=np.ones(2, np.int32))),
    ),
    "mask_wrong_length": ("mask", lambda: contact(mask=np.ones(3, bool))),
    "mask_rank_2": ("mask", lambda: contact(mask=np.ones((2, 1), bool))),
    "mask_float": ("mask", lambda: contact(mask=np.ones(2))),
    "radius_not_scalar": ("radius", lambda: contact(radius=np.array([0.5]))),
    "radius_complex": ("radius", lambda: contact(radius=0.5 + 0j)),
    "swept_x_prev_rank_3": ("x_prev", lambda: crossing(x_prev=X[None])),
    "swept_x_prev_integer": ("x_prev", lambda: crossing(x_prev=X.astype(np.int32))),
    "swept_x_trailing_3": ("x", lambda: crossing(x=np.zeros((2, 3)))),
    "swept_x_shape_differs": ("x", lambda: crossing(x=np.zeros((3, 2)))),
    "swept_x_dtype_differs": ("x", lambda: crossing(x=X.astype(np.float32))),
    "swept_x_complex": ("x", lambda: crossing(x=X.astype(np.complex128))),
    "swept_nodes_dtype_differs": (
        "surface.nodes",
        lambda: crossing(surface=SURFACE._replace(nodes=NODES.astype(np.float32))),
    ),
    "swept_segments_float": (
        "surface.segments",
        lambda: crossing(surface=SURFACE._replace(segments=SEGMENTS.astype(np.float32))),
    ),
    "swept_mask_wrong_length": ("mask", lambda: crossing(mask=np.ones(1, bool))),
    "swept_mask_integer": ("mask", lambda: crossing(mask=np.ones(2, np.int8))),
}


# Two float dtypes mixed: with x64 off both are float32 as JAX computes them,
# which docs/contract.md accepts (the last test below).
MIXED_FLOATS = {
    "nodes_float32_x_float64",
    "nodes_float64_x_float32",
    "swept_x_dtype_differs",
    "swept_nodes_dtype_differs",
}


@pytest.mark.parametrize(
    "case",
    [
        pytest.param(case, marks=[pytest.mark.x64] if case in MIXED_FLOATS else [])
        for case in BAD_SHAPES_AND_DTYPES
    ],
)
def test_bad_shape_or_dtype_raises_naming_the_argument(case):
    name, call = BAD_SHAPES_AND_DTYPES[case]
    with pytest.raises(ValueError, match=rf"^{re.escape(name)}\b(?!\.)"):
        call()


@TRANSFORMS
def test_bad_shapes_raise_at_trace_time(transform):
    with pytest.raises(ValueError, match=r"^x\b(?!\.)"):
        transform(contact)(np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"^x\b(?!\.)"):
        transform(crossing)(X, np.zeros((3, 2)))


@pytest.mark.x64
@TRANSFORMS
def test_mixed_float_dtypes_raise_at_trace_time(transform):
    with pytest.raises(ValueError, match=r"^surface\.nodes\b"):
        transform(contact)(X, SURFACE._replace(nodes=jnp.asarray(NODES, jnp.float32)))


def test_surface_must_be_a_surface():
    with pytest.raises(ValueError, match=r"^surface\b"):
        contact(surface=(NODES, SEGMENTS))


# Value errors: only where the values are concrete (outside jit).
BAD_VALUES = {
    "segment_index_too_large": (
        "surface.segments",
        lambda: contact(surface=SURFACE._replace(segments=np.array([[0, 1], [1, 3]], np.int32))),
    ),
    "segment_index_negative": (
        "surface.segments",
        lambda: contact(surface=SURFACE._replace(segments=np.array([[0, 1], [-1, 2]], np.int32))),
    ),
    "swept_segment_index_too_large": (
        "surface.segments",
        lambda: crossing(surface=SURFACE._replace(segments=np.array([[0, 3]], np.int32))),
    ),
    "radius_negative": ("radius", lambda: contact(radius=-0.25)),
    "radius_tiny_negative": ("radius", lambda: contact(radius=-np.finfo(np.float64).tiny)),
    "radius_nan": ("radius", lambda: contact(radius=np.nan)),
    "radius_inf": ("radius", lambda: contact(radius=np.inf)),
    "radius_nan_array": ("radius", lambda: contact(radius=jnp.asarray(np.nan))),
}


@pytest.mark.parametrize("case", list(BAD_VALUES))
def test_bad_concrete_value_raises_naming_the_argument(case):
    name, call = BAD_VALUES[case]
    with pytest.raises(ValueError, match=rf"^{re.escape(name)}\b(?!\.)"):
        call()


@functools.cache
def allocated(radius):
    """A ``Search`` and its state for ``X`` and ``SURFACE``, closest points and
    paths: the bucket detectors under jit."""
    search = Search(radius=radius)
    return search, search.allocate(X, SURFACE, x_prev=X)


@functools.cache
def jitted_detectors():
    """Every detector jitted once for the module, on a surface argument: one
    compilation per surface shape, whatever the bad indices."""
    search, state = allocated(2.0)
    return (
        jax.jit(lambda s: jaxcontact.all_to_all(X, s, radius=2.0)),
        jax.jit(lambda s: jaxcontact.swept(X, X[::-1], s)),
        jax.jit(lambda s: search.closest(search.init(X, s, sizes=state.sizes), X, s)[0]),
        jax.jit(lambda s: search.swept(state, X[::-1], X, s)[0]),
    )


@pytest.mark.parametrize("bad", [[1, 3], [-1, 2], [7, -5]])
def test_segment_index_out_of_range_under_jit_is_not_a_segment(bad):
    # Under jit the indices cannot be checked; the gather would clamp them to
    # real nodes and make up a segment. That segment is ignored instead, and
    # the other rows are as without it. (The search state is made inside, for
    # the surface at hand, with the sizes allocated for the good one.)
    segments = jnp.asarray([[0, 1], bad], jnp.int32)
    surface = SURFACE._replace(segments=segments)
    only_good = Surface(SURFACE.nodes, segments[:1])
    for detect in jitted_detectors():
        got, expected = detect(surface), detect(only_good)
        for field, value in zip(got._fields, got, strict=True):
            np.testing.assert_array_equal(value, getattr(expected, field), err_msg=field)


# Every public detector, plain and under jit (the bucket ones under jit as a
# ``Search`` with a state allocated outside for the good inputs), for the bad
# inputs the issue lists; and ``Search.allocate``, plain (it measures on the
# host).
def _detectors(transform):
    jitted = transform is jax.jit
    search, state = allocated(0.5)

    def bucket_sort(x, s, m=None):
        if jitted:
            return search.closest(state, x, s, mask=m)[0]
        return jaxcontact.bucket_sort(x, s, radius=0.5, mask=m)

    def bucket_swept(x, s, m=None):
        if jitted:
            return search.swept(state, x, x, s, mask=m)[0]
        return jaxcontact.bucket_swept(x, x, s, mask=m)

    return {
        "all_to_all": lambda x, s, m=None: jaxcontact.all_to_all(x, s, radius=0.5, mask=m),
        "bucket_sort": bucket_sort,
        "swept": lambda x, s, m=None: jaxcontact.swept(x, x, s, mask=m),
        "bucket_swept": bucket_swept,
        "allocate": lambda x, s, m=None: search.allocate(x, s, mask=m),
        "allocate_paths": lambda x, s, m=None: search.allocate(x, s, x_prev=x, mask=m),
    }


DETECTORS = ("all_to_all", "bucket_sort", "swept", "bucket_swept")
ALLOCATE = ("allocate", "allocate_paths")

# (argument the message must start with, x, surface, mask) of each bad call.
BAD_FOR_EVERY_DETECTOR = {
    "x_rank_3": ("x", X[None], SURFACE, None),
    "x_trailing_1": ("x", X[:, :1], SURFACE, None),
    "x_integer": ("x", X.astype(np.int32), SURFACE, None),
    "x_complex": ("x", X.astype(np.complex64), SURFACE, None),
    # Half precision looks like a float but the error bounds are not for it.
    "x_float16": ("x", X.astype(np.float16), SURFACE, None),
    "nodes_complex": ("surface.nodes", X, SURFACE._replace(nodes=NODES + 0j), None),
    "segments_trailing_3": (
        "surface.segments",
        X,
        SURFACE._replace(segments=np.zeros((2, 3), np.int32)),
        None,
    ),
    "surface_mask_float": ("surface.mask", X, SURFACE._replace(mask=np.ones(2)), None),
    "mask_wrong_length": ("mask", X, SURFACE, np.ones(3, bool)),
    "mask_integer": ("mask", X, SURFACE, np.ones(2, np.int32)),
}


# Search.allocate is plain only: under jit it refuses any input (it measures
# on the host). A rank-3 x is a batch of scenes to it, not an error.
NAMING_CASES = [
    (transform, detector, case)
    for transform in ("plain", "jit")
    for detector in DETECTORS
    for case in BAD_FOR_EVERY_DETECTOR
] + [
    ("plain", detector, case)
    for detector in ALLOCATE
    for case in BAD_FOR_EVERY_DETECTOR
    if case != "x_rank_3"
]


@pytest.mark.parametrize("transform, detector, case", NAMING_CASES)
def test_every_detector_names_the_bad_argument(case, detector, transform):
    name, x, surface, mask = BAD_FOR_EVERY_DETECTOR[case]
    transform = jax.jit if transform == "jit" else (lambda f: f)
    call = _detectors(transform)[detector]
    if name == "x" and detector.endswith(("swept", "paths")):
        name = "x_prev"  # the bad x is passed as both ends of the paths
    with pytest.raises(ValueError, match=rf"^{re.escape(name)}\b(?!\.)"):
        transform(call)(x, surface, mask)


def test_search_allocate_under_jit_raises_naming_search():
    search, _ = allocated(0.5)
    with pytest.raises(ValueError, match="Search.allocate .*concrete"):
        jax.jit(lambda x: search.allocate(x, SURFACE))(X)


@pytest.mark.parametrize("detector", DETECTORS + ALLOCATE)
@pytest.mark.parametrize("bad", [[[0, 1], [1, 3]], [[0, 1], [-1, 2]]], ids=["high", "negative"])
def test_every_detector_rejects_concrete_segment_indices_out_of_range(detector, bad):
    surface = SURFACE._replace(segments=np.asarray(bad, np.int32))
    with pytest.raises(ValueError, match=r"^surface\.segments\b"):
        _detectors(lambda f: f)[detector](X, surface)


@pytest.mark.parametrize("radius", [-1.0, np.nan, np.inf])
@pytest.mark.parametrize("detector", ["bucket_sort", "measure", "Search"])
def test_bucket_functions_reject_bad_radius(detector, radius):
    calls = {
        "bucket_sort": lambda: jaxcontact.bucket_sort(X, SURFACE, radius=radius),
        "measure": lambda: measure(X, SURFACE, radius=radius),
        "Search": lambda: Search(radius=radius),
    }
    with pytest.raises(ValueError, match=r"^radius\b"):
        calls[detector]()


EMPTY = Surface(jnp.zeros((0, 2)), jnp.zeros((0, 2), jnp.int32))


EMPTY_CASES = [(transform, detector) for transform in ("plain", "jit") for detector in DETECTORS]
# A search that keeps candidates (a skin and cells) on empty inputs.
EMPTY_CASES += [("jit", "bucket_sort_with_skin")]


@pytest.mark.parametrize("transform, detector", EMPTY_CASES)
@pytest.mark.parametrize("empty", ["slaves", "segments", "both"])
def test_every_detector_takes_empty_inputs(empty, detector, transform):
    x = X[:0] if empty in ("slaves", "both") else X
    surface = EMPTY if empty in ("segments", "both") else SURFACE
    if transform == "jit" and detector.startswith("bucket"):
        # The search is allocated for the shapes at hand; with a skin and
        # cells it keeps candidates (found at allocate, reused under jit).
        skin, method = (0.1, "binned") if detector.endswith("skin") else (0.0, "auto")
        radius = None if detector == "bucket_swept" else 0.5
        search = Search(radius=radius, skin=skin, method=method)
        state = search.allocate(x, surface, x_prev=x)

        def call(x, s):
            if detector == "bucket_swept":
                return search.swept(state, x, x, s)[0]
            return search.closest(state, x, s)[0]
    else:
        call = _detectors(lambda f: f)[detector]
    result = (jax.jit(call) if transform == "jit" else call)(x, surface)
    assert result.segment.shape == (len(x),)
    assert (np.asarray(result.segment) == -1).all()
    assert not bool(result.overflow)
    for value in result:
        assert np.isfinite(np.asarray(value, np.float64)).all()


# With x64 on, ``jax.enable_x64(False)`` would only imitate the mode (and
# compile its 23 programs twice in CI); the x64-off pass runs it for real.
@pytest.mark.skipif(X64, reason="runs in the x64-off pass (tests/test_x64_off.py)")
def test_numpy_float64_inputs_with_x64_off_are_computed_in_float32():
    # With x64 off (JAX's default), NumPy float64 arrays, float64 radii and
    # int64 indices become float32 and int32: mixed with float32 arrays they
    # have the same dtype as JAX computes them (docs/contract.md, Dtypes), so
    # every detector accepts them and every float result is float32.
    # Regression: x (NumPy float64) became float32 but the nodes (NumPy
    # float64) were compared as float64, so a plain NumPy call raised "must
    # have the slaves' dtype float32; got ... float32".
    # Fresh arrays: a jitted function above may hold a device copy of X.
    double, nodes64, single = X.copy(), NODES.copy(), X.astype(np.float32)
    with jax.enable_x64(False):
        search = Search(radius=0.5)
        for x, nodes in ((double, nodes64), (double, NODES.astype(np.float32)), (single, nodes64)):
            surface = Surface(nodes, SEGMENTS.astype(np.int64))
            radius = np.float64(0.5)
            state = search.allocate(x, surface, x_prev=single)
            contacts = [
                jaxcontact.all_to_all(x, surface, radius=radius),
                jaxcontact.bucket_sort(x, surface, radius=radius),
                search.closest(state, x, surface)[0],
            ]
            crossings = [
                jaxcontact.swept(single[::-1], x, surface),
                jaxcontact.bucket_swept(single[::-1], x, surface),
                search.swept(state, single[::-1], x, surface)[0],
            ]
            jaxcontact.validate(x, surface, radius=radius, x_prev=single)
            for contact in contacts:
                assert contact.gap.dtype == contact.point.dtype == np.float32
                assert contact.segment.dtype == np.int32 and bool(contact.found[0])
            for crossing in crossings:
                assert crossing.t.dtype == crossing.point.dtype == np.float32
                assert crossing.segment.dtype == np.int32 and bool(crossing.crossed.any())
