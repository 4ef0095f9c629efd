"""Plain exhaustive calls pad to size classes: a long process compiles few programs.

Each program XLA compiles maps hundreds of memory regions into the process
(1.2's benchmarks/archive/long_process.py, in commit 5928bf7f76cc);
plain calls of ``all_to_all`` and ``swept`` at many shapes must share programs.
The one-call bucket forms are a ``Search`` allocated per call: they pad
nothing and keep nothing between calls.
"""

import jax
import numpy as np
import pytest
from jax.extend.core import Jaxpr

from jaxcontact import Surface, all_to_all, bucket_sort, bucket_swept, swept
from jaxcontact._pipeline import driver
from jaxcontact._pipeline.sizes import size_class

NODES = np.array([[3.0, 0.0], [2.0, 0.1], [1.0, 0.0], [0.0, 0.05]])
SEGMENTS = np.array([[0, 1], [1, 2], [2, 3]])


def _closest(detect):
    return lambda x, surface: detect(x, surface, radius=0.3)


def _crossing(detect):
    return lambda x, surface: detect(x + np.array([0.0, 0.5]), x - np.array([0.0, 0.5]), surface)


DETECTORS = {
    "all_to_all": (_closest(all_to_all), driver.exhaustive),
    "swept": (_crossing(swept), driver.exhaustive),
}


def test_size_classes_are_at_most_a_quarter_above():
    counts = np.arange(0, 5000)
    classes = np.array([size_class(int(n)) for n in counts])
    assert (classes >= counts).all()
    assert (classes <= counts + counts // 4).all()
    assert size_class(0) == 0 and size_class(5, 16) == 16
    # Four classes per doubling: few programs over a sweep.
    assert len(set(classes[1025:2049])) == 4


@pytest.mark.parametrize("name", DETECTORS)
def test_plain_calls_at_many_shapes_share_one_program(name):
    detect, program = DETECTORS[name]
    rng = np.random.default_rng(0)
    surface = Surface(NODES, SEGMENTS)
    # 1..16 slaves and 1..4 segments: one size class each.
    scenes = [rng.uniform([0, -0.5], [3, 0.5], (n, 2)) for n in range(1, 17)]
    first = detect(scenes[-1], surface)
    compiled = program._cache_size()
    for x in scenes:
        for count in (1, 2, 3):
            result = detect(x, Surface(NODES, SEGMENTS[:count]))
            # Padding rows were cut back, and each row is its own unpadded answer.
            assert result.segment.shape == (len(x),)
            alone = [
                detect(x[i : i + 1], Surface(NODES, SEGMENTS[:count])) for i in (0, len(x) - 1)
            ]
            assert result.segment[0] == alone[0].segment[0]
            assert result.segment[-1] == alone[1].segment[0]
    assert program._cache_size() == compiled, "a plain call at a new shape compiled anew"
    assert first.segment.shape == (16,)


def test_padding_is_cut_back_and_keeps_dtypes_and_overflow():
    x = np.array([[1.5, 0.2], [0.5, -0.1], [2.5, 0.3]])
    contact = all_to_all(x, Surface(NODES, SEGMENTS), radius=0.3)
    for name, values in contact._asdict().items():
        if np.ndim(values):
            assert values.shape[0] == 3, name
    assert isinstance(
        contact.gap, jax.Array
    ) and contact.gap.dtype == jax.dtypes.canonicalize_dtype(np.float64)
    assert contact.overflow.shape == ()


def _shapes(jaxpr) -> set[tuple[int, ...]]:
    """Every shape of a value in ``jaxpr`` and the programs it calls."""
    shapes = set()
    for eqn in jaxpr.eqns:
        for var in (*eqn.invars, *eqn.outvars):
            shapes.add(tuple(getattr(var.aval, "shape", ())))
        for param in eqn.params.values():
            for sub in param if isinstance(param, (tuple, list)) else (param,):
                inner = getattr(sub, "jaxpr", sub)
                if isinstance(inner, Jaxpr):
                    shapes |= _shapes(inner)
    return shapes


def test_traced_calls_are_not_padded():
    # Padding is cut back, so the values alone cannot tell: the traced
    # program's shapes must be the caller's (3 rows, 3 segments, 4 nodes),
    # never a size class (16 rows, 8 segments and nodes).
    x = np.array([[1.5, 0.2], [0.5, -0.1], [2.5, 0.3]])
    traced = jax.make_jaxpr(lambda x: all_to_all(x, Surface(NODES, SEGMENTS), radius=0.3).gap)(x)
    dims = {dim for shape in _shapes(traced.jaxpr) for dim in shape}
    assert 3 in dims and not dims & {8, 16}, sorted(dims)
    gap = jax.jit(lambda x: all_to_all(x, Surface(NODES, SEGMENTS), radius=0.3).gap)(x)
    plain = all_to_all(x, Surface(NODES, SEGMENTS), radius=0.3).gap
    np.testing.assert_array_equal(gap, plain)


@pytest.mark.parametrize("query", ["closest", "swept"])
def test_plain_bucket_calls_keep_nothing_between_calls(query):
    # Each one-call form measures its sizes from its own data: a call whose
    # slaves spread past the previous call's (one block of 64 rows near the
    # master, then all 256) still gives the dense answer, not an overflow.
    rng = np.random.default_rng(1)
    near = rng.uniform([0.0, -0.25], [3.0, 0.25], (256, 2))
    one_block = near.copy()
    one_block[64:, 1] += 100.0  # only the first block of 64 rows near the master
    surface = Surface(NODES, SEGMENTS)
    if query == "closest":
        detect, dense, flag = _closest(bucket_sort), _closest(all_to_all), "found"
    else:
        detect, dense, flag = _crossing(bucket_swept), _crossing(swept), "crossed"
    for x in (one_block, one_block + 0.01, near, one_block):
        got, want = detect(x, surface), dense(x, surface)
        assert not bool(got.overflow)
        np.testing.assert_array_equal(got.segment, want.segment)
        np.testing.assert_array_equal(getattr(got, flag), getattr(want, flag))
        assert getattr(want, flag).any()
    counts = [int(getattr(dense(x, surface), flag).sum()) for x in (one_block, near)]
    assert counts[1] > counts[0]  # the third call does outgrow the first's sizes


def test_checked_host_inputs_stay_numpy_in_the_dtype_jax_computes_in():
    from jaxcontact._pipeline.inputs import as_array

    values = as_array(np.zeros((3, 2)))
    assert isinstance(values, np.ndarray)
    assert values.dtype == jax.dtypes.canonicalize_dtype(np.float64)
    radius = as_array(0.5, np.float32)
    assert isinstance(radius, np.ndarray) and radius.dtype == np.float32
    on_device = jax.numpy.zeros(3)
    assert as_array(on_device) is on_device
    assert as_array(on_device, np.int32).dtype == np.int32
