"""This tree's public forms beside another git revision's, interleaved in one process.

    python benchmarks/against.py --against 4bb0a9e
    taskset -c 0 python benchmarks/against.py --against 4bb0a9e --out benchmarks/results/pinned
    python benchmarks/against.py --against 4bb0a9e --quick --out /tmp/against   # a smoke test

For a change that must not slow anything (a refactor, a new layout), every form a user calls
is timed on the reference scenes (``docs/scenes.md``, float32, ``jax_enable_x64`` off) for
both trees, round-robin (``jaxcontact._timing.time_interleaved``: compiled ahead, two warm-up
runs, then ``--repeats`` rounds, 20 by default, every call ended by ``block_until_ready``;
each round starts one call later than the last, so that no call always follows the same other
one; median and 10th-90th percentile). The other revision (``--against``, required) is
extracted with ``git archive`` and imported as ``jaxcontact_against``
(``benchmarks.harness.revision``). Both trees run in the same process on the same inputs, so
load on a shared machine falls on both alike: read the ratio (this tree's median over the
other's; above 1 is slower), not the times across runs, and set it beside ``itself``: a
second, separately jitted copy of this tree's form in the same rounds, over the first (the
spread of one program against itself, the run's noise floor).

The forms: ``all_to_all`` and ``swept`` jitted (where N x M is at most ``EXHAUSTIVE_PAIRS``),
a ``Search.closest`` step jitted (no skin: the whole bucket sort every call, the dense and the
compact form), a step with the candidates reused (``skin = radius / 2``), and a
``Search.swept`` step. Each pair of answers is compared row for row (``segment``, ``found``
or ``crossed``): "equal" or the count that differ; and each pair of optimised XLA programs,
names and source locations left out: "same" says the two trees run the same program,
whatever the timer says on a noisy machine.

The figure: per scene and form, the ratio, beside a grey bar of 1 +- |itself - 1|: a ratio
inside its bar is within what the same program measures against itself.
"""

from __future__ import annotations

import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import numpy as np

import jaxcontact
from benchmarks.harness import _run, report
from benchmarks.harness.revision import extracted
from benchmarks.harness.timing import compiled_call, time_interleaved
from jaxcontact.scenes import cutting_scene, rough_die_scene

SCENES = {
    "cutting 10^4": lambda: cutting_scene(10_000, 18.0, x_tip_prev=18.2),
    "cutting 81,939, tool in": lambda: cutting_scene(81_939, 18.0, x_tip_prev=18.2),
    "rough die 10^4 x 10^3": lambda: rough_die_scene(10_000, 1_000),
    "rough die 10^5 x 10^4": lambda: rough_die_scene(100_000, 10_000),
}
QUICK = ("cutting 10^4", "rough die 10^4 x 10^3")
# The exhaustive forms are timed where they take under a second or so.
EXHAUSTIVE_PAIRS = 10**8
# The forms, named as the benchmark figures name them (``benchmarks.harness.style``).
ALL_TO_ALL = "all_to_all"
SWEPT = "swept"
WHOLE = "Search.closest (whole search)"
WHOLE_COMPACT = "Search.closest (compact, whole search)"
REUSED = "Search.closest (reused state)"
SEARCH_SWEPT = "Search.swept"
FORMS = (ALL_TO_ALL, SWEPT, WHOLE, WHOLE_COMPACT, REUSED, SEARCH_SWEPT)
# Who runs each form in one round: this tree, the other revision, this tree's second copy.
THIS, OTHER, AGAIN = "this tree", "other", "again"


