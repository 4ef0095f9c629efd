"""This tree's public forms beside another git revision's, interleaved in one process.

For a change that must not slow anything (a refactor, a new layout), every
form a user calls is timed on the reference scenes (``docs/scenes.md``,
float32) for both trees, round-robin (``jaxcontact._timing.time_interleaved``:
compiled ahead, two warm-up runs, then ``--repeats`` rounds, every call ended
by ``block_until_ready``; each round starts one call later than the last,
so that no call always follows the same other one; median and 10th-90th
percentile). The other
revision is extracted with ``git archive`` and imported as
``jaxcontact_against``. Both trees run in the same process on the same
inputs, so load on a shared machine falls on both alike: read the ratio
column (this tree's median over the other's; above 1 is slower), not the
times across runs, and set it beside the ``itself`` column: a second,
separately jitted copy of this tree's form in the same rounds, over the
first (the spread of one program against itself, the run's noise floor).

The forms: ``all_to_all`` and ``swept`` jitted (where N x M is at most
``EXHAUSTIVE_PAIRS``), a ``Search.closest`` step
jitted (no skin: the whole bucket sort every call, the N-row and the compact
form), a step with the candidates reused (``skin = radius / 2``), and a
``Search.swept`` step. Each pair of answers is compared row for row
(``segment``, ``found`` or ``crossed``): "equal" or the count that differ;
and each pair of optimised XLA programs, names and source locations left
out: "same" says the two trees run the same program, whatever the timer
says on a noisy machine.

    python benchmarks/against.py --against 4bb0a9e --out benchmarks/results
    taskset -c 0 python benchmarks/against.py --against 4bb0a9e --out benchmarks/results/pinned
    python benchmarks/against.py --against 4bb0a9e --quick        # a smoke test
"""

from __future__ import annotations

import argparse
import pathlib
import re
import sys

import jax
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))

import jaxcontact  # noqa: E402
from benchmarks.harness._run import machine  # noqa: E402
from benchmarks.harness.revision import extracted  # noqa: E402
from jaxcontact._timing import time_interleaved  # noqa: E402
from jaxcontact.scenes import cutting_scene, rough_die_scene  # noqa: E402

SCENES = {
    "cutting 10^4": lambda: cutting_scene(10_000, 18.0, x_tip_prev=18.2),
    "cutting 81,939, tool in": lambda: cutting_scene(81_939, 18.0, x_tip_prev=18.2),
    "rough die 10^4 x 10^3": lambda: rough_die_scene(10_000, 1_000),
    "rough die 10^5 x 10^4": lambda: rough_die_scene(100_000, 10_000),
}
QUICK = ("cutting 10^4", "rough die 10^4 x 10^3")
# The exhaustive forms are timed where they take under a second or so.
EXHAUSTIVE_PAIRS = 10**8


def forms(package, scene) -> dict:
    """name -> ``(jitted, args)`` of every form of ``package`` on ``scene``."""
    radius = float(scene.radius)
    x_prev = scene.x_prev if scene.x_prev is not None else scene.x
    scene = scene._replace(surface=package.Surface(*scene.surface))
    calls = {}
    if scene.x.shape[0] * scene.surface.segments.shape[0] <= EXHAUSTIVE_PAIRS:
        calls["all_to_all"] = (
            jax.jit(lambda x, s: package.all_to_all(x, s, radius=radius)),
            (scene.x, scene.surface),
        )
        calls["swept"] = (jax.jit(package.swept), (x_prev, scene.x, scene.surface))
    searches = {
        "Search.closest": package.Search(radius=radius),
        "Search.closest compact": package.Search(radius=radius, compact=True),
        "Search.closest, candidates reused": package.Search(radius=radius, skin=radius / 2),
    }
    for name, search in searches.items():
        state = search.allocate(scene.x, scene.surface, x_prev=x_prev)
        step = jax.jit(lambda state, x, s, search=search: search.closest(state, x, s)[0])
        calls[name] = (step, (state, scene.x, scene.surface))
    swept_search = package.Search(radius=None)
    state = swept_search.allocate(scene.x, scene.surface, x_prev=x_prev)
    step = jax.jit(lambda state, p, x, s: swept_search.swept(state, p, x, s)[0])
    calls["Search.swept"] = (step, (state, x_prev, scene.x, scene.surface))
    return calls


