"""jaxcontact beside its peers: the same closest-segment query, timed in one process.

Scenes (docs/scenes.md): the cutting scene with the tool in the workpiece
(``x_tip = 18``) from 10^3 to 10^6 nodes, the same with the tool clear of it
(``x_tip = 20.5``), and the rough die from (10^4, 10^3) to (10^6, 10^5). On
each, ``all_to_all`` and ``bucket_sort (sized)`` (float32, jit: the bucket
sort with its ``Sizes`` measured outside the timer, its whole search, broad
phase included, inside), ``bucket_sort (sized, compact)`` (the same search
returning the found contacts only, a ``ContactList``) and every peer of ``baselines.PEERS`` that is
installed are run round-robin; ``ratio`` is a method's median over
``bucket_sort (sized)``'s. Every answer is checked against ``all_to_all``
in float64, and each kind of disagreement is its own column (missed, false, ties
at a shared vertex, wrong segment, largest gap error).

A method is skipped, with the reason in its row, where it would hold more
than ``PAIR_BUDGET`` slave-segment pairs at once (the dense NumPy plane) or
evaluate more than ``DENSE_BUDGET`` pairs per call (``all_to_all``). A method
whose first call takes longer than ``--slow`` seconds is timed by that one
call only.

    python benchmarks/peers.py [--quick] [--out DIR]
"""

from __future__ import annotations

import functools
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness import _run, answers
from benchmarks.harness.internals import measure, measure_contacts
from benchmarks.peer_codes import baselines
from jaxcontact import all_to_all
from jaxcontact.scenes import cutting_scene, rough_die_scene

# The library's bucket sort, as timed here: fixed sizes, measured outside the timer.
LIBRARY = "bucket_sort (sized)"
# The same with the compact result (a ``ContactList`` of the found contacts).
COMPACT = "bucket_sort (sized, compact)"
PAIR_BUDGET = 5e7  # NumPy (N, M, 2) float32 temporaries: about 0.4 GB each
DENSE_BUDGET = 1.2e9  # all_to_all pairs per call: a few seconds on a CPU core

FULL_SCENES = (
    *(("cutting, tool in (x_tip=18)", n, 18.0) for n in (1_000, 10_000, 81_939, 1_000_000)),
    *(("cutting, tool clear (x_tip=20.5)", n, 20.5) for n in (81_939, 1_000_000)),
    *(("rough die", n, m) for n, m in ((10**4, 10**3), (10**5, 10**4), (10**6, 10**5))),
)
QUICK_SCENES = (
    ("cutting, tool in (x_tip=18)", 10_000, 18.0),
    ("cutting, tool clear (x_tip=20.5)", 10_000, 20.5),
    ("rough die", 10**4, 10**3),
)


# Left out of --quick runs, which must finish in two minutes on 2 cores.
QUICK_SKIPS = {"jax-md cell list": "skipped in --quick: importing jax-md alone takes about 15 s"}


def build(kind, size, parameter):
    if kind == "rough die":
        return rough_die_scene(size, parameter)
    return cutting_scene(size, parameter)


def _skip_reason(name, x, start, end, radius, quick) -> str | None:
    """Why ``name`` is not run on this scene, or None."""
    if quick and name in QUICK_SKIPS:
        return QUICK_SKIPS[name]
    pairs = len(x) * len(start)
    if name == "NumPy dense" and pairs > PAIR_BUDGET:
        return f"skipped: (N, M) plane of {pairs:.0e} pairs > {PAIR_BUDGET:.0e}"
    if name.startswith("NumPy box-then-dense"):
        low = np.minimum(start, end).min(axis=0) - radius
        high = np.maximum(start, end).max(axis=0) + radius
        inside = int(np.all((x >= low) & (x <= high), axis=1).sum())
        if inside * len(start) > PAIR_BUDGET:
            return f"skipped: {inside:,} slaves in the box x {len(start):,} segments > budget"
    if name == "all_to_all" and pairs > DENSE_BUDGET:
        return f"skipped: {pairs:.0e} pairs per call > {DENSE_BUDGET:.0e}"
    return baselines.unavailable(name) if name in baselines.PEERS else None


def _methods(scene):
    """name -> (fn, args): the library's two detectors, then the peers."""
    radius = scene.radius
    sizes = measure(scene.x, scene.surface, radius=radius)
    compact_sizes = measure_contacts(scene.x, scene.surface, radius, None, sizes, slack=1.5)
    methods = {
        "all_to_all": (
            jax.jit(functools.partial(all_to_all, radius=radius)),
            (scene.x, scene.surface),
        ),
        LIBRARY: (_run.sized_contact(radius, sizes), (scene.x, scene.surface)),
        # The compact form (``Search(compact=True)``): the found contacts only,
        # in a capacity measured once outside the timer, as the other sizes.
        COMPACT: (_run.sized_contact(radius, compact_sizes), (scene.x, scene.surface)),
    }
    for name, (_, prepare) in baselines.PEERS.items():
        methods[name] = prepare
    return methods


