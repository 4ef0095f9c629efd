"""Path crossing, jaxcontact beside its peers: the first crossing of ``x_prev -> x``, timed.

    python benchmarks/swept_peers.py [--quick] [--out DIR] [--repeats K] [--slow S] [--scenes 6,7]
    taskset -c 0 python benchmarks/swept_peers.py --out benchmarks/results/pinned

Scenes (docs/scenes.md) with motion: the cutting scene with the tool in the
workpiece (``x_tip = 18``, previous tip 18.2) at 10^4, 81,939 and 10^6
nodes, the same with the tool clear (20.5, previous 20.7) at 81,939 and
10^6, and the paper's Tests 1 (n = 286, d = 5) and 2 (n = 250, face length
20, d = 10). On each, ``swept``, ``bucket_swept (sized)`` (float32, jit;
the bucket sort with its ``Sizes`` measured outside the timer), the compact
form ``Search.swept, compact`` (a jitted ``Search(compact=True).swept`` step
returning a ``CrossingList``, allocated outside the timer) and every peer
of ``SWEPT_PEERS`` that is installed run round-robin (``time_interleaved``);
``ratio`` is a method's median over ``bucket_swept (sized)``'s.

Every answer is checked against jaxcontact's ``swept`` in float64 on the
same (float32) numbers: ``missed`` and ``false`` crossings, ``ties`` (another
segment met at the same time to within 1e-9: a path through a vertex shared
by two segments), ``wrong_segment`` (another segment, met later) and
``max_t_error`` (the largest ``|t - t_reference|`` where both cross).

The record (``<out>/swept_peers.json``) and figure (``<out>/swept_peers.png``: each
method's median against the node count, one panel per scene family, the paper's tests,
one size each, in a panel of their own) are built as ``peers.py``'s. ``--scenes``
runs the full run's scenes of those numbers only (1 to 7, in the order above), to
finish a run that was cut short (a lent GPU's time): the record is written after each
scene.
"""

from __future__ import annotations

import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks import peers
from benchmarks.harness import _run
from benchmarks.harness.internals import measure
from benchmarks.peer_codes import baselines, ipc
from jaxcontact import CrossingList, Search, swept
from jaxcontact.scenes import cutting_scene, paper_scene

LIBRARY = "bucket_swept (sized)"
COMPACT = "Search.swept, compact"  # returns a CrossingList: the crossed paths only
PAIR_BUDGET = 5e7  # NumPy dense: (N, M) float32 temporaries of about 0.2 GB each
TIE = 1e-9  # two float64 times this close are one time (a shared vertex)

FULL_SCENES = (
    *(("cutting, tool in (x_tip=18 from 18.2)", n, (18.0, 18.2)) for n in (10**4, 81_939, 10**6)),
    *(("cutting, tool clear (x_tip=20.5 from 20.7)", n, (20.5, 20.7)) for n in (81_939, 10**6)),
    ("paper Test 1 (d=5)", 286, (10.0, 5.0)),
    ("paper Test 2 (length 20, d=10)", 250, (20.0, 10.0)),
)
QUICK_SCENES = (
    ("cutting, tool in (x_tip=18 from 18.2)", 10**4, (18.0, 18.2)),
    ("cutting, tool clear (x_tip=20.5 from 20.7)", 10**4, (20.5, 20.7)),
    ("paper Test 1 (d=5)", 99, (10.0, 5.0)),
)


def build(kind, size, parameters):
    """The scene: ``size`` nodes (the paper's ``n``); ``parameters`` two tips or (length, d)."""
    if kind.startswith("paper"):
        length, travel = parameters
        return paper_scene(size, length=length, d=travel)
    x_tip, x_tip_prev = parameters
    return cutting_scene(size, x_tip, x_tip_prev=x_tip_prev)


def numpy_dense(x_prev, x, start, end):
    """``baselines.brute_crossing`` on NumPy: every path-segment pair at once."""
    return baselines.brute_crossing(np, x_prev, x, start, end)


def _numba_grid(threads):
    """prepare for ``numba_grid.swept`` on ``threads``: compiled ahead (``fn.compile_s``)."""

    def prepare(x_prev, x, start, end):
        return _run.numba_peer("swept", threads, x.dtype, (x_prev, x, start, end))

    return prepare