def _rows(result, num_rows: int):
    """``(segment, flag)`` of a result, list forms spread to N rows."""
    if hasattr(result, "to_contact"):
        result = result.to_contact(num_rows)
    flag = result.found if hasattr(result, "found") else result.crossed
    return np.asarray(result.segment), np.asarray(flag)


def _program(jitted, args) -> list[str]:
    """The optimised HLO of ``jitted(*args)``, names, metadata and source tables left out."""
    text = jitted.lower(*args).compile().as_text()
    lines = []
    for line in text.splitlines():
        line = line.strip()
        if not line or re.match(r"^\d+ ", line) or line.startswith(("FileNames", "FunctionNames")):
            continue
        if line.startswith(("FileLocations", "StackFrames")):
            continue
        line = re.sub(r",?\s*metadata=\{[^}]*\}", "", line)
        line = re.sub(r"%[\w.\-]+", "%v", line)
        lines.append(re.sub(r"\b([A-Za-z_][\w\-]*?)\.\d+\b", r"\1", line))
    return lines


def same_program(new, old) -> str:
    """Whether the two trees compile a form to the same XLA program."""
    mine, theirs = _program(*new), _program(*old)
    if mine == theirs:
        return "same"
    return f"differs ({len(mine)} against {len(theirs)} lines)"


def compared(new, old, num_rows: int) -> str:
    (segment, flag), (segment_then, flag_then) = _rows(new, num_rows), _rows(old, num_rows)
    differ = int(np.sum((segment != segment_then) | (flag != flag_then)))
    return "equal" if differ == 0 else f"{differ} rows differ"


def run_scene(name: str, then, repeats: int) -> list[tuple]:
    scene = SCENES[name]()
    new, old = forms(jaxcontact, scene), forms(then, scene)
    # A second, separately jitted copy of this tree's form: the spread of one
    # program against itself, in the same rounds, is the run's noise floor.
    again = forms(jaxcontact, scene)
    calls = {}
    for form in new:
        calls[(form, "this tree")] = new[form]
        calls[(form, "against")] = old[form]
        calls[(form, "again")] = again[form]
    timings = time_interleaved(calls, repeats=repeats, rotate=True)
    rows = []
    num_rows = scene.x.shape[0]
    for form in new:
        now, before = timings[(form, "this tree")], timings[(form, "against")]
        itself = timings[(form, "again")]
        check = compared(new[form][0](*new[form][1]), old[form][0](*old[form][1]), num_rows)
        program = same_program(new[form], old[form])
        rows.append(
            (
                name,
                form,
                now.median_s * 1e3,
                before.median_s * 1e3,
                now.median_s / before.median_s,
                itself.median_s / now.median_s,
                now.compile_s,
                before.compile_s,
                check,
                program,
            )
        )
    return rows


def table(rows, revision: str) -> str:
    head = (
        f"| scene | form | this tree (ms) | {revision} (ms) | ratio | itself | compile (s) | "
        f"compile {revision} (s) | answers | XLA program |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n"
    )
    body = "".join(
        f"| {s} | {f} | {a:.3f} | {b:.3f} | {r:.2f} | {i:.2f} | {c:.2f} | {d:.2f} | {k} | {p} |\n"
        for s, f, a, b, r, i, c, d, k, p in rows
    )
    return head + body


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", required=True, help="the git revision to time beside")
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--quick", action="store_true", help="two small scenes, 5 repeats")
    parser.add_argument("--out", type=pathlib.Path, help="write against.md here")
    args = parser.parse_args(argv)
    then = extracted(args.against)
    names = QUICK if args.quick else tuple(SCENES)
    repeats = 5 if args.quick else args.repeats
    rows = []
    for name in names:
        rows += run_scene(name, then, repeats)
        print(table(rows, args.against), flush=True)
    report = (
        f"# This tree against {args.against}\n\n{machine()}\n\n"
        f"`python benchmarks/against.py --against {args.against}`\n\n" + table(rows, args.against)
    )
    print(report)
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "against.md").write_text(report)


if __name__ == "__main__":
    main()
