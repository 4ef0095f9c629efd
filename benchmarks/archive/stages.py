"""Where the sized bucket sort's time goes: each stage timed apart, beside the floors.

    python benchmarks/stages.py                       # cutting 81,939 and 10^6, rough die 10^5
    python benchmarks/stages.py --scenes cutting-81939 --repeats 40
    python benchmarks/stages.py --against main        # and that revision's bucket sort beside
    python benchmarks/stages.py --quick               # 10^4 nodes, a smoke test
    XLA_FLAGS=--xla_cpu_enable_xprof_traceme=true python benchmarks/stages.py --profile DIR

On each scene (float32, ``docs/scenes.md``; the scenes of ``peers.py``) the
closest-point bucket sort with measured ``Sizes`` ("bucket_sort (sized)" of
``peers.py``) is cut into its stages, each its own jitted function run on
the real output of the stage before:

- broad: resolved segments, the master's box, the kept blocks;
- kept: the kept slaves gathered;
- cells (many segments only): segments binned, each kept slave's list;
- search: the chosen segment of each kept slave;
- assemble: the ``Contact`` of the kept slaves (the tie rule included);
- write: their rows written into N rows of nothing found.

The compact form (``ContactList``: the same search, only the slaves that
may be found assembled, packed into a measured capacity, no N rows written)
is timed beside the whole, checked against it to rounding.

Their sum is not the whole program's time (a stage apart pays a dispatch and
loses fusion across its borders) but shows the split. Beside them, in the
same round-robin: the whole program, the floors (an empty jitted call; one
vectorised pass over ``x``; a ``Contact`` of N rows of zeros with the found
rows scattered in, and the three fields the numba grid returns) and the
numba grid on one thread. Every stage's result is checked bit for bit
against the whole program's. ``kernels`` counts the thunks XLA's CPU
runtime runs per call of each program (fusions and other non-trivial
instructions, each while body once); ``--profile DIR`` also writes a
perfetto trace of the whole program and prints its ten costliest thunks
(run with the traceme flag above: without it the trace holds no thunks).
``--against REV`` times that git revision's bucket sort beside this one
(the package extracted under another name), checked bit for bit.
"""

from __future__ import annotations

import argparse
import functools
import glob
import gzip
import json
import os
import pathlib
import re
import sys
from collections import Counter

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import _run
from benchmarks.harness.internals import (
    _inputs,
    broad_phase,
    contact_from_choice,
    empty_contact,
    kept_rows,
    list_candidates,
    measure,
    measure_contacts,
    ruled,
    search_all,
    search_listed,
    squared_distance,
    vmapped,
    write_blocks,
)
from benchmarks.harness.revision import extracted
from benchmarks.harness.timing import time_interleaved
from benchmarks.peers import build

SCENES = {
    "cutting-10000": ("cutting, tool in (x_tip=18)", 10_000, 18.0),
    "cutting-81939": ("cutting, tool in (x_tip=18)", 81_939, 18.0),
    "cutting-1e6": ("cutting, tool in (x_tip=18)", 10**6, 18.0),
    "cutting-clear-81939": ("cutting, tool clear (x_tip=20.5)", 81_939, 20.5),
    "die-1e4": ("rough die", 10**4, 10**3),
    "die-1e5": ("rough die", 10**5, 10**4),
    "die-1e6": ("rough die", 10**6, 10**5),
}
# Instructions that run no kernel of their own.
_FREE = {"parameter", "constant", "get-tuple-element", "tuple", "bitcast", "opt-barrier"}


