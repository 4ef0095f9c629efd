"""Plain calls pad to size classes: a long process compiles few programs.

Each program XLA compiles maps hundreds of memory regions into the process
(benchmarks/long_process.py); plain calls at many shapes must share programs.
"""

import jax
import numpy as np
import pytest

from jaxcontact import Surface, all_to_all, bucket_sort, bucket_swept, swept
from jaxcontact._bucket import contact_jit, crossing_jit
from jaxcontact._dense import _all_to_all, _swept
from jaxcontact._padded import size_class

NODES = np.array([[3.0, 0.0], [2.0, 0.1], [1.0, 0.0], [0.0, 0.05]])
SEGMENTS = np.array([[0, 1], [1, 2], [2, 3]])


def _closest(detect):
    return lambda x, surface: detect(x, surface, radius=0.3)


def _crossing(detect):
    return lambda x, surface: detect(x + np.array([0.0, 0.5]), x - np.array([0.0, 0.5]), surface)


DETECTORS = {
    "all_to_all": (_closest(all_to_all), _all_to_all),
    "bucket_sort": (_closest(bucket_sort), contact_jit),
    "swept": (_crossing(swept), _swept),
    "bucket_swept": (_crossing(bucket_swept), crossing_jit),
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


def test_traced_calls_are_not_padded():
    x = np.array([[1.5, 0.2], [0.5, -0.1], [2.5, 0.3]])
    traced = jax.jit(lambda x: all_to_all(x, Surface(NODES, SEGMENTS), radius=0.3).gap)(x)
    plain = all_to_all(x, Surface(NODES, SEGMENTS), radius=0.3).gap
    np.testing.assert_array_equal(traced, plain)
