"""One contact-search step: fixed sizes, a reused ``Search`` state, a re-find.

Two scenes (docs/scenes.md), float32: the cutting scene at 81,939 nodes with
the tool tip at ``x = 18`` (radius 0.1, skin 0.05; 20 segments, no cells) and
the rough die at 10^5 nodes x 10^4 segments (radius 0.02, skin 0.01; cells).
On each, five programs answer the same query on the same ``x``, timed
round-robin in one process (``benchmarks.harness.timing.time_interleaved``:
each compiled ahead of the runs, its compile time reported apart; warm-up
runs; then ``--repeats`` rounds, every call ended by ``block_until_ready``;
median and 10th-90th percentile):

- (a) ``bucket_sort (sized)``: the bucket sort with ``Sizes`` measured once
  at the radius (``jaxcontact._pipeline.sizes.measure``) and reused every call
  (``jaxcontact._bucket.contact_jit``): the broad and the narrow phase every
  call, no measuring.
- (b) ``Search.closest (reused state)``: ``Search(radius, skin)``, its state
  allocated at ``x``; every call is on that same ``x``, so the skin rule
  holds and the candidates found within ``radius + skin`` are kept: the
  skin check, then the narrow phase on them.
- (c) ``Search.closest (re-find every call)``: the same search, its state
  allocated at ``x`` moved by ``(2 skin, 0)``; every call is on ``x``, so
  each call finds the candidates again inside the step. The
  state is not threaded from call to call, and the state it returns is
  checked to count one rebuild. (b)'s and (c)'s states are sized for both
  positions together (``allocate(..., at_least=...)``): one program.
- (d) ``Search.closest (skin 0)``: ``Search(radius)`` keeps no candidates;
  each call runs the whole bucket sort with the allocated sizes, as (a).
- (e) ``all_to_all``: every slave against every segment (the cutting scene
  only: on the rough die it is 10^9 pairs).
- (f) ``bucket_sort (sized as the Search)``: (a)'s whole search with (b)'s
  sizes (at ``radius + skin``, for both positions): what the larger sizes
  alone cost.
- (g) ``narrow phase on the kept candidates``: (b)'s candidates passed
  straight to the narrow phase (``jaxcontact._bucket.contact_jit``), no skin
  check and no ``cond``: (b) less (g) is what the check and the ``cond``
  cost (on a GPU, a ``cond`` reads its predicate back to the host).
- with ``--against REV``, ``Search.closest (reused state) at REV``: (b) as
  that git revision builds it (``stages.py``'s extracted copy), timed in the
  same rounds, its answer checked like the others'.

Each answer's ``segment`` and ``found`` are compared with ``all_to_all``'s on
the cutting scene and with (a)'s on the rough die (the ``check`` column), and
each overflow flag is reported.

    python benchmarks/search_step.py                 # 200 rounds
    python benchmarks/search_step.py --quick         # 20 rounds, a smoke test
    python benchmarks/search_step.py --out DIR       # also writes DIR/search_step.md
    python benchmarks/search_step.py --against REV   # and REV's reused step beside
    taskset -c 0 python benchmarks/search_step.py    # pinned to one core
"""

from __future__ import annotations

import argparse
import functools
import os
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import numpy as np

from benchmarks.harness._run import machine, sized_contact
from benchmarks.harness.internals import _bucket, measure
from benchmarks.harness.timing import time_interleaved
from jaxcontact import Contact, Search, all_to_all
from jaxcontact.scenes import cutting_scene, rough_die_scene

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from stages import against  # noqa: E402


def scenes(quick: bool):
    """(title, scene, skin, dense reference?) of each scene measured."""
    die = (10_000, 1_000) if quick else (100_000, 10_000)
    return [
        ("cutting scene x_tip=18", cutting_scene(81_939, x_tip=18.0), 0.05, True),
        (f"rough die {die[0]:,} x {die[1]:,}", rough_die_scene(*die), 0.01, False),
    ]