def stage_programs(sizes, num_rows):
    """name -> jitted stage: the sized closest-point bucket sort cut where its data is small."""
    block_size, capacity = sizes.block_size, sizes.block_capacity

    def broad(x, surface, radius):
        segments = _inputs.resolve_segments(surface)
        boxes, blocks = broad_phase(x, x, None, segments, radius, block_size, capacity)
        return segments, boxes, blocks

    def kept(x, blocks):
        (rows,), ok = kept_rows(blocks, None, x)
        return rows, ok

    def cells(kept, ok, segments, boxes):
        return list_candidates(kept, ok, segments, boxes, sizes)[0]

    # The pair score as the detectors call it: ``(*row, row_tags, (edge, tags))``, no rule.
    kernel = ruled(squared_distance, None)

    def search(kept, segments, listed):
        if sizes.use_cells:
            return search_listed(kernel, (kept, None), segments, listed, sizes)[0]
        pair_value = vmapped(kernel, kept, None)
        return search_all(pair_value, segments, kept.shape[0], kept.dtype)[0]

    def assemble(kept, segments, choice, radius, ok):
        return contact_from_choice(kept, segments, choice, radius, jnp.zeros((), bool), ok)

    def write(part, blocks):
        empty = empty_contact(jnp.zeros((num_rows, 2), part.gap.dtype), part.overflow)
        return write_blocks(part, blocks, empty, block_size)

    programs = {"broad": broad, "kept": kept, "cells": cells, "search": search}
    programs |= {"assemble": assemble, "write": write}
    return {name: jax.jit(fn) for name, fn in programs.items()}


def staged_calls(scene, sizes, whole):
    """name -> (jitted, args) of every stage on the real inputs, checked against ``whole``."""
    programs = stage_programs(sizes, scene.x.shape[0])
    radius = jnp.asarray(scene.radius, scene.x.dtype)
    calls = {"broad": (programs["broad"], (scene.x, scene.surface, radius))}
    segments, boxes, blocks = programs["broad"](*calls["broad"][1])
    calls["kept"] = (programs["kept"], (scene.x, blocks))
    kept, ok = programs["kept"](*calls["kept"][1])
    listed = None
    if sizes.use_cells:
        calls["cells"] = (programs["cells"], (kept, ok, segments, boxes))
        listed = programs["cells"](*calls["cells"][1])
    calls["search"] = (programs["search"], (kept, segments, listed))
    choice = programs["search"](*calls["search"][1])
    calls["assemble"] = (programs["assemble"], (kept, segments, choice, radius, ok))
    part = programs["assemble"](*calls["assemble"][1])
    calls["write"] = (programs["write"], (part, blocks))
    same(programs["write"](*calls["write"][1]), whole, "the stages")
    return calls


def floor_calls(scene, whole):
    """name -> (jitted, args): what any answer costs at least, on this machine."""
    num_rows, x = scene.x.shape[0], scene.x
    found = np.flatnonzero(np.asarray(whole.found)).astype(np.int32)
    rows = jnp.asarray(found)
    gap, segment, point = whole.gap[rows], whole.segment[rows], whole.point[rows]
    low, high = jnp.min(scene.surface.nodes, axis=0), jnp.max(scene.surface.nodes, axis=0)

    def dispatch(value):
        return value + 1

    def read(x, low, high):
        # Per coordinate: ``jnp.all(..., axis=-1)`` over the length-2 axis runs
        # as a loop per row on XLA's CPU, about twice this floor's time.
        inside = [(x[:, k] >= low[k]) & (x[:, k] <= high[k]) for k in (0, 1)]
        return jnp.any(inside[0] & inside[1])

    def write_contact(rows, gap, segment, point):
        empty = empty_contact(jnp.zeros((num_rows, 2), gap.dtype), jnp.zeros((), bool))
        return empty._replace(
            gap=empty.gap.at[rows].set(gap),
            xi=empty.xi.at[rows].set(gap),
            segment=empty.segment.at[rows].set(segment),
            point=empty.point.at[rows].set(point),
            normal=empty.normal.at[rows].set(point),
            found=empty.found.at[rows].set(True),
            active=empty.active.at[rows].set(gap < 0),
        )

    def write_three(rows, gap, segment):
        return (
            jnp.full((num_rows,), -1, jnp.int32).at[rows].set(segment),
            jnp.zeros((num_rows,), gap.dtype).at[rows].set(gap),
            jnp.zeros((num_rows,), bool).at[rows].set(True),
        )

    # The Contact's bytes per row: gap, xi, segment, point, normal, found, active.
    row_bytes = 5 * x.dtype.itemsize + 4 + 2
    buffer = np.empty(num_rows * row_bytes, np.uint8)
    return {
        "floor: NumPy fill of the Contact's bytes": (lambda: buffer.fill(0), ()),
        "floor: dispatch": (jax.jit(dispatch), (gap[:1],)),
        "floor: read x once": (jax.jit(read), (x, low, high)),
        "floor: write Contact": (jax.jit(write_contact), (rows, gap, segment, point)),
        "floor: write 3 fields": (jax.jit(write_three), (rows, gap, segment)),
    }


