"""What the benchmark suites share: timing rows, the command line, a progress bar.

Every benchmark collects ``dict`` rows with the same keys (``COLUMNS``), so the suites
build their tables alike, and a row carries its own check against the reference beside
its timing; ``suite`` is every maintained suite's command line (its record:
``harness/report.py``). ``sized_contact`` and ``sized_crossing``
are the bucket sorts the benchmarks time: fixed ``Sizes`` measured outside
the timer, the whole search (broad phase included) inside it.
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import functools
import os
import platform
import sys
import time

import jax
import numpy as np

from benchmarks.harness import answers, report
from benchmarks.harness.internals import sized_bucket_sort, sized_bucket_swept
from benchmarks.harness.timing import Timing, compiled_call, pinned_note, time_interleaved
from benchmarks.peer_codes import numba_grid
from jaxcontact import ContactList

COLUMNS = (
    "scene",
    "nodes",
    "segments",
    "position",
    "method",
    "dtype",
    "compile_s",
    "temp_mib",
    "out_mib",
    "args_mib",
    "median_ms",
    "p10_ms",
    "p90_ms",
    "runs",
    "ratio",
    "missed",
    "false",
    "ties",
    "wrong_segment",
    "max_gap_error",
    "wrong_by",
    "max_t_error",
    "note",
)


def row(scene, nodes, segments, method, timing=None, mismatch=None, **fields) -> dict:
    """One result row; ``timing`` a ``Timing`` (or None: not run), ``mismatch`` a ``Mismatch``.

    Example:
      >>> row("cutting", 10, 20, "NumPy dense", note="skipped")["median_ms"]
      ''
    """
    out = dict.fromkeys(COLUMNS, "")
    out.update(scene=scene, nodes=nodes, segments=segments, method=method)
    if timing is not None:
        out.update(timing_fields(timing))
    if mismatch is not None:
        out.update(mismatch_fields(mismatch))
    out.update(fields)
    return out


def mismatch_fields(mismatch) -> dict:
    """The row fields of an ``answers.Mismatch``: its counts, the errors formatted."""
    return {
        **mismatch._asdict(),
        "max_gap_error": f"{mismatch.max_gap_error:.3g}",
        "wrong_by": f"{mismatch.wrong_by:.3g}",
    }


def run_methods(methods, check, *, repeats, slow_s, library, prepare_args=(), **fields):
    """Every method on one scene: compiled, checked, then timed round-robin; one row each.

    Args:
      methods: name -> ``(fn, args)``, a peer's ``prepare`` (called with
        ``prepare_args``, it returns them or a string), or a string saying
        why that method is not run (its row's note). A jitted ``fn`` is compiled ahead of the
        runs (``compile_s``: tracing, lowering and compiling) and XLA's
        account of the compiled program is kept: ``temp_mib`` (temporaries),
        ``out_mib`` (outputs) and ``args_mib`` (arguments). A plain ``fn``
        may carry the ``compile_s`` of its own preparation as an attribute.
      check: ``result -> dict`` of row fields (the reference's counts and a
        note) for the answer of the first call, which is also a warm-up.
      repeats: timed rounds of each method (``add_timings``).
      slow_s: a method whose first call took longer is timed by that call.
      library: the method every ``ratio`` is against.
      prepare_args: the arguments of every ``prepare`` in ``methods``.
      **fields: what every row holds beside: ``scene``, ``nodes``,
        ``segments``, ``dtype`` (left empty in the rows of methods not run).

    Returns:
      One row per method, in the order of ``methods``.
    """
    rows, timed, single = [], {}, {}
    for name, method in methods.items():
        entry = row(method=name, **fields)
        if callable(method):
            method = method(*prepare_args)  # (fn, args), or why it cannot run here
        if isinstance(method, str):
            rows.append({**entry, "dtype": "", "note": method})
            continue
        fn, args = method
        if hasattr(fn, "lower"):
            call, compile_s = compiled_call(fn, args)
            entry.update(memory_fields(call))
        else:
            call, compile_s = fn, getattr(fn, "compile_s", None)
        began = time.perf_counter()
        result = jax.block_until_ready(call(*args))
        first_s = time.perf_counter() - began
        entry.update(check(result))
        time_or_note(entry, name, call, args, first_s, slow_s, timed, single)
        entry["compile_s"] = "" if compile_s is None else round(compile_s, 3)
        rows.append(entry)
    return add_timings(rows, timed, single, repeats, library)


def memory_fields(compiled) -> dict:
    """XLA's account of a compiled program, in MiB: temporaries, outputs, arguments.

    Temporaries plus outputs is what one call allocates beyond its
    arguments (donated arguments aside): the program's own peak, as XLA
    plans it. Empty fields where the backend gives no account.
    """
    memory = compiled.memory_analysis()
    if memory is None:
        return {}
    return {
        "temp_mib": round(memory.temp_size_in_bytes / 2**20, 3),
        "out_mib": round(memory.output_size_in_bytes / 2**20, 3),
        "args_mib": round(memory.argument_size_in_bytes / 2**20, 3),
    }


def time_or_note(entry, name, call, args, first_s, slow_s, timed, single) -> None:
    """Queues ``call`` for the round-robin in ``timed``, or, when its first call
    took over ``slow_s`` seconds, keeps that one call as its time in ``single``
    and says so in ``entry["note"]``."""
    if first_s > slow_s:
        single[name] = Timing(None, first_s, first_s, first_s, 1)
        entry["note"] += f"; first call {first_s:.1f} s > {slow_s:g} s: timed once"
    else:
        timed[name] = (call, args)


def add_timings(rows, timed, single, repeats, library) -> list[dict]:
    """``rows`` with each method's timing and its ratio to ``library``'s median;
    ``timed`` run round-robin (``time_interleaved``), ``single`` as they are."""
    timings = {**time_interleaved(timed, repeats=repeats, warmup=0), **single}
    library_ms = timings[library].median_s * 1e3
    for entry in rows:
        timing = timings.get(entry["method"])
        if timing is None:
            continue
        entry.update({**timing_fields(timing), "compile_s": entry["compile_s"]})
        entry["ratio"] = f"{timing.median_s * 1e3 / library_ms:.2f}"
    return rows


def timing_fields(timing) -> dict:
    """The row fields of a ``Timing``: compile seconds, median and spread in ms, runs."""
    return {
        "compile_s": "" if timing.compile_s is None else round(timing.compile_s, 3),
        "median_ms": round(timing.median_s * 1e3, 4),
        "p10_ms": round(timing.p10_s * 1e3, 4),
        "p90_ms": round(timing.p90_s * 1e3, 4),
        "runs": timing.runs,
    }


def sized_contact(radius, sizes):
    """``bucket_sort`` with fixed ``sizes``, jitted: ``fn(x, surface) -> Contact``.

    The benchmarks' "bucket_sort (sized)": the sizes are measured once outside
    the timer (``jaxcontact._pipeline.sizes.measure``); every call runs the whole
    search with them, broad phase included. The one-call ``bucket_sort``
    measures them again at every call, on the host.
    """

    @jax.jit
    def contact(x, surface):
        return sized_bucket_sort(x, surface, radius=radius, sizes=sizes)

    return contact


def sized_crossing(sizes):
    """``bucket_swept`` with fixed ``sizes``, jitted: ``fn(x_prev, x, surface) -> Crossing``
    (the benchmarks' "bucket_swept (sized)"; see ``sized_contact``)."""

    @jax.jit
    def crossing(x_prev, x, surface):
        return sized_bucket_swept(x_prev, x, surface, sizes=sizes)

    return crossing


def contact_of(result):
    """A ``Search`` step's ``Contact`` (the first of its ``(Contact, state)``); else ``result``."""
    if not hasattr(result, "found") and hasattr(result[0], "found"):
        return result[0]
    return result


def answer_of(result, num_rows: int | None = None):
    """``(segment, gap, found)`` as NumPy arrays, from a ``Contact``, a ``ContactList``
    (of ``num_rows`` slaves), a ``Search`` step's ``(Contact, state)`` or a peer's tuple."""
    result = contact_of(result)
    if isinstance(result, ContactList):
        result = result.to_contact(num_rows)
    if hasattr(result, "found"):
        return np.asarray(result.segment), np.asarray(result.gap), np.asarray(result.found)
    return tuple(np.asarray(part) for part in result[:3])


def check(result, x, start, end, reference) -> answers.Mismatch:
    """``answers.compare``'s count of how ``result`` differs from ``reference``."""
    return answers.compare(*answer_of(result, len(x)), x, start, end, reference)


def reference_fields(result, x, start, end, reference) -> dict:
    """The row fields of ``result`` checked against ``reference``: ``answers.compare``'s
    counts, and a note that says them in words (and ``overflow`` where a ``Contact`` set it)."""
    mismatch = check(result, x, start, end, reference)
    overflow = "; overflow" if bool(getattr(contact_of(result), "overflow", False)) else ""
    return {**mismatch_fields(mismatch), "note": answers.describe(mismatch) + overflow}


def endpoints(surface):
    """NumPy ``(start, end)`` f[M, 2] of a ``Surface``'s segments."""
    nodes = np.asarray(surface.nodes)
    segments = np.asarray(surface.segments)
    return nodes[segments[:, 0]], nodes[segments[:, 1]]


def progress(items, desc: str):
    """``items`` wrapped in a tqdm bar when tqdm is installed, else a plain counter on stderr."""
    items = list(items)
    try:
        from tqdm import tqdm
    except ImportError:
        return _plain_progress(items, desc)
    return tqdm(items, desc=desc, file=sys.stderr, leave=False)


def _plain_progress(items, desc):
    for index, item in enumerate(items):
        print(f"{desc}: {index + 1}/{len(items)}", file=sys.stderr, flush=True)
        yield item


# glibc's malloc.h: the two parameters ``reuse_pages`` sets with ``mallopt``.
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
PAGES_REUSED = 1 << 30  # bytes: both thresholds, as MALLOC_MMAP_THRESHOLD_=1073741824 sets them
_allocator = []  # ``reuse_pages``'s note, for ``machine``'s line


def glibc_mallopt():
    """glibc's ``mallopt``, or None where the C library is not glibc."""
    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c")).mallopt
    except (OSError, AttributeError, TypeError):
        return None
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return mallopt


def set_thresholds(mallopt, threshold: int) -> bool:
    """glibc's mmap and trim thresholds, both to ``threshold`` bytes; whether
    glibc took both (``mallopt`` returns 0 for a value it refuses: glibc
    before 2.26 caps the mmap threshold at 32 MiB)."""
    return bool(mallopt(M_MMAP_THRESHOLD, threshold)) & bool(mallopt(M_TRIM_THRESHOLD, threshold))


def reuse_pages() -> None:
    """Has glibc keep freed blocks for the next call (both thresholds 1 GiB), as
    ``MALLOC_MMAP_THRESHOLD_=1073741824 MALLOC_TRIM_THRESHOLD_=1073741824`` would
    from a process's start; ``machine``'s line says so from then on.

    With glibc's start values a block of 128 KiB or more is mapped fresh and
    unmapped at ``free``, so each call's buffers fault their pages in again,
    and glibc moves the threshold itself as large blocks are freed: a call's
    time then depends on what ran before it in the process (the numba grid on
    the chip's outline at 10^4 nodes: 4.4-4.7 ms in a new process, 1.0 ms
    after a scene of 10^6 nodes). The archive's ``malloc.py`` (commit
    ``5928bf7f76cc``) measured both settings; every program ran as fast
    or faster with pages reused, so the comparisons of peers set it for all of them.
    """
    mallopt = glibc_mallopt()
    if mallopt is None:
        _allocator[:] = ["glibc's malloc thresholds not set (not glibc)"]
        return
    if not set_thresholds(mallopt, PAGES_REUSED):
        _allocator[:] = ["glibc refused the malloc thresholds (pages not kept)"]
        return
    _allocator[:] = ["glibc's malloc keeps freed pages (mmap and trim thresholds 1 GiB)"]


def machine() -> str:
    """One line: the CPU, the cores this process may use, jax and numpy versions."""
    return "; ".join(
        [
            report.cpu(),
            pinned_note(),
            f"python {platform.python_version()}, jax {jax.__version__}, "
            f"numpy {np.__version__}, {jax.devices()[0].device_kind}",
            *_allocator,
        ]
    )


def suite(name, run, draw, description, argv=None, *, options=()) -> int:
    """The command line of a maintained suite ``benchmarks/<name>.py``.

    ``run(args)`` measures and returns ``{"title", "tables", "data", "notes"}`` (tables from
    ``report.table``); the record (with its provenance) goes to ``<--out>/<name>.json``, its
    figure, ``draw(record, pyplot)``, to ``<--out>/<name>.png``, and its markdown to standard
    output. ``options``: more ``(flags, keywords)`` for ``add_argument``.
    """
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help="small sizes, a smoke test")
    parser.add_argument("--out", default="benchmarks/results", help="folder for JSON and PNG")
    parser.add_argument("--repeats", type=int, default=None, help="timed runs per method")
    for flags, keywords in options:
        parser.add_argument(*flags, **keywords)
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    reuse_pages()  # every peer at its best (malloc.py in commit 5928bf7f76cc)
    jax.config.update("jax_enable_x64", True)  # float64 scenes and variants beside float32
    rec = _record(name, args, run(args), argv)
    rec["allocator"] = list(_allocator)
    written = report.save(rec, args.out, draw)
    print(report.markdown(rec, f"{name}.png" if len(written) > 1 else None))
    print(f"wrote {', '.join(written)}", file=sys.stderr)
    return 0


def _record(name: str, args, found: dict, argv=None) -> dict:
    return report.record(
        name,
        found["title"],
        found["tables"],
        data=found.get("data"),
        notes=found.get("notes", ()),
        argv=argv,
        quick=args.quick,
    )


def keep_partial(name: str, args, found: dict) -> None:
    """Saves ``found`` (what ``run`` returns) as the record so far, the JSON alone: a run cut
    short (a lent GPU's time ran out part way once) leaves its finished scenes. The finished
    run writes over it, figure included."""
    rec = _record(name, args, found)
    report.save(rec, args.out)


def cores_short_of(threads: int) -> str | None:
    """Why a peer on ``threads`` threads cannot run in this process, or None.

    Under ``taskset -c 0`` (a pinned run) one core is allowed, and numba
    refuses more threads than cores.
    """
    cores = len(os.sched_getaffinity(0))
    if threads <= cores:
        return None
    return f"not run: {threads} threads, {cores} core allowed (pinned)"


def numba_peer(kind: str, threads: int, dtype, args: tuple, **options):
    """A peer's ``prepare`` result for ``numba_grid.<kind>`` (``"closest"`` or
    ``"swept"``) on ``threads``: ``(fn, args)``, compiled ahead for ``dtype``
    (``fn.compile_s``, reported apart as a jitted peer's compilation is), or
    why it cannot run in this process (``cores_short_of``)."""
    short = cores_short_of(threads)
    if short:
        return short
    compile_s = numba_grid.compile_for(kind, dtype, threads)
    fn = functools.partial(getattr(numba_grid, kind), threads=threads, **options)
    fn.compile_s = compile_s
    return fn, args
