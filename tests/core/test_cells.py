"""The sort the cell binning and the vertex neighbours stand on."""

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxcontact._pipeline import cells as _cells
from jaxcontact._pipeline import sort as _sort
from jaxcontact._pipeline.broad import Box
from jaxcontact._pipeline.cells import Grid, bin_segments
from jaxcontact._pipeline.sort import stable_order


@settings(max_examples=40, deadline=None)
@given(
    data=st.data(),
    # 10 takes the one-key sort; 2**30 and 2**31 - 1 make key * size
    # overflow int32 and take the radix sort's passes.
    num_values=st.sampled_from([10, 2**30, 2**31 - 1]),
    size=st.integers(0, 40),
)
def test_stable_order_is_numpys_stable_argsort(data, num_values, size):
    # Few distinct keys over the whole range, so that equal keys meet.
    values = data.draw(st.lists(st.integers(0, num_values - 1), min_size=1, max_size=4))
    keys = np.asarray(data.draw(st.lists(st.sampled_from(values), min_size=size, max_size=size)))
    keys = keys.astype(np.int32)
    expected = np.argsort(keys, kind="stable")
    np.testing.assert_array_equal(np.asarray(stable_order(keys, num_values)), expected)


def test_stable_order_past_its_passes_is_argsort(monkeypatch):
    monkeypatch.setattr(_sort, "MOST_PASSES", 0)
    keys = np.asarray([2**30, 5, 2**30, 0, 5, 7], np.int32)
    got = np.asarray(_sort.stable_order(keys, 2**31 - 1))
    np.testing.assert_array_equal(got, np.argsort(keys, kind="stable"))


def test_binning_by_packed_pairs_is_the_stable_sorts(monkeypatch):
    """``bin_segments`` orders each cell's segments alike by either sort."""
    rng = np.random.default_rng(3)
    low = rng.uniform(0, 9, (50, 2)).astype(np.float32)
    boxes = Box(
        jnp.asarray(low), jnp.asarray(low + rng.uniform(0, 2.5, (50, 2)).astype(np.float32))
    )
    ok = jnp.asarray(rng.random(50) < 0.8)
    grid = Grid(jnp.zeros(2, jnp.float32), jnp.asarray(1.0, jnp.float32))
    packed = bin_segments(boxes, ok, grid, (10, 10), (4, 4), 50)
    monkeypatch.setattr(_cells, "sorted_pair_keys", lambda *args: None)
    stable = bin_segments(boxes, ok, grid, (10, 10), (4, 4), 50)
    for got, wanted in zip(packed, stable, strict=True):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(wanted))


@pytest.mark.parametrize("size", [1, 1000])
def test_stable_order_keeps_equal_keys_in_input_order(size):
    keys = np.zeros(size, np.int32)
    np.testing.assert_array_equal(np.asarray(stable_order(keys, 1)), np.arange(size))