def forms(package, scene, names=None) -> dict:
    """name -> ``(jitted, args)`` of the forms ``names`` (default ``FORMS``) of ``package`` on
    ``scene``."""
    names = FORMS if names is None else names
    radius = float(scene.radius)
    x_prev = scene.x_prev if scene.x_prev is not None else scene.x
    scene = scene._replace(surface=package.Surface(*scene.surface))
    calls = {}
    if scene.x.shape[0] * scene.surface.segments.shape[0] <= EXHAUSTIVE_PAIRS:
        calls[ALL_TO_ALL] = (
            jax.jit(lambda x, s: package.all_to_all(x, s, radius=radius)),
            (scene.x, scene.surface),
        )
        calls[SWEPT] = (jax.jit(package.swept), (x_prev, scene.x, scene.surface))
    searches = {
        WHOLE: package.Search(radius=radius),
        WHOLE_COMPACT: package.Search(radius=radius, compact=True),
        REUSED: package.Search(radius=radius, skin=radius / 2),
    }
    for name, search in searches.items():
        if name in names:
            state = search.allocate(scene.x, scene.surface, x_prev=x_prev)
            step = jax.jit(lambda state, x, s, search=search: search.closest(state, x, s)[0])
            calls[name] = (step, (state, scene.x, scene.surface))
    if SEARCH_SWEPT in names:
        swept_search = package.Search(radius=None)
        state = swept_search.allocate(scene.x, scene.surface, x_prev=x_prev)
        step = jax.jit(lambda state, p, x, s: swept_search.swept(state, p, x, s)[0])
        calls[SEARCH_SWEPT] = (step, (state, x_prev, scene.x, scene.surface))
    return {name: call for name, call in calls.items() if name in names}


def _rows(result, num_rows: int):
    """``(segment, flag)`` of a result, list forms spread to N rows."""
    if hasattr(result, "to_contact"):
        result = result.to_contact(num_rows)
    flag = result.found if hasattr(result, "found") else result.crossed
    return np.asarray(result.segment), np.asarray(flag)


def program_lines(text: str) -> list[str]:
    """An optimised HLO ``text`` with names, metadata and source tables left out: two
    trees' programs compare equal when they run the same computation."""
    lines = []
    for line in text.splitlines():
        line = line.strip()
        if not line or re.match(r"^\d+ ", line) or line.startswith(("FileNames", "FunctionNames")):
            continue
        if line.startswith(("FileLocations", "StackFrames")):
            continue
        line = re.sub(r",?\s*metadata=\{[^}]*\}", "", line)
        if line.endswith("{"):  # a computation's head: its parameters' names left out
            line = re.sub(r"([(,]\s*)[\w.\-]+: ", r"\1", line)
        line = re.sub(r"%[\w.\-]+", "%v", line)
        lines.append(re.sub(r"\b([A-Za-z_][\w\-]*?)\.\d+\b", r"\1", line))
    return lines


def same_program(mine: str, theirs: str) -> str:
    """Whether two optimised HLO texts are the same XLA program."""
    mine, theirs = program_lines(mine), program_lines(theirs)
    if mine == theirs:
        return "same"
    return f"differs ({len(mine)} against {len(theirs)} lines)"


def compared(new, old, num_rows: int) -> str:
    """Two answers row for row: "equal", or how many rows differ."""
    (segment, flag), (segment_then, flag_then) = _rows(new, num_rows), _rows(old, num_rows)
    differ = int(np.sum((segment != segment_then) | (flag != flag_then)))
    return "equal" if differ == 0 else f"{differ} rows differ"


def run_scene(name: str, then, repeats: int, names=None) -> list[dict]:
    """One scene: each form of this tree, of ``then`` (the other revision's package) and
    this tree's second copy, compiled once (that compile timed and its text kept), then timed
    in the same rotating rounds; one row per form."""
    scene = SCENES[name]()
    # The second copy, separately jitted: the spread of one program against itself.
    trees = {THIS: jaxcontact, OTHER: then, AGAIN: jaxcontact}
    built = {who: forms(package, scene, names) for who, package in trees.items()}
    calls, compile_s, texts = {}, {}, {}
    for form in built[THIS]:
        for who in trees:  # a form's three copies side by side in every round
            compiled, compile_s[form, who] = compiled_call(*built[who][form])
            texts[form, who] = compiled.as_text()
            calls[form, who] = (compiled, built[who][form][1])
    timings = time_interleaved(calls, repeats=repeats, rotate=True)
    rows = []
    for form in built[THIS]:
        now, before, itself = (timings[form, who] for who in (THIS, OTHER, AGAIN))
        answers = [calls[form, who][0](*calls[form, who][1]) for who in (THIS, OTHER)]
        rows.append(
            {
                "scene": name,
                "form": form,
                "this_ms": now.median_s * 1e3,
                "other_ms": before.median_s * 1e3,
                "this_p10_ms": now.p10_s * 1e3,
                "this_p90_ms": now.p90_s * 1e3,
                "other_p10_ms": before.p10_s * 1e3,
                "other_p90_ms": before.p90_s * 1e3,
                "ratio": now.median_s / before.median_s,
                "itself": itself.median_s / now.median_s,
                "compile_s": compile_s[form, THIS],
                "other_compile_s": compile_s[form, OTHER],
                "answers": compared(*answers, scene.x.shape[0]),
                "program": same_program(texts[form, THIS], texts[form, OTHER]),
            }
        )
    return rows


