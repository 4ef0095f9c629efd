"""Where the suite's time goes: XLA compiles per test (a pytest plugin, opt-in).

``python -m pytest -q -n 2 -p tests.support.compile_log`` prints, at the end, the
number of XLA compilations and their seconds, the tests that compiled most,
and per jitted function how many programs it compiled and in how many xdist
workers (many programs of one function: candidates for a shared shape).
Counts come from ``jax.monitoring``'s backend-compile event; programs loaded
from a persistent compilation cache (``JAX_COMPILATION_CACHE_DIR``) are
counted apart. ``JAXCONTACT_COMPILE_LOG_KEEP=rows.json`` also keeps every
compile's row (worker, test, program, seconds, loaded from the cache) as JSON.
"""

from __future__ import annotations

import collections
import json
import os
import shutil
import tempfile

import jax
import pytest

_EVENT = "/jax/core/compile/backend_compile_duration"
_HIT = "/jax/compilation_cache/cache_hits"
_current = ["(outside tests)"]
_hits = [0]
# (test, program, seconds, 1 if loaded from the persistent cache else 0)
_compiles: list[tuple[str, str, float, int]] = []


def _listen(event, duration, **kwargs):
    if event == _EVENT:
        program = str(kwargs.get("fun_name", "?"))
        _compiles.append((_current[0], program, duration, _hits[0]))
        _hits[0] = 0


def _count_hit(event, **kwargs):
    if event == _HIT:
        _hits[0] = 1


jax.monitoring.register_event_duration_secs_listener(_listen)
jax.monitoring.register_event_listener(_count_hit)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _current[0] = item.nodeid
    yield
    _current[0] = "(outside tests)"


def _log_dir(config) -> str:
    # The controller makes the folder; xdist workers inherit it through the env.
    if "JAXCONTACT_COMPILE_LOG_DIR" not in os.environ:
        os.environ["JAXCONTACT_COMPILE_LOG_DIR"] = tempfile.mkdtemp(prefix="compile_log_")
    return os.environ["JAXCONTACT_COMPILE_LOG_DIR"]


def pytest_configure(config):
    _log_dir(config)


def pytest_sessionfinish(session):
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    path = os.path.join(_log_dir(session.config), f"{worker}.json")
    with open(path, "w") as stream:
        json.dump([[worker, *row] for row in _compiles], stream)


def pytest_terminal_summary(terminalreporter, config):
    if os.environ.get("PYTEST_XDIST_WORKER"):
        return
    rows = []
    folder = _log_dir(config)
    for name in sorted(os.listdir(folder)):
        with open(os.path.join(folder, name)) as stream:
            rows += json.load(stream)
    shutil.rmtree(folder, ignore_errors=True)
    keep = os.environ.get("JAXCONTACT_COMPILE_LOG_KEEP")
    if keep:  # every compile's row, as JSON, for a closer look
        with open(keep, "w") as stream:
            json.dump(rows, stream)
    write = terminalreporter.write_line
    total = sum(row[3] for row in rows)
    hits = sum(row[4] for row in rows)
    workers = sorted({row[0] for row in rows})
    write(
        f"compiles: {len(rows) - hits}, and {hits} loaded from the persistent cache; "
        f"{total:.1f} s in all; workers {workers}"
    )
    per_test = collections.defaultdict(lambda: [0, 0.0])
    for _, test, _, seconds, _ in rows:
        per_test[test][0] += 1
        per_test[test][1] += seconds
    write("most compile time, per test (count, seconds):")
    for test, (count, seconds) in sorted(per_test.items(), key=lambda kv: -kv[1][1])[:40]:
        write(f"  {count:4d} {seconds:7.1f}  {test}")
    per_program = collections.defaultdict(lambda: [0, 0.0, set()])
    for worker, _, program, seconds, _ in rows:
        entry = per_program[program]
        entry[0] += 1
        entry[1] += seconds
        entry[2].add(worker)
    write("programs by total compile time (count, seconds, workers):")
    by_time = sorted(per_program.items(), key=lambda kv: -kv[1][1])
    for program, (count, seconds, where) in by_time[:30]:
        write(f"  {count:4d} {seconds:7.1f} {len(where)}  {program}")