def same(result, expected, what: str, rounding: bool = False) -> int:
    """Raises unless every field of two ``Contact`` s is bit-identical (with
    ``rounding``: the float fields to 16 ulps of the coordinates' scale, and
    a row may name the other segment of a vertex tie, where its gap and
    point agree to that and the two segments' float32 distances round
    alike). Returns how many rows did that."""
    scale = 1 + float(np.max(np.abs(np.asarray(expected.point)), initial=0))
    tol = 16 * float(np.finfo(np.asarray(expected.gap).dtype).eps) * scale
    other = np.zeros(np.asarray(expected.gap).shape, bool)
    if rounding:
        segment, wanted_segment = np.asarray(result.segment), np.asarray(expected.segment)
        near = np.abs(np.asarray(result.gap) - np.asarray(expected.gap)) <= tol
        near &= np.all(np.abs(np.asarray(result.point) - np.asarray(expected.point)) <= tol, -1)
        other = (segment != wanted_segment) & near
    for name in expected._fields:
        got, wanted = np.asarray(getattr(result, name)), np.asarray(getattr(expected, name))
        if wanted.shape[:1] == other.shape:
            got, wanted = got[~other], wanted[~other]
        if rounding and np.issubdtype(wanted.dtype, np.floating):
            equal = np.allclose(got, wanted, rtol=0, atol=tol)
        else:
            equal = np.array_equal(got, wanted)
        if not equal:
            raise AssertionError(f"{what}: field {name} differs from the whole program's")
    return int(np.sum(other))


def kernels(jitted, args) -> int:
    """Thunks the CPU runtime runs for one call: instructions of the entry
    computation and of every branch, loop body and called computation, less
    those that run nothing (fusion bodies are one kernel; loop bodies counted once)."""
    return len(kernel_lines(jitted.lower(*args).compile().as_text())[0])


def kernel_lines(text: str) -> tuple[list[str], dict[str, list[str]]]:
    """``kernels``' thunks as the lines of the optimised HLO ``text`` that make
    them, and every computation's lines by name (a fusion's body among them)."""
    text = re.sub(r"/\*.*?\*/", "", text)
    bodies, name = {}, None
    for line in text.splitlines():
        head = re.match(r"^(?:ENTRY )?%(\S+) .*\{$", line)
        if head:
            name = head.group(1)
            bodies[name] = []
            if line.startswith("ENTRY"):
                entry = name
        elif name and re.match(r"^\s+(ROOT )?%", line):
            bodies[name].append(line)
    made, todo, seen = [], [entry], set()
    while todo:
        computation = todo.pop()
        if computation in seen:
            continue
        seen.add(computation)
        for line in bodies[computation]:
            opcode = re.search(r"= (?:\([^=]*?\)|\S+) ([a-z][a-z0-9-]*)\(", line)
            opcode = opcode.group(1) if opcode else ""
            if opcode in ("conditional", "while", "call"):
                attrs = r"(?:branch_computations=\{[^}]*\}|body=%\S+|condition=%\S+|to_apply=%\S+)"
                for found in re.findall(attrs, line):
                    todo += re.findall(r"%([\w.-]+)", found)
            elif opcode and opcode not in _FREE:
                made.append(line)
    return made, bodies


# The stage each library function belongs to, for attributing a thunk by its call stack.
STAGE_OF = {
    "rows_ok": "broad",
    "resolve_segments": "broad",
    "broad_phase": "broad",
    "kept_rows": "kept",
    "list_candidates": "cells",
    "search_all": "search",
    "search_listed": "search",
    "contact_from_choice": "assemble",
    "write_blocks": "write",
    "empty_contact": "write",
}


