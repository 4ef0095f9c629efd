"""Runs ``tests/sharded`` in a process with 4 CPU devices.

JAX fixes its device count when it starts, and this process has started it
with one; the sharded tests need their own.
"""

import os
import socket
import subprocess
import sys
from pathlib import Path

import jax
import numpy as np
import pytest
from jax.sharding import NamedSharding
from jax.sharding import PartitionSpec as P

from jaxcontact import Contact, all_to_all
from jaxcontact.scenes import cutting_scene
from tests.support.helpers import assert_pytest_passes_in_subprocess

ROOT = Path(__file__).resolve().parent.parent


def _xla_flags(devices: int) -> str:
    """This process's XLA flags (the suite's code generation), with ``devices`` CPU devices."""
    flags = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={devices}"
    return flags.strip()


@pytest.mark.multidevice
@pytest.mark.slow
def test_sharded_suite_on_four_cpu_devices():
    env = {"XLA_FLAGS": _xla_flags(4), "JAXCONTACT_SHARDED": "1"}
    assert_pytest_passes_in_subprocess(["tests/sharded"], env)


def test_shard_map_on_one_device_is_the_detector():
    # The route to many devices (docs/guides/devices.md), here in the suite's
    # own process: the user's shard_map around a detector, the slaves split.
    scene = cutting_scene(500, 18.0)
    mesh = jax.make_mesh((1,), ("slaves",))
    fields = Contact(*[P("slaves")] * len(Contact._fields))._replace(overflow=P())
    mapped = jax.shard_map(
        lambda x, surface: all_to_all(x, surface, radius=0.1),
        mesh=mesh,
        in_specs=(P("slaves"), P()),
        out_specs=fields,
        check_vma=False,  # the detectors' conds return constants where they skip work
    )
    # The slaves placed split over the mesh, as shard_map's in_specs say
    # (newer JAX refuses inputs whose sharding differs from in_specs).
    x = jax.device_put(scene.x, NamedSharding(mesh, P("slaves")))
    got = jax.jit(mapped)(x, scene.surface)
    want = all_to_all(scene.x, scene.surface, radius=0.1)
    for field, value in zip(want._fields, want, strict=True):
        np.testing.assert_array_equal(getattr(got, field), value, err_msg=field)
    assert got.gap.sharding.spec == P("slaves")


def _example(*args, devices: int):
    env = {**os.environ, "XLA_FLAGS": _xla_flags(devices)}
    return subprocess.Popen(
        [sys.executable, "examples/multihost.py", "--nodes", "3000", *args],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def _summary(process) -> str:
    out, _ = process.communicate(timeout=300)
    assert process.returncode == 0, out[-4000:]
    return out


@pytest.mark.multidevice
@pytest.mark.slow
def test_multihost_example_runs_on_one_host_and_on_two_processes():
    one = _summary(_example(devices=4))
    assert "1 process(es), 4 device(s)" in one
    assert "bucket sort = all-to-all: True, overflow: False" in one
    # Two processes of two devices each, coordinated over localhost: the same answer.
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    both = [
        _example("--coordinator", f"127.0.0.1:{port}", "--processes", "2", "--process-id", str(i),
                 devices=2)
        for i in range(2)
    ]  # fmt: skip
    first, _ = _summary(both[0]), _summary(both[1])
    assert "2 process(es), 4 device(s)" in first

    def found(out):
        line = next(line for line in out.splitlines() if "device(s):" in line)
        return line.split("device(s):")[1]

    assert found(first) == found(one)
