"""Test-wide JAX settings: float64 available, strict rank promotion."""

import os

import jax

# tests/sharded needs 4 devices, fixed when JAX starts: tests/test_shard.py
# runs it in a process of its own, with JAXCONTACT_SHARDED=1.
collect_ignore = [] if os.environ.get("JAXCONTACT_SHARDED") == "1" else ["sharded"]

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")