def table(rows, revision: str) -> dict:
    columns = [
        "scene",
        "form",
        "this tree ms",
        f"{revision} ms",
        "ratio",
        "itself",
        "compile s",
        f"compile {revision} s",
        "answers",
        "XLA program",
    ]
    keys = ["scene", "form", "this_ms", "other_ms", "ratio", "itself", "compile_s"]
    keys += ["other_compile_s", "answers", "program"]
    return report.table(
        columns,
        [[row[key] for key in keys] for row in rows],
        title=f"This tree against {revision}",
        note=f"ratio: this tree's median over {revision}'s (above 1: slower). itself: a second "
        "copy of this tree's form over the first, in the same rounds (the run's noise). "
        "answers: segment and found (or crossed), row for row. XLA program: the two optimised "
        "programs, names and source locations left out.",
    )


def run(args) -> dict:
    then = extracted(args.against)
    names = QUICK if args.quick else tuple(SCENES)
    repeats = args.repeats or (5 if args.quick else 20)
    x64 = jax.config.jax_enable_x64
    # float32 scenes as a float32 simulation runs them: x64 off, its programs.
    jax.config.update("jax_enable_x64", False)
    rows = []
    try:
        for name in names:
            rows += run_scene(name, then, repeats)
            print(f"{name}: done", file=sys.stderr, flush=True)
    finally:
        jax.config.update("jax_enable_x64", x64)
    return {
        "title": f"This tree against {args.against}, interleaved",
        "tables": [table(rows, args.against)],
        "data": {"rows": rows, "revision": args.against, "repeats": repeats},
        "notes": [
            f"float32; median of {repeats} rotating rounds after 2 warm-up runs, compile apart."
        ],
    }


def draw(record, plt):
    """Per scene and form: the ratio (a marker in the form's look), beside a grey bar of
    1 +- |itself - 1| (the same program against itself); a line at 1."""
    from benchmarks.harness import style

    rows, revision = record["data"]["rows"], record["data"]["revision"]
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    names = list(dict.fromkeys(r["form"] for r in rows))
    figure, axes = plt.subplots(figsize=(11, 4.6))
    width = 0.8 / len(names)
    used = {}
    for index, form in enumerate(names):
        looks = {**style.style(form, used), "linestyle": "none", "markersize": 7}
        mine = [r for r in rows if r["form"] == form]
        at = [scenes.index(r["scene"]) - 0.4 + width * (index + 0.5) for r in mine]
        spread = [abs(r["itself"] - 1) for r in mine]
        axes.bar(at, [2 * s for s in spread], width * 0.7, [1 - s for s in spread], color="#d9d9d9")
        axes.plot(at, [r["ratio"] for r in mine], **looks, label=form)
    axes.axhline(1.0, color="#525252", linewidth=0.8)
    axes.set_xticks(range(len(scenes)), [re.sub(r"10\^(\d+)", r"$10^{\1}$", s) for s in scenes])
    for between in range(1, len(scenes)):
        axes.axvline(between - 0.5, color="#dddddd", linewidth=0.8)
    axes.set_xlim(-0.5, len(scenes) - 0.5)
    axes.set(
        ylabel=f"this tree's median / {revision}'s",
        title=f"This tree against {revision} (grey: this tree against itself, the noise)",
    )
    axes.grid(True, axis="y", alpha=0.3)
    style.legend_outside(axes, "right")
    return figure


if __name__ == "__main__":
    options = ((("--against",), {"required": True, "help": "the git revision to time beside"}),)
    sys.exit(_run.suite("against", run, draw, __doc__.splitlines()[0], options=options))
