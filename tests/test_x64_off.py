"""The default path: a sizeable part of the suite again with x64 off, in a process of its own.

tests/conftest.py turns ``jax_enable_x64`` on, so that float64 is tested;
most users run with it off (JAX's default), where NumPy float64 inputs,
float64 radii and int64 indices become 32-bit. The flag is fixed when JAX
starts, so the tests marked ``x64_off`` run again in a subprocess with
``JAXCONTACT_X64=0`` and XLA's default CPU code generation (the rest of the
suite compiles with the older emitters and no LLVM optimisation,
tests/conftest.py): every detector
(``all_to_all``, ``swept``, ``bucket_sort``, ``bucket_swept``), the
``Search`` object, the validation
errors and the dtype rules, with the tests that need float64 skipped
(conftest.py) and the sweeps over random scenes' sizes
(tests/core/test_oracle.py, over both queries) at their largest
size only. Gradients and transforms (tests/core/test_grad.py,
tests/core/test_transforms.py) run with x64 on only since 0.4.0, to keep CI
under its ceiling; their float32 programs are the same but for index dtypes. By hand, the same:
``JAXCONTACT_X64=0 python -m pytest -q -n 2 -m x64_off``; the whole suite
that way: ``JAXCONTACT_X64=0 python -m pytest -q -n 2``.
"""

import os

import pytest

from tests.support.helpers import X64, assert_pytest_passes_in_subprocess


@pytest.mark.slow
@pytest.mark.skipif(not X64, reason="this process runs with x64 off already")
def test_the_default_path_with_x64_off():
    # XLA's default CPU code generation here, as users run it, where the rest of
    # the suite compiles faster (tests/conftest.py, JAXCONTACT_FAST_COMPILE).
    env = {"JAXCONTACT_X64": "0", "JAXCONTACT_FAST_COMPILE": "0"}
    assert_pytest_passes_in_subprocess(["-m", "x64_off", "tests"], env)


@pytest.mark.x64_off
def test_the_suite_compiles_with_the_code_generation_it_was_asked_for():
    # Both passes check the environment JAX starts from: the older emitters and
    # no LLVM optimisation unless JAXCONTACT_FAST_COMPILE=0 (as the x64-off
    # pass above sets it), where XLA's defaults are left alone.
    flags = os.environ.get("XLA_FLAGS", "").split()
    fast = os.environ.get("JAXCONTACT_FAST_COMPILE", "1") != "0"
    assert ("--xla_cpu_use_fusion_emitters=false" in flags) == fast
    assert ("--xla_backend_optimization_level=0" in flags) == fast