def _plain(peer):
    return lambda x_prev, x, start, end: (peer, (x_prev, x, start, end))


# name -> (module it needs, or None; prepare(x_prev, x, start, end) -> (fn, args)); each fn
# returns (segment, t, crossed) as NumPy arrays.
SWEPT_PEERS = {
    "NumPy dense": (None, _plain(numpy_dense)),
    "numba grid (1 thread)": ("numba", _numba_grid(1)),
    "numba grid (prange, 2 threads)": ("numba", _numba_grid(2)),
    "IPC Toolkit LBVH + Tight Inclusion CCD": ("ipctk", _plain(ipc.ipctk_lbvh_ccd)),
}


def reference_crossing(scene):
    """``(segment, t, crossed)`` of jaxcontact's ``swept`` in float64 on the scene's numbers."""
    if not jax.config.jax_enable_x64:
        raise ValueError("reference_crossing needs jax_enable_x64 (the bench entry points set it)")
    nodes = scene.surface.nodes.astype(jnp.float64)
    crossing = swept(
        scene.x_prev.astype(jnp.float64),
        scene.x.astype(jnp.float64),
        scene.surface._replace(nodes=nodes),
    )
    return np.asarray(crossing.segment), np.asarray(crossing.t), np.asarray(crossing.crossed)


def pair_time(x_prev, x, start, end):
    """f64[K]: the time ``t`` where each path meets its own segment's line, row by row (or inf).

    Example:
      >>> pair_time([[0.0, 1.0]], [[0.0, -1.0]], [[-1.0, 0.0]], [[1.0, 0.0]]).tolist()
      [0.5]
    """
    x_prev, x, start, end = (np.asarray(a, np.float64) for a in (x_prev, x, start, end))
    motion, direction = x - x_prev, end - start
    denominator = baselines.cross(motion, direction)
    safe = np.where(denominator == 0, 1, denominator)
    return np.where(denominator == 0, np.inf, baselines.cross(start - x_prev, direction) / safe)


def compare_crossing(result, reference, x_prev, x, start, end) -> dict:
    """Row fields counting how ``(segment, t, crossed)`` differs from ``reference``."""
    segment, t, crossed = (np.asarray(part) for part in result[:3])
    segment = np.where(crossed, segment, -1)
    ref_segment, ref_t, ref_crossed = reference
    both = crossed & ref_crossed
    other = np.flatnonzero(both & (segment != ref_segment))
    own_t = pair_time(x_prev[other], x[other], start[segment[other]], end[segment[other]])
    ties = int(np.sum(np.abs(own_t - ref_t[other]) <= TIE))
    error = np.abs(np.asarray(t, np.float64) - ref_t)[both]
    return {
        "missed": int(np.sum(ref_crossed & ~crossed)),
        "false": int(np.sum(crossed & ~ref_crossed)),
        "ties": ties,
        "wrong_segment": other.size - ties,
        "max_t_error": float(error.max()) if error.size else 0.0,
        "note": "",
    }


def _methods(scene):
    """name -> (fn, args) or a prepare function: the library's two detectors, then the peers."""
    sizes = measure(scene.x, scene.surface, x_prev=scene.x_prev)
    args = (scene.x_prev, scene.x, scene.surface)
    methods = {"swept": (jax.jit(swept), args), LIBRARY: (_run.sized_crossing(sizes), args)}
    # The compact form, as a simulation runs it: a Search step (capacity
    # measured at allocate: the paths crossing then, times the default slack).
    search = Search(compact=True)
    state = search.allocate(scene.x, scene.surface, x_prev=scene.x_prev)
    methods[COMPACT] = (jax.jit(search.swept), (state, *args))
    for name, (_, prepare) in SWEPT_PEERS.items():
        methods[name] = prepare
    return methods


def _skip_reason(name, pairs) -> str | None:
    if name == "NumPy dense" and pairs > PAIR_BUDGET:
        return f"skipped: (N, M) plane of {pairs:.0e} pairs > {PAIR_BUDGET:.0e}"
    return baselines.unavailable_module(SWEPT_PEERS[name][0]) if name in SWEPT_PEERS else None


