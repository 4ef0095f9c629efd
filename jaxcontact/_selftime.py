"""``jaxcontact bench``: times jaxcontact's own forms on the reference scenes.

``all_to_all``, ``bucket_sort``, one jitted ``Search.closest`` step (its
state allocated outside the timer) and ``swept``, on the scenes of
``jaxcontact.scenes``, in float32, each timed by ``time_interleaved``
(compiled apart, then round-robin runs). It writes ``bench.csv`` and, with
matplotlib installed, ``bench.png`` into ``--out``. It leaves the process as
it finds it (no allocator or thread settings) and times no other library:
the comparisons with peers are the repository's ``benchmarks/`` folder
(``python benchmarks/peers.py``).
"""

from __future__ import annotations

import argparse
import csv
import functools
import os

import jax

from jaxcontact import Search, all_to_all, bucket_sort, swept
from jaxcontact._timing import pinned_note, time_interleaved
from jaxcontact.scenes import cutting_scene, paper_scene, rough_die_scene

COLUMNS = ("scene", "nodes", "segments", "form", "compile_s", "median_ms", "p10_ms", "p90_ms")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``jaxcontact bench``, on ``parser`` (the command line's subparser)."""
    parser.add_argument("--quick", action="store_true", help="small scenes: well under a minute")
    parser.add_argument("--out", default="jaxcontact-bench", help="folder for the CSV and PNG")
    parser.add_argument("--repeats", type=_positive, default=10, help="timed runs per form")


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1; got {value}")
    return value


def scenes(quick: bool) -> dict:
    """Name -> ``Scene``: the paper's Test 1, the cutting scene and the rough die."""
    if quick:
        return {
            "paper, n=60": paper_scene(60),
            "cutting": cutting_scene(5_000, 18.0, x_tip_prev=18.2),
            "rough die": rough_die_scene(10_000, 1_000),
        }
    return {
        "paper, n=250": paper_scene(250),
        "cutting": cutting_scene(81_939, 18.0, x_tip_prev=18.2),
        "rough die": rough_die_scene(100_000, 10_000),
    }


def forms(scene) -> dict:
    """Form name -> ``(fn, args)`` on ``scene``: the calls ``time_interleaved`` takes."""
    x, surface, radius = scene.x, scene.surface, scene.radius
    search = Search(radius=radius)
    state = search.allocate(x, surface)
    return {
        "all_to_all": (jax.jit(functools.partial(all_to_all, radius=radius)), (x, surface)),
        "bucket_sort": (functools.partial(bucket_sort, radius=radius), (x, surface)),
        "Search.closest (jit)": (jax.jit(search.closest), (state, x, surface)),
        "swept": (jax.jit(swept), (scene.x_prev, x, surface)),
    }


def run(args: argparse.Namespace) -> int:
    """Times every form on every scene; prints a table, writes CSV (and PNG); returns 0."""
    rows = []
    for name, scene in scenes(args.quick).items():
        timings = time_interleaved(forms(scene), repeats=args.repeats)
        for form, timing in timings.items():
            rows.append(
                {
                    "scene": name,
                    "nodes": scene.x.shape[0],
                    "segments": scene.surface.segments.shape[0],
                    "form": form,
                    "compile_s": round(timing.compile_s, 3),
                    "median_ms": round(timing.median_s * 1e3, 3),
                    "p10_ms": round(timing.p10_s * 1e3, 3),
                    "p90_ms": round(timing.p90_s * 1e3, 3),
                }
            )
            print(
                f"{name:<14} {rows[-1]['nodes']:>8,} nodes  {form:<22} "
                f"compile {timing.compile_s:7.3f} s  median {timing.median_s * 1e3:9.3f} ms",
                flush=True,
            )
    print(f"float32, {args.repeats} runs each; jax {jax.__version__}; {pinned_note()}")
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "bench.csv")
    with open(path, "w", newline="") as stream:
        writer = csv.DictWriter(stream, COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")
    try:
        import matplotlib
    except ImportError:
        print('PNG skipped: it needs matplotlib (pip install "jaxcontact[bench]").')
        return 0
    matplotlib.use("Agg")  # headless: no display needed
    print(f"wrote {plot(rows, args.out)}")
    return 0


def plot(rows: list[dict], out: str) -> str:
    """Median run time of each form, one group of bars per scene; the PNG's path."""
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(row["scene"] for row in rows))
    kinds = list(dict.fromkeys(row["form"] for row in rows))
    figure, axes = plt.subplots(figsize=(8, 4.5), layout="constrained")
    width = 0.8 / len(kinds)
    for k, form in enumerate(kinds):
        medians = {row["scene"]: row["median_ms"] for row in rows if row["form"] == form}
        spots = [i + (k - (len(kinds) - 1) / 2) * width for i in range(len(names))]
        axes.bar(spots, [medians.get(n, 0.0) for n in names], width, label=form)
    nodes = {row["scene"]: row["nodes"] for row in rows}
    axes.set_xticks(range(len(names)), [f"{name}\n{nodes[name]:,} nodes" for name in names])
    axes.set(yscale="log", ylabel="median run time (ms)", title="jaxcontact's forms, float32")
    axes.legend(fontsize=8)
    path = os.path.join(out, "bench.png")
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return path