def run_scene(kind, size, parameter, repeats, slow_s, quick=False) -> list[dict]:
    """Every method on one scene: checked, then timed round-robin; one row per method.

    ``kind`` is ``"rough die"`` (``parameter``: its segment count) or a
    cutting scene (``parameter``: the tool tip's x); ``size`` the slave count.
    """
    scene = build(kind, size, parameter)
    x = np.asarray(scene.x)
    start, end = _run.endpoints(scene.surface)
    reference = answers.reference_contact(x, scene.surface, scene.radius)
    label = f"{kind}" + (f", M={parameter:,}" if kind == "rough die" else "")
    position = "" if kind == "rough die" else f"x_tip={parameter}"
    methods = {
        name: _skip_reason(name, x, start, end, scene.radius, quick) or method
        for name, method in _methods(scene).items()
    }
    return _run.run_methods(
        methods,
        lambda result: _run.reference_fields(result, x, start, end, reference),
        repeats=repeats,
        slow_s=slow_s,
        library=LIBRARY,
        prepare_args=(x, start, end, scene.radius),
        scene=label,
        nodes=len(x),
        segments=len(start),
        position=position,
        dtype=str(x.dtype),
    )


def ratios(rows) -> str:
    """Markdown pivot: each method's median over ``bucket_sort (sized)``'s, one column per scene."""
    scenes = list(dict.fromkeys((r["scene"], r["nodes"]) for r in rows))
    header = [f"{scene.replace(' (x_tip=', ' (')}, N={nodes:,}" for scene, nodes in scenes]
    lines = ["| method | " + " | ".join(header) + " |", "|---|" + "---:|" * len(scenes)]
    for method in dict.fromkeys(r["method"] for r in rows):
        cells = []
        for scene, nodes in scenes:
            found = [
                r for r in rows if (r["scene"], r["nodes"], r["method"]) == (scene, nodes, method)
            ]
            ratio = found[0]["ratio"] if found else ""
            cells.append(f"{ratio}x" if ratio else "—")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot(rows, out) -> list[str]:
    """Run time against nodes for every method, one panel per scene kind, log axes; one look
    per method (``benchmarks.harness.style``), one legend right of the panels."""
    plt = _run.pyplot(out)
    if plt is None:
        return []
    from benchmarks.harness import style

    kinds = list(dict.fromkeys(r["scene"].split(", M=")[0] for r in rows))
    figure, panels = plt.subplots(
        1, len(kinds), figsize=(4.6 * len(kinds) + 3.4, 4.5), squeeze=False
    )
    used = {}
    for axes, kind in zip(panels[0], kinds, strict=True):
        mine = [r for r in rows if r["scene"].startswith(kind) and r["median_ms"] != ""]
        for name in dict.fromkeys(r["method"] for r in rows):  # every panel in one order
            points = [(r["nodes"], r["median_ms"]) for r in mine if r["method"] == name]
            if points:
                axes.plot(*zip(*points, strict=True), **style.style(name, used), label=name)
        axes.set(xscale="log", yscale="log", xlabel="slave nodes N", ylabel="median (ms)")
        axes.set_title(kind, fontsize=9)
        axes.grid(True, which="major", alpha=0.3)
    style.legend_outside(panels[0][-1])
    return [_run.save_figure(figure, out, "peers")]


def run(quick: bool, out: str, repeats: int | None = None, slow_s: float | None = None) -> str:
    """Runs every scene, writes CSV/markdown/PNG into ``out``; returns the markdown."""
    slow_s = slow_s or (3.0 if quick else 30.0)
    rows = []
    for kind, size, parameter in _run.progress(QUICK_SCENES if quick else FULL_SCENES, "peers"):
        count = repeats or (5 if quick else (20 if size <= 10**5 else 5))
        rows += run_scene(kind, size, parameter, count, slow_s, quick)
    pictures = plot(rows, out)
    columns = ("scene", "position", "nodes", "segments", "method", "compile_s", "median_ms")
    more = ("p10_ms", "p90_ms", "runs", "ratio", "max_gap_error", "note")
    body = [
        "Ratios (— : not run on that scene, the reason in the table below):",
        "",
        ratios(rows),
        "",
        _run.markdown(rows, (*columns, *more)),
    ]
    note = (
        "float32 inputs; medians of interleaved runs; ratio = median / bucket_sort (sized)'s"
        " median (bucket_sort (sized): the bucket sort with sizes measured outside the timer)."
    )
    text = _run.section("peers", "Peers", quick, note, body, pictures)
    _run.write(out, "peers", rows, text)
    return text


def main(argv=None) -> int:
    return _run.main(run, __doc__.splitlines()[0], argv, slow=True)