def run_scene(kind, size, parameters, repeats, slow_s) -> list[dict]:
    """Every method on one scene: checked, then timed round-robin; one row per method, its
    fields JSON scalars (``peers.scalars``)."""
    scene = build(kind, size, parameters)
    x_prev, x = np.asarray(scene.x_prev), np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    reference = reference_crossing(scene)
    methods = {
        name: _skip_reason(name, len(x) * len(start)) or method
        for name, method in _methods(scene).items()
    }

    def check(result):
        if isinstance(result, tuple) and isinstance(result[0], CrossingList):
            assert not bool(result[0].overflow)
            result = result[0].to_crossing(len(x))
        if hasattr(result, "crossed"):
            result = (result.segment, result.t, result.crossed)
        return compare_crossing(result, reference, x_prev, x, start, end)

    rows = _run.run_methods(
        methods,
        check,
        repeats=repeats,
        slow_s=slow_s,
        library=LIBRARY,
        prepare_args=(x_prev, x, start, end),
        scene=kind,
        nodes=len(x),
        segments=len(start),
        dtype=str(x.dtype),
        crossed=int(reference[2].sum()),
    )
    return [peers.scalars(entry) for entry in rows]


NOTE = (
    "float32 inputs; medians of interleaved runs. ratio: a method's median over bucket_swept"
    " (sized)'s (the bucket sort with its sizes measured outside the timer). Each answer is"
    " checked against jaxcontact's swept in float64: missed and false crossings, ties (another"
    " segment met at the same time: a path through a shared vertex), wrong segment (another"
    " one, met later) and the largest |t - t_reference| where both cross. compile s: tracing,"
    " lowering and compiling (jit and numba); memory MiB: XLA's temporaries and outputs of a"
    " jitted method's program."
)
TITLE = "Path crossing: jaxcontact and its peers"


def scene_title(entry) -> str:
    return (
        f"{entry['scene']}: N = {entry['nodes']:,} nodes, M = {entry['segments']:,} segments,"
        f" {entry['crossed']:,} paths cross"
    )


def _found(runs, notes=()) -> dict:
    """The record's title, tables, figure data and notes for ``runs``."""
    return {
        "title": TITLE,
        "tables": [
            peers.ratio_table(runs, LIBRARY, NOTE),
            *peers.scene_tables(runs, "max_t_error", scene_title),
        ],
        "data": {"library": LIBRARY, "runs": runs},
        "notes": [*notes, *peers.left_out_note(runs)],
    }


def run(args) -> dict:
    """Every scene of ``args`` (``quick``, ``repeats``, ``slow``; ``scenes``: the numbers,
    counted from 1, of the scenes to run, all if None): the record's title, tables, figure
    data and notes. The record so far is written to ``<args.out>/swept_peers.json`` after each
    scene (no figure), so a run cut short leaves the scenes it measured."""
    slow_s = args.slow or (3.0 if args.quick else 30.0)
    scenes = QUICK_SCENES if args.quick else FULL_SCENES
    if args.scenes:
        numbers = [int(n) for n in str(args.scenes).split(",")]
        if not all(1 <= n <= len(scenes) for n in numbers):
            raise ValueError(f"scenes: expected numbers from 1 to {len(scenes)}, got {numbers}")
        scenes = tuple(scenes[n - 1] for n in numbers)
    runs = []
    for done, (kind, size, parameters) in enumerate(_run.progress(scenes, "swept"), 1):
        count = args.repeats or (5 if args.quick else (20 if size <= 10**5 else 5))
        runs += run_scene(kind, size, parameters, count, slow_s)
        if done < len(scenes):
            # A lent GPU's time ran out part way once (2 of 7 scenes in 135 s), leaving none.
            found = _found(runs, [f"Partial: {done} of {len(scenes)} scenes."])
            _run.keep_partial("swept_peers", args, found)
    return _found(runs)


def draw(record, plt):
    return peers.draw_medians(record, plt, xlabel="nodes N")


OPTIONS = (
    *peers.OPTIONS,
    (
        ("--scenes",),
        {"default": None, "help": "comma-separated numbers of the full run's scenes, from 1"},
    ),
)

if __name__ == "__main__":
    sys.exit(_run.suite("swept_peers", run, draw, __doc__.splitlines()[0], options=OPTIONS))
