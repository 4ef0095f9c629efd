"""benchmarks/harness/program.py on tiny jitted functions: kernels, their kinds, loop trip
counts and XLA's bytes accessed, each against what the function is known to compile to."""

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import program

X = jnp.ones(64, jnp.float32)


def _compiled(fn, *args):
    return jax.jit(fn).lower(*args).compile()


def test_kernels_are_sorted_by_kind():
    """A reduction, a gather and a sort, each found among a program's kernels."""
    x, index = np.linspace(0.0, 1.0, 64, dtype=np.float32), np.arange(64, dtype=np.int32)[::-1]

    def three(x, index):
        return jnp.max(x * 2.0), x[index] * 3.0, jnp.sort(x[:40])

    text = _compiled(three, x, index).as_text()
    kinds = program.kernel_kinds(text)
    assert list(kinds) == list(program.KINDS)
    assert kinds[program.GATHER] >= 1 and kinds[program.SORT] >= 1, kinds
    assert kinds[program.SCALAR] + kinds[program.WINDOW] >= 1, kinds
    assert sum(kinds.values()) == len(program.kernel_lines(text))


def test_a_scan_of_known_length_reports_its_trip_count():
    def scan(x):
        return jax.lax.scan(lambda c, _: (jnp.sin(c) * 1.5, None), x, None, length=37)[0]

    shape = program.describe(_compiled(scan, X))
    assert shape.loops == (37,)
    assert program.largest_trip(shape.loops) == 37


def test_loops_in_a_loop_body_and_a_branch_are_found():
    def nested(x, flag):
        def outer(c, _):
            return jax.lax.scan(lambda d, _: (jnp.sin(d) * 1.5, None), c, None, length=3)[0], None

        looped = jax.lax.scan(outer, x, None, length=5)[0]
        return jax.lax.cond(
            flag, lambda y: jax.lax.fori_loop(0, 6, lambda i, c: jnp.cos(c), y), jnp.exp, looped
        )

    shape = program.describe(_compiled(nested, X, True))
    assert sorted(shape.loops) == [3, 5, 6]
    assert program.largest_trip(shape.loops) == 6


def test_a_loop_of_bounds_known_at_run_time_is_unknown():
    def dynamic(x, n):
        return jax.lax.fori_loop(0, n, lambda i, c: c * 1.01, x)

    shape = program.describe(_compiled(dynamic, X, 4))
    assert shape.loops == (None,)
    assert program.largest_trip(shape.loops) == "unknown"


def test_a_function_with_no_loop_reports_none():
    shape = program.describe(_compiled(lambda x: x * 2.0 + 1.0, X))
    assert shape.loops == ()
    assert program.largest_trip(shape.loops) is None
    assert shape.kernels == 1  # one elementwise fusion
    assert shape.kinds[program.ELEMENTWISE] == 1


def test_bytes_accessed_beside_the_inputs_and_outputs():
    shape = program.describe(_compiled(lambda x, y: (x * y, jnp.sum(y)), X, X))
    itemsize = X.dtype.itemsize
    assert shape.minimum_bytes == (64 + 64 + 64 + 1) * itemsize  # two inputs, two outputs
    assert shape.bytes_accessed is not None and shape.bytes_accessed >= shape.minimum_bytes