def stage_of_instructions(text: str) -> dict:
    """instruction name -> stage, from the innermost library function in its
    call stack (the metadata of a compiled program's text)."""
    tables = {}
    for table in ("FunctionNames", "FileLocations", "StackFrames"):
        block = re.search(rf"^{table}\n(.*?)\n\n", text, re.S | re.M)
        tables[table] = dict(re.findall(r"^(\d+) (.*)$", block.group(1), re.M) if block else [])
    functions = {key: value.strip('"') for key, value in tables["FunctionNames"].items()}
    location = {
        key: re.search(r"function_name_id=(\d+)", value).group(1)
        for key, value in tables["FileLocations"].items()
    }
    frames = {
        key: re.search(r"file_location_id=(\d+) parent_frame_id=(\d+)", value).groups()
        for key, value in tables["StackFrames"].items()
    }

    def stage(frame):
        while frame in frames:
            place, parent = frames[frame]
            name = functions.get(location.get(place, ""), "")
            if name in STAGE_OF:
                return STAGE_OF[name]
            # The text names a frame's parent by its number plus one (0: none).
            frame = str(int(parent) - 1)
        return "other"

    found = re.findall(r"^\s+(?:ROOT )?%(\S+) = .*?stack_frame_id=(\d+)", text, re.M)
    return {name: stage(frame) for name, frame in found}


def profile(jitted, args, out: str, repeats: int = 5) -> list[str]:
    """Thunk time of ``jitted`` per call, by stage and for the ten costliest
    thunks, from a perfetto trace (microseconds, inflated by the tracing)."""
    call = jitted.lower(*args).compile()
    stages = stage_of_instructions(call.as_text())
    jax.block_until_ready(call(*args))
    with jax.profiler.trace(out, create_perfetto_trace=True):
        for _ in range(repeats):
            jax.block_until_ready(call(*args))
    (path,) = glob.glob(os.path.join(out, "**", "perfetto_trace.json.gz"), recursive=True)
    with gzip.open(path) as stream:
        events = json.load(stream)
    events = events["traceEvents"] if isinstance(events, dict) else events
    spent, by_stage, runs = Counter(), Counter(), 0
    for event in events:
        name = event.get("name", "")
        # Branches and loops hold the thunks they run: count those only.
        if event.get("ph") == "X" and name in stages and not name.startswith(("cond", "while")):
            spent[name] += event["dur"] / repeats
            by_stage[stages[name]] += event["dur"] / repeats
            runs += 1
    lines = [f"{runs / repeats:.0f} thunks run per call; by stage:"]
    lines += [f"{us:10.1f} us  {stage}" for stage, us in by_stage.most_common()]
    lines.append("costliest thunks:")
    lines += [f"{us:10.1f} us  {name} ({stages[name]})" for name, us in spent.most_common(10)]
    return lines


def against(revision: str):
    """``(package, sized_contact)`` of the bucket sort at git ``revision``, imported
    as ``jaxcontact_against`` from an extracted copy (``harness.revision``)."""
    package = extracted(revision)
    from jaxcontact_against._sizes import measure as measure_then
    from jaxcontact_against.bench._run import sized_contact

    return package, functools.partial(_sized_then, measure_then, sized_contact)


def _sized_then(measure_then, sized_contact, scene, surface):
    sizes = measure_then(scene.x, surface, radius=scene.radius)
    return sized_contact(scene.radius, sizes)


def numba_call(scene):
    """The numba grid on one thread, compiled, or None where numba is missing."""
    from benchmarks.peer_codes import baselines, numba_grid

    if baselines.unavailable("numba grid (1 thread)"):
        return None
    x = np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    numba_grid.compile_for("closest", x.dtype)
    return lambda: numba_grid.closest(x, start, end, scene.radius), ()


