"""Test-wide JAX settings: float64 available, strict rank promotion."""

import os

import jax
from hypothesis import HealthCheck, settings

# tests/sharded needs 4 devices, fixed when JAX starts: tests/test_shard.py
# runs it in a process of its own, with JAXCONTACT_SHARDED=1.
collect_ignore = [] if os.environ.get("JAXCONTACT_SHARDED") == "1" else ["sharded"]

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

# Property tests (tests/test_properties.py and others using hypothesis): a
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