def what(name: str, state) -> str:
    """What one call of ``name`` does, read off its state."""
    if name == "bucket_sort (sized)":
        return "broad + narrow phase, sizes fixed (measured once, at the radius)"
    if name == "all_to_all":
        return "every slave against every segment"
    if name == "bucket_sort (sized as the Search)":
        return "broad + narrow phase, with the Search's sizes (radius + skin)"
    if name == "narrow phase on the kept candidates":
        return "narrow phase on the Search's kept candidates; no skin check, no cond"
    if state.candidates is None:
        return "no candidates kept: broad + narrow phase with the allocated sizes"
    if name.startswith("Search.closest (reused state)"):
        return "skin check; candidates kept; narrow phase on them"
    return "skin check; candidates found again; narrow phase"


def differences(result, reference) -> str:
    """Rows whose segment or found flag differ from the reference's."""
    segment = np.asarray(result.segment) != np.asarray(reference.segment)
    found = np.asarray(result.found) != np.asarray(reference.found)
    wrong = int(np.sum(segment | found))
    return f"{wrong} of {int(np.sum(np.asarray(reference.found)))} found differ"


def programs(scene, radius: float, skin: float, dense: bool, revision: str | None = None):
    """name -> (fn, args), and notes on how they were set up."""
    x, surface = scene.x, scene.surface
    sized_sizes = measure(x, surface, radius=radius)
    sized = sized_contact(radius, sized_sizes)
    search = Search(radius=radius, skin=skin)
    # Moved by twice the skin in x: the skin rule fails for every call on x.
    moved = x.at[:, 0].add(2 * skin)
    # Both states sized to hold both positions, so that (b) and (c) run one
    # program and differ only in the branch the skin check takes.
    stale = search.allocate(moved, surface, at_least=search.allocate(x, surface))
    reused = search.allocate(x, surface, at_least=stale)
    step = jax.jit(search.closest)
    plain = Search(radius=radius)
    calls = {
        "bucket_sort (sized)": (sized, (x, surface)),
        "Search.closest (reused state)": (step, (reused, x, surface)),
        "Search.closest (re-find every call)": (step, (stale, x, surface)),
        "Search.closest (skin 0)": (
            jax.jit(plain.closest),
            (plain.allocate(x, surface), x, surface),
        ),
    }
    if reused.candidates is not None:
        calls["bucket_sort (sized as the Search)"] = (
            sized_contact(radius, reused.sizes),
            (x, surface),
        )
        sizes = reused.sizes

        @jax.jit
        def narrow(x, surface, candidates):
            return _bucket.contact_jit(x, surface, radius, None, sizes=sizes, candidates=candidates)

        calls["narrow phase on the kept candidates"] = (
            narrow,
            (x, surface, reused.candidates),
        )
    if revision:
        package, _ = against(revision)
        then = package.Search(radius=radius, skin=skin)
        surface_then = package.Surface(*surface)
        state_then = then.allocate(x, surface_then)
        calls[f"Search.closest (reused state) at {revision}"] = (
            jax.jit(then.closest),
            (state_then, x, surface_then),
        )
    if dense:
        calls["all_to_all"] = (jax.jit(functools.partial(all_to_all, radius=radius)), (x, surface))
    notes = [
        f"(a) sizes at radius {radius:g}: {brief(sized_sizes)}; (b), (c) sizes at radius + skin "
        f"{radius + skin:g}, for x and x + ({2 * skin:g}, 0) together: {brief(reused.sizes)}.",
    ]
    listed = reused.candidates.listed if reused.candidates is not None else None
    if listed is not None:
        # The pairs (f) and (g) score: the kept lists (within radius + skin)
        # against lists built at the radius with the same sizes and cells.
        at_radius = _bucket.find(x, surface, np.asarray(radius, x.dtype), None, reused.sizes)
        kept_pairs = int(np.sum(np.asarray(listed.count)))
        fresh_pairs = int(np.sum(np.asarray(at_radius.listed.count)))
        notes.append(
            f"(b)'s kept lists hold {kept_pairs:,} (slave, segment) pairs; the same sizes' "
            f"lists built at the radius, {fresh_pairs:,} ({kept_pairs / fresh_pairs:.2f}x)."
        )
    if reused.candidates is not None:
        notes.append(
            f"(c) re-finds by a stale state: allocated at x + ({2 * skin:g}, 0), called on x "
            f"(moved {2 * skin:g} > skin {skin:g}), not threaded; the same program as (b)."
        )
    return calls, notes