def run_scene(key, repeats, revision=None, profile_dir=None) -> str:
    scene = build(*SCENES[key])
    sizes = measure(scene.x, scene.surface, radius=scene.radius)
    whole = _run.sized_contact(scene.radius, sizes)
    expected = whole(scene.x, scene.surface)
    calls = {"bucket_sort (sized)": (whole, (scene.x, scene.surface))}
    if revision:
        package, sized_then = against(revision)
        surface = package.Surface(*scene.surface)
        then = sized_then(scene, surface)
        same(then(scene.x, surface), expected, f"bucket_sort at {revision}")
        calls[f"bucket_sort (sized) at {revision}"] = (then, (scene.x, surface))
    # The compact form: the same search, the found rows packed, no N rows written.
    compact_sizes = measure_contacts(scene.x, scene.surface, scene.radius, None, sizes, 1.5)
    compact = _run.sized_contact(scene.radius, compact_sizes)
    calls["bucket_sort (sized, compact)"] = (compact, (scene.x, scene.surface))
    packed = compact(scene.x, scene.surface).to_contact(scene.x.shape[0])
    ties = same(packed, expected, "compact", rounding=True)
    stages = staged_calls(scene, sizes, expected)
    calls |= {f"stage: {name}": call for name, call in stages.items()}
    calls |= floor_calls(scene, expected)
    numba = numba_call(scene)
    if numba:
        calls["numba grid (1 thread)"] = numba
    timings = time_interleaved(calls, repeats=repeats)
    base = timings["bucket_sort (sized)"].median_s
    found = int(np.asarray(expected.found).sum())
    lines = [
        f"### {SCENES[key][0]}, N = {scene.x.shape[0]:,}, M = {scene.surface.segments.shape[0]:,}",
        "",
        f"{found:,} rows found ({found / scene.x.shape[0]:.2%}); kept slaves "
        f"{sizes.slave_capacity:,} ({sizes.block_capacity} blocks of {sizes.block_size}); "
        f"cells {'x'.join(map(str, sizes.grid_shape)) if sizes.use_cells else 'none'}"
        + (
            f"; the compact form names the other segment of a vertex tie in {ties} rows"
            if ties
            else ""
        ),
        "",
        "| program | median ms | p10-p90 ms | of the whole | kernels |",
        "|---|---:|---:|---:|---:|",
    ]
    stage_sum = 0.0
    for name, timing in timings.items():
        jitted, args = calls[name]
        count = kernels(jitted, args) if hasattr(jitted, "lower") else ""
        if name.startswith("stage:"):
            stage_sum += timing.median_s
        lines.append(
            f"| {name} | {timing.median_s * 1e3:.3f} | {timing.p10_s * 1e3:.3f}-"
            f"{timing.p90_s * 1e3:.3f} | {timing.median_s / base:.2f} | {count} |"
        )
    lines.append(f"| sum of the stages | {stage_sum * 1e3:.3f} | | {stage_sum / base:.2f} | |")
    if profile_dir:
        lines += ["", "The whole program's thunks, traced (inflated by the tracing):", "", "```"]
        lines += profile(whole, (scene.x, scene.surface), os.path.join(profile_dir, key))
        lines.append("```")
    return "\n".join(lines + [""])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = ["cutting-81939", "cutting-1e6", "die-1e5"]
    parser.add_argument("--scenes", nargs="+", choices=SCENES, default=default)
    parser.add_argument("--repeats", type=int, default=20, help="timed runs of each program")
    parser.add_argument("--quick", action="store_true", help="small scenes, 5 runs: a smoke test")
    parser.add_argument("--against", help="git revision whose bucket sort is timed beside")
    parser.add_argument("--profile", help="folder for perfetto traces of the whole programs")
    args = parser.parse_args(argv)
    command = " ".join(["python benchmarks/stages.py", *(sys.argv[1:] if argv is None else argv)])
    print(f"`{command}`; {_run.machine()}; float32", flush=True)
    scenes, repeats = args.scenes, args.repeats
    if args.quick:
        scenes, repeats = ["cutting-10000", "die-1e4"], 5
    for key in scenes:
        print(run_scene(key, repeats, args.against, args.profile), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
