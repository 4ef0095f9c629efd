"""The sort the cell binning and the vertex neighbours stand on."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxcontact._sort import stable_order


@settings(max_examples=40, deadline=None)
@given(
    keys=st.lists(st.integers(0, 9), min_size=0, max_size=40),
    # 10 takes the one-key sort; 2**30 makes key * size overflow int32 and
    # takes argsort(stable=True).
    num_values=st.sampled_from([10, 2**30]),
)
def test_stable_order_is_numpys_stable_argsort(keys, num_values):
    keys = np.asarray(keys, np.int32)
    expected = np.argsort(keys, kind="stable")
    np.testing.assert_array_equal(np.asarray(stable_order(keys, num_values)), expected)


@pytest.mark.parametrize("size", [1, 1000])
def test_stable_order_keeps_equal_keys_in_input_order(size):
    keys = np.zeros(size, np.int32)
    np.testing.assert_array_equal(np.asarray(stable_order(keys, 1)), np.arange(size))
