"""Test-wide JAX settings: the x64 mode, strict rank promotion, markers, hypothesis.

The suite runs in one of two modes, chosen when JAX starts (the flag is
process-wide):

- ``JAXCONTACT_X64=1`` (the default): ``jax_enable_x64`` on, so float64 and
  float32 are both tested.
- ``JAXCONTACT_X64=0``: x64 off, JAX's default and the path most users run:
  NumPy float64 inputs become float32. Tests that need float64 skip
  themselves: those marked ``x64`` and every case parametrized with a float64
  dtype. Tests written for "the best float" use ``tests.support.helpers.FLOAT``,
  float32 in this mode. ``tests/test_x64_off.py`` runs a chosen part of the
  suite this way in a process of its own.

The suite compiles with XLA's older CPU emitters
(``--xla_cpu_use_fusion_emitters=false``) and without LLVM's optimisation
(``--xla_backend_optimization_level=0``; XLA's default is 3): most of the
suite's time is XLA compiling. The older emitters give the same answers bit
for bit and compile about a third faster than XLA's defaults; LLVM's
optimisation off takes another third off the whole suite, and its
floating-point results may differ from the optimised code's in the last
bits (docs/development.md has the measurements). Every test passed so but
two, whose checks depend on the optimised code (two routes of one
arithmetic, or two steps of one loop, agreeing to the last bit): they compile
their programs with XLA's defaults themselves (``tests.support.helpers.XLA_DEFAULTS``;
tests/core/test_small_paths.py and tests/core/test_all_to_all.py).
``JAXCONTACT_FAST_COMPILE=0`` compiles with XLA's defaults instead;
``tests/test_x64_off.py`` runs its pass that way, so that the path most
users run (x64 off, XLA's default code generation) is tested as they run
it, and ``JAXCONTACT_FAST_COMPILE=0 python -m pytest -q -n 2`` runs the
whole suite so.
"""

import os

import jax
import numpy as np
import pytest
from hypothesis import HealthCheck, settings

X64 = os.environ.get("JAXCONTACT_X64", "1") != "0"

# Read when JAX starts its CPU backend, after this file runs; subprocess
# suites inherit them (tests/test_x64_off.py's pass strips them again).
# Any value of either option already there is dropped first, so that the
# x64-off pass really gets XLA's defaults.
FAST_COMPILE = ("--xla_cpu_use_fusion_emitters=false", "--xla_backend_optimization_level=0")
_NAMES = {flag.split("=")[0] for flag in FAST_COMPILE}
_FLAGS = [
    flag for flag in os.environ.get("XLA_FLAGS", "").split() if flag.split("=")[0] not in _NAMES
]
if os.environ.get("JAXCONTACT_FAST_COMPILE", "1") != "0":
    _FLAGS += FAST_COMPILE
os.environ["XLA_FLAGS"] = " ".join(_FLAGS)

# tests/sharded needs 4 devices, fixed when JAX starts: tests/test_shard.py
# runs it in a process of its own, with JAXCONTACT_SHARDED=1.
collect_ignore = [] if os.environ.get("JAXCONTACT_SHARDED") == "1" else ["sharded"]

jax.config.update("jax_enable_x64", X64)
jax.config.update("jax_numpy_rank_promotion", "raise")

# Property tests (tests/core/test_properties.py and others using hypothesis): a
# bounded, reproducible profile for CI; HYPOTHESIS_PROFILE=thorough for a
# longer search by hand.
settings.register_profile(
    "ci",
    max_examples=15,
    deadline=None,
    derandomize=True,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.register_profile(
    "thorough",
    max_examples=300,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def _is_float64(value) -> bool:
    """A dtype parameter (``np.float64``, ``jnp.float64``, ``np.dtype("float64")``),
    or a case object (not an array) whose ``dtype`` is one."""
    if not isinstance(value, (type, np.dtype)) and not hasattr(value, "shape"):
        value = getattr(value, "dtype", None)
    return isinstance(value, (type, np.dtype)) and np.dtype(value) == np.float64


def pytest_configure(config):
    # Under pytest-xdist, ``-n 2`` alone sends tests one by one to whichever
    # worker is free (``--dist load``): both workers then run the same file
    # at once, and each compiles the programs its tests share (module-level
    # jits, cached allocations, scenes of one shape). Whole files per worker
    # instead (``--dist loadfile``), in the order of collection below
    # (``--no-loadscope-reorder``, else xdist puts the files with most tests
    # first): on 2 cores, tests/core/test_bucket.py, test_search.py and
    # test_compact.py together took 4 min 27 s instead of 7 min 12 s. A
    # ``--dist`` given on the command line is kept.
    if getattr(config.option, "dist", "no") != "load" or hasattr(config, "workerinput"):
        return
    if any(
        arg in ("-d", "--distload") or arg.startswith("--dist")
        for arg in config.invocation_params.args
    ):
        return
    config.option.dist = "loadfile"
    config.option.loadscopereorder = False


@pytest.hookimpl(tryfirst=True)  # before -m reads the markers added here
def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.nodeid.startswith(("jaxcontact/sim/", "jaxcontact/problems/")):  # their doctests
            item.add_marker(pytest.mark.simulation)
            item.add_marker(pytest.mark.slow)
    # The files with long tests (subprocess suites, simulations) first, so
    # that under xdist the other worker runs the many short ones meanwhile
    # instead of waiting on a long one at the end. Whole files, in their own
    # order: their tests share fixtures and compiled programs.
    slow_files = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow_files)
    if X64:
        return
    skip = pytest.mark.skip(reason="needs float64: x64 is off (JAXCONTACT_X64=0)")
    for item in items:
        params = getattr(getattr(item, "callspec", None), "params", {})
        if item.get_closest_marker("x64") or any(map(_is_float64, params.values())):
            item.add_marker(skip)