def brief(sizes) -> str:
    """The capacities that matter on this scene, in a few words."""
    blocks = -(-sizes.num_slaves // sizes.block_size)
    text = f"{sizes.block_capacity} of {blocks} blocks of {sizes.block_size} slaves kept"
    if sizes.use_cells:
        return text + f", {sizes.grid_shape} cells of at most {sizes.cell_capacity} segments"
    return text + ", each kept slave against every segment (no cells)"


def table(calls, timings, results, reference_name) -> list[str]:
    base = timings["bucket_sort (sized)"].median_s * 1e3
    reference = results[reference_name]
    reference = reference if isinstance(reference, Contact) else reference[0]
    lines = [
        "| method | what a call does | median ms | p10-p90 ms | sized / this "
        f"| compile s | check against {reference_name} |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for name, (_, args) in calls.items():
        timing = timings[name]
        result = results[name]
        contact, state = (result, None) if isinstance(result, Contact) else result
        check = differences(contact, reference) + f"; overflow {bool(contact.overflow)}"
        if state is not None:
            check += f"; rebuilds {int(state.rebuilds)}"
        ms = timing.median_s * 1e3
        lines.append(
            f"| {name} | {what(name, args[0])} | {ms:.3f} "
            f"| {timing.p10_s * 1e3:.3f}-{timing.p90_s * 1e3:.3f} | {base / ms:.2f}x "
            f"| {timing.compile_s:.2f} | {check} |"
        )
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 rounds: a smoke test")
    parser.add_argument("--repeats", type=int, default=None, help="timed rounds (200)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed runs of each first")
    parser.add_argument("--out", default=None, help="folder: write search_step.md there")
    parser.add_argument("--against", help="git revision whose reused step is timed beside")
    args = parser.parse_args(argv)
    repeats = args.repeats or (20 if args.quick else 200)

    command = "python benchmarks/search_step.py" + " --quick" * args.quick
    if args.repeats:
        command += f" --repeats {args.repeats}"
    if args.warmup != 5:
        command += f" --warmup {args.warmup}"
    if args.against:
        command += f" --against {args.against}"
    lines = [
        "## Search step",
        "",
        f"`{command}`; {machine()}; float32; median of {repeats} interleaved rounds after "
        f"{args.warmup} warm-up runs, compile apart. Ratio: the sized bucket sort's median "
        "over the method's.",
        "",
    ]
    for title, scene, skin, dense in scenes(args.quick):
        radius = float(scene.radius)
        calls, notes = programs(scene, radius, skin, dense, args.against)
        timings = time_interleaved(calls, repeats=repeats, warmup=args.warmup)
        results = {name: jax.block_until_ready(fn(*a)) for name, (fn, a) in calls.items()}
        nodes, segments = scene.x.shape[0], scene.surface.segments.shape[0]
        lines += [
            f"### {title}: {nodes:,} nodes x {segments:,} segments, radius {radius:g}, "
            f"skin {skin:g}",
            "",
            *table(calls, timings, results, "all_to_all" if dense else "bucket_sort (sized)"),
            "",
            *[f"- {note}" for note in notes],
            "",
        ]
    text = "\n".join(lines)
    print(text)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        path = os.path.join(args.out, "search_step.md")
        with open(path, "w") as stream:
            stream.write(text)
        print(f"wrote {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
