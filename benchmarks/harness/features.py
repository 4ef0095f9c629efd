"""Slip tracking, Coulomb friction and smooth normals: their cost per step beside the plain search.

Float32, every variant one jitted step ``step(carry, x, surface, pairing)``
that returns what a simulation needs (the contact and the forces on the
slaves and the master's nodes; the slip where it is tracked) and the carry
for the next step (the ``SearchState``, and the ``Friction`` for Coulomb).
Each step is compiled ahead of the runs (its compile time reported apart);
then it is called with the carry it returned last time, on positions that
alternate between two frames ``x0, x1, x0, ...``, so every step has slip to
compute. Two warm-up steps, then the median and the 10th-90th percentile of
``--repeats`` rounds, the five variants of one scene run round-robin in this
one process (``benchmarks.harness.timing.time_interleaved``), every call ended
by ``block_until_ready``:

1. **plain**: ``Search(radius).closest``, then ``forces.penalty`` (the normal
   penalty on the slaves and its reaction on the master's nodes);
2. **track**: ``Search(track=True)`` (the slip since the last step), then
   ``penalty``;
3. **track + Coulomb**: ``Search(track=True)``, then ``forces.coulomb`` (the
   penalty and the return-mapped friction force, the ``Friction`` carried);
4. **smooth normals**: ``Search(normals="smooth")``, then ``penalty``;
5. **all**: ``Search(track=True, normals="smooth")``, then ``coulomb``.

Scenes, each with the dense ``Contact`` and the compact ``ContactList``
(``compact=True``; the slip stays dense, f[N]): the cutting scene
(``scenes.cutting_scene``, tool tip at ``x = 18``, 1 mm into the workpiece,
radius 0.1, as ``benchmarks/bodies.py`` part 3) at 10^4 and 81,939 nodes,
the frames the grid and the grid moved by ``+0.01`` in x (the cutting
direction: the nodes slide along the tool's flank and into its rake face);
and the curling chip (``scenes.curling_chip(10_000)``, every node a slave,
``Pairs(slave_node, self_contact=True)``, radius ``2 h``), the
frames the chip and the chip moved by ``0.75 h`` in x (its nodes off the
workpiece's rectangle move, the master moving with them: the chip's tip
slides along the machined surface). The states are allocated for both frames
(``allocate(x1, at_least=allocate(x0))`` of the plain search, then
``init(x0, sizes=...)`` of each variant); no skin (the whole bucket sort
every step, as ``bodies.py``). Stiffness ``1e3``, tangent stiffness ``1e3``,
``mu = 0.3``.

Checked, on two fresh steps (``x0`` then ``x1``) of every variant: the
contact's segments and found rows equal the plain variant's (smooth normals
change the normal, the gap and with it ``active`` only: the largest gap
change and the rows whose ``active`` changed are given), the compact form's
equal the dense form's; the slip and the anchors are finite, and on the rows
that stayed on one segment's interior the slip equals the slave's move
relative to the material point, along the segment, and on the rows that
changed segment the path length along the outline from the material point
(both computed here on the host, float64, the walk unlimited); the forces on
the slaves and on the master's nodes sum to zero (relative to the sum of
their magnitudes); Coulomb's normal part equals the penalty's, its
tangential part is within ``mu f_n``, its dissipation is ``>= 0``; no
overflow. A second table times the pieces the variants add, each
jitted alone on the plain variant's contact: ``to_contact`` (the compact
form spread over N rows, as ``history_of`` and ``track`` do),
``history_of``, ``track`` (the vertex links, the walk, and the arc-coordinate
fallback under a ``cond``), ``vertex_neighbours`` (the sort both ``track`` and
the smoothing do), ``chains`` (the fallback's outline walk, run only where a
slave jumped past the walk), ``smoothed``, ``penalty`` and ``coulomb``,
beside a jitted call that returns one row of ``x`` (the floor of one call: a
piece alone pays it, inside the step it does not).

    python benchmarks/friction.py                 # full sizes, about 3 minutes on 2 cores
    taskset -c 0 python benchmarks/friction.py    # pinned to one core
    python benchmarks/friction.py --quick         # 2,000 nodes, one form each, a smoke test
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness._run import machine
from benchmarks.harness.internals import _inputs, _normals, _outline, _track
from benchmarks.harness.timing import time_interleaved
from jaxcontact import Contact, ContactList, Pairs, Search
from jaxcontact.forces import Friction, coulomb, penalty
from jaxcontact.scenes import curling_chip, cutting_scene

STIFFNESS = 1e3
TANGENT_STIFFNESS = 1e3
MU = 0.3
CUT_SHIFT = 0.01  # the cutting scene's second frame: the grid moved this far in x
CHIP_SHIFT = 0.75  # the curling chip's: the chip moved this many node spacings h in x
TIP = 18.0  # the cutting tool's tip, as bodies.py part 3
FORCE_TOLERANCE = 1e-5  # |sum of the forces| over the sum of their magnitudes
SLIP_TOLERANCE = 1e-5  # |slip - the host's| on rows that stayed on one segment's interior

VARIANTS = {  # name -> (Search keywords, forces)
    "plain: closest + penalty": ({}, "penalty"),
    "track: closest(track) + penalty": ({"track": True}, "penalty"),
    "track + Coulomb": ({"track": True}, "coulomb"),
    'smooth normals: closest(normals="smooth") + penalty': ({"normals": "smooth"}, "penalty"),
    "all: track + smooth + Coulomb": ({"track": True, "normals": "smooth"}, "coulomb"),
}
PLAIN = next(iter(VARIANTS))


# -- the steps ---------------------------------------------------------------------


def make_step(search: Search, forces: str, num_slaves: int):
    """``step(carry, x, surface, pairing) -> (carry, out)``: one simulation step.

    ``carry`` is the state (and the ``Friction`` for Coulomb); ``out`` the
    contact, the ``Forces`` and, with tracking, the ``Slip``.
    """

    def step(carry, x, surface, pairing):
        state, friction = carry if forces == "coulomb" else (carry, None)
        found = search.closest(state, x, surface, **pairing)
        contact, state = found[:2]
        slip = found[2] if search.track else None
        if forces == "coulomb":
            pushed, friction = coulomb(
                contact,
                slip,
                friction,
                surface,
                stiffness=STIFFNESS,
                tangent_stiffness=TANGENT_STIFFNESS,
                mu=MU,
            )
            return (state, friction), (contact, pushed, slip, friction)
        pushed = penalty(contact, surface, STIFFNESS, num_slaves=num_slaves)
        return state, (contact, pushed, slip)

    return step


class Carried:
    """A compiled step called with the carry it returned last, on the frames in turn."""

    def __init__(self, compiled, carry, frames, pairing):
        self.compiled, self.carry, self.frames, self.pairing = compiled, carry, frames, pairing
        self.calls = 0

    def __call__(self):
        x, surface = self.frames[self.calls % len(self.frames)]
        self.calls += 1
        self.carry, out = self.compiled(self.carry, x, surface, self.pairing)
        return self.carry, out


# -- checks ----------------------------------------------------------------------


def dense(contact, num_rows: int) -> Contact:
    return contact.to_contact(num_rows) if isinstance(contact, ContactList) else contact


def host(tree):
    return jax.tree.map(np.asarray, tree)


def force_balance(pushed) -> float:
    """|sum on slaves + sum on master| over the sum of the forces' magnitudes."""
    on_slaves = np.asarray(pushed.on_slaves, np.float64)
    on_master = np.asarray(pushed.on_master, np.float64)
    total = np.abs(on_slaves.sum(0) + on_master.sum(0)).max()
    scale = np.abs(on_slaves).sum() + np.abs(on_master).sum()
    return float(total / scale) if scale > 0 else 0.0


def expected_slip(first: Contact, now: Contact, frames, segments: np.ndarray):
    """Host slip on the rows found on one segment's interior at both steps whose
    segment's two nodes moved alike: ``(rows, slip)``, the slave's move
    relative to the material point, along the segment now."""
    (x0, s0), (x1, s1) = frames
    x0, x1 = np.asarray(x0, np.float64), np.asarray(x1, np.float64)
    n0, n1 = np.asarray(s0.nodes, np.float64), np.asarray(s1.nodes, np.float64)
    segment = np.asarray(now.segment)
    rows = (
        np.asarray(first.found)
        & np.asarray(now.found)
        & (np.asarray(first.segment) == segment)
        & (np.asarray(first.vertex) < 0)
        & (np.asarray(now.vertex) < 0)
    )
    k = np.maximum(segment, 0)
    a, b = segments[k, 0], segments[k, 1]
    move_a, move_b = n1[a] - n0[a], n1[b] - n0[b]
    rows &= np.all(move_a == move_b, axis=-1)
    tangent = n1[b] - n1[a]
    tangent /= np.linalg.norm(tangent, axis=-1, keepdims=True)
    relative = (x1 - x0) - move_a
    return rows, np.sum(relative * tangent, axis=-1)


def walked_slip(first: Contact, now: Contact, surface):
    """Host slip on the rows found at both steps on different segments of one
    outline: ``(rows, slip)``, the path length along the current outline from
    the material point to the point now, by the segments' links (end node to
    start node), the shorter way, in float64 and with no limit on the walk."""
    segments = np.asarray(surface.segments)
    nodes = np.asarray(surface.nodes, np.float64)
    length = np.linalg.norm(nodes[segments[:, 1]] - nodes[segments[:, 0]], axis=-1)
    after, before = np.full(len(segments), -1), np.full(len(segments), -1)
    starting, ending = {}, {}
    for k, (a, b) in enumerate(segments.tolist()):
        starting.setdefault(a, k)
        ending.setdefault(b, k)
    for k, (a, b) in enumerate(segments.tolist()):
        after[k], before[k] = starting.get(b, -1), ending.get(a, -1)
    was, now_segment = np.asarray(first.segment), np.asarray(now.segment)
    rows = np.asarray(first.found) & np.asarray(now.found) & (was != now_segment)
    wanted = np.full(len(was), np.nan)
    for i in np.flatnonzero(rows):
        k0, k1 = int(was[i]), int(now_segment[i])
        xi0, xi1 = float(first.xi[i]), float(now.xi[i])
        ways = []
        for links, sign, covered, rest in (
            (after, 1.0, (1 - xi0) * length[k0], xi1),
            (before, -1.0, xi0 * length[k0], 1 - xi1),
        ):
            k = links[k0]
            while k >= 0 and k != k0:
                if k == k1:
                    ways.append(sign * (covered + rest * length[k1]))
                    break
                covered, k = covered + length[k], links[k]
        if ways:
            wanted[i] = min(ways, key=abs)
    return rows & np.isfinite(wanted), wanted


def checks(name, out, plain, dense_plain, first, frames, surface, num_rows, compact):
    """Words on one variant's second step ``out`` against the plain variant's."""
    contact, pushed, slip = dense(out[0], num_rows), out[1], out[2]
    contact, plain = host(contact), host(plain)
    words = []
    same = np.array_equal(contact.segment, plain.segment) and np.array_equal(
        contact.found, plain.found
    )
    words.append(f"segments = plain: {same}")
    if compact and dense_plain is not None:
        dense_plain = host(dense_plain)
        same_dense = np.array_equal(contact.segment, dense_plain.segment) and np.array_equal(
            contact.found, dense_plain.found
        )
        words.append(f"= dense form: {same_dense}")
    if not np.array_equal(contact.gap, plain.gap):
        both = contact.found & plain.found
        worst = np.abs(contact.gap.astype(np.float64) - plain.gap)[both].max(initial=0.0)
        changed = int(np.sum(contact.active != plain.active))
        words.append(f"gap changed by up to {worst:.1e}, active changed on {changed} rows")
    words.append(f"found {int(contact.found.sum())}, active {int(contact.active.sum())}")
    if slip is not None:
        slip = host(slip)
        finite = bool(np.isfinite(slip.slip).all() and np.isfinite(slip.anchor).all())
        first_contact = host(dense(first[0], num_rows))
        moved = int(
            np.sum(contact.found & first_contact.found & (contact.segment != first_contact.segment))
        )
        rows, wanted = expected_slip(first_contact, contact, frames, np.asarray(surface.segments))
        error = np.abs(slip.slip.astype(np.float64) - wanted)[rows].max(initial=0.0)
        walked, along = walked_slip(first_contact, contact, surface)
        walk_error = np.abs(slip.slip.astype(np.float64) - along)[walked].max(initial=0.0)
        words.append(
            f"slip finite: {finite}, persisted {int(slip.persisted.sum())}, "
            f"largest slip {np.abs(slip.slip).max(initial=0):.2e}; against the host: "
            f"{int(rows.sum())} rows on one segment, max error {error:.1e}, "
            f"{int(walked.sum())} of the {moved} rows that changed segment (walked on the "
            f"host), max error {walk_error:.1e}"
            + " (over tolerance!)"
            * bool(max(error, walk_error) > SLIP_TOLERANCE)
        )
    balance = force_balance(pushed)
    words.append(
        f"forces sum {balance:.1e} of their magnitude"
        + " (over tolerance!)" * bool(balance > FORCE_TOLERANCE)
    )
    if len(out) == 4:  # Coulomb: compare its normal part with the penalty's
        friction = host(out[3])
        reference = host(penalty(out[0], surface, STIFFNESS, num_slaves=num_rows))
        f = np.asarray(pushed.on_slaves, np.float64)
        normal = np.asarray(contact.normal, np.float64)
        along = np.sum(f * normal, axis=-1)
        want = np.sum(np.asarray(reference.on_slaves, np.float64) * normal, axis=-1)
        scale = max(np.abs(want).max(initial=0.0), 1e-30)
        tangential = np.abs(normal[:, 0] * f[:, 1] - normal[:, 1] * f[:, 0])
        over = int(np.sum(tangential > MU * np.maximum(along, 0) * (1 + 1e-5) + 1e-6 * scale))
        words.append(
            f"normal part = penalty's to {np.abs(along - want).max(initial=0) / scale:.1e}; "
            f"stuck {int(friction.stuck.sum())}, sliding "
            f"{int(np.sum(contact.active & ~friction.stuck))}; tangential over mu f_n on {over}; "
            f"min dissipated {friction.dissipated.min(initial=0):.1e}"
        )
    words.append(f"overflow {bool(contact.overflow)}")
    return "; ".join(words)


# -- one scene -------------------------------------------------------------------


def scene_part(title, frames, radius, compact, pairing, repeats, warmup, contacts, notes):
    """Times the five variants of one scene round-robin; returns the rows and the parts' inputs."""
    (x0, surface0), (x1, surface1) = frames
    num_rows = x0.shape[0]
    # One allocation for both frames; each variant starts its own state with those sizes.
    start = time.perf_counter()
    sizing = Search(radius=radius, compact=compact)
    allocated = sizing.allocate(x0, surface0, **pairing)
    sizes = sizing.allocate(x1, surface1, at_least=allocated, **pairing).sizes
    allocate_s = time.perf_counter() - start
    calls, compiles, steps, fresh = {}, {}, {}, {}
    for name, (keywords, forces) in VARIANTS.items():
        search = Search(radius=radius, compact=compact, **keywords)
        state = search.init(x0, surface0, sizes=sizes)
        carry = (state, Friction.zeros(num_rows, x0.dtype)) if forces == "coulomb" else state
        step = jax.jit(make_step(search, forces, num_rows))
        start = time.perf_counter()
        compiled = step.lower(carry, x0, surface0, pairing).compile()
        compiles[name] = time.perf_counter() - start
        steps[name], fresh[name] = compiled, carry
        calls[name] = (Carried(compiled, carry, frames, pairing), ())
    timings = time_interleaved(calls, repeats=repeats, warmup=warmup)

    # Two fresh steps of each: x0 (nothing persists), then x1 (slip).
    results = {}
    for name, compiled in steps.items():
        carry, first = compiled(fresh[name], x0, surface0, pairing)
        _, second = compiled(carry, x1, surface1, pairing)
        results[name] = jax.block_until_ready((first, second))
    plain = dense(results[PLAIN][1][0], num_rows)
    dense_key = title.replace(", compact", "")
    dense_plain = contacts.get(dense_key)
    if not compact:
        contacts[dense_key] = plain
    base = timings[PLAIN].median_s
    cells = (
        f"{'x'.join(map(str, sizes.grid_shape))} cells of {sizes.cell_size:.3g}, at most "
        f"{sizes.cell_capacity} segments"
        if sizes.use_cells
        else "no cells"
    )
    notes.append(
        f"{title}: allocated (host, untimed) in {allocate_s:.1f} s: {sizes.block_capacity} "
        f"blocks of {sizes.block_size} rows kept, {cells}"
        + f", {sizes.contact_capacity} entries" * compact
        + ". Over plain: "
        + ", ".join(
            f"{name.split(':')[0]} {(timings[name].median_s - base) * 1e3:+.2f} ms"
            for name in list(VARIANTS)[1:]
        )
        + "."
    )
    rows = []
    for name in VARIANTS:
        first, second = results[name]
        check = checks(name, second, plain, dense_plain, first, frames, surface1, num_rows, compact)
        rows.append(
            {
                "scene": title,
                "method": name,
                "timing": timings[name],
                "ratio": timings[name].median_s / base,
                "compile": compiles[name],
                "check": check,
            }
        )
    return rows, results[PLAIN]


def parts_part(title, frames, radius, compact, plain_results, repeats, warmup):
    """Times the pieces the variants add, each jitted alone, on the plain variant's contacts."""
    (x0, surface0), (x1, surface1) = frames
    num_rows = x0.shape[0]
    first, second = plain_results
    before, now = first[0], second[0]
    history = _track.history_of(before, num_rows)
    slip = _track.track(history, now, surface1)
    friction = Friction.zeros(num_rows, x0.dtype)
    corner = _normals.CORNER_DEGREES

    def segments_of(surface):
        return _inputs.resolve_segments(_inputs.check_surface(surface, x0.dtype))

    calls = {"a jitted call returning one row (the floor)": (jax.jit(lambda x: x[0]), (x1,))}
    if compact:
        calls["to_contact(N)"] = (jax.jit(lambda c: c.to_contact(num_rows)), (now,))
    calls["history_of"] = (jax.jit(lambda c: _track.history_of(c, num_rows)), (now,))
    calls["track (links, walk, fallback cond)"] = (
        jax.jit(lambda h, c, s: _track.track(h, c, s)),
        (history, now, surface1),
    )
    calls["vertex_neighbours (the sort)"] = (
        jax.jit(lambda s: _outline.vertex_neighbours(segments_of(s))),
        (surface1,),
    )
    calls["chains (the fallback's walk)"] = (
        jax.jit(lambda s: _outline.chains(segments_of(s))),
        (surface1,),
    )
    calls["smoothed"] = (
        jax.jit(lambda c, x, s: _normals.smoothed(c, x, s, corner)),
        (now, x1, surface1),
    )
    calls["penalty"] = (
        jax.jit(lambda c, s: penalty(c, s, STIFFNESS, num_slaves=num_rows)),
        (now, surface1),
    )
    calls["coulomb"] = (
        jax.jit(
            lambda c, sl, f, s: coulomb(
                c, sl, f, s, stiffness=STIFFNESS, tangent_stiffness=TANGENT_STIFFNESS, mu=MU
            )
        ),
        (now, slip, friction, surface1),
    )
    timings = time_interleaved(calls, repeats=repeats, warmup=warmup)
    return [(title, name, timing) for name, timing in timings.items()]


# -- the scenes --------------------------------------------------------------------


def cutting_frames(num_nodes: int):
    scene = cutting_scene(num_nodes, TIP)
    x0 = scene.x
    x1 = x0.at[:, 0].add(CUT_SHIFT)
    title = f"cutting scene, {x0.shape[0]:,} nodes, R = {scene.radius:g}"
    return title, ((x0, scene.surface), (x1, scene.surface)), scene.radius, {}


def chip_frames(num_nodes: int):
    scene = curling_chip(num_nodes)
    x0 = np.asarray(scene.x)
    h = scene.radius / 2
    # The chip: every node off the workpiece's rectangle [0, 10] x [-2, 0].
    off = np.minimum.reduce(
        [np.abs(x0[:, 1]), np.abs(x0[:, 1] + 2), np.abs(x0[:, 0]), np.abs(x0[:, 0] - 10)]
    )
    chip = off > 1e-6
    x1 = x0 + np.where(chip[:, None], [CHIP_SHIFT * h, 0.0], 0.0)
    frames = []
    for x in (x0, x1):
        x = jnp.asarray(x, scene.x.dtype)
        frames.append((x, scene.surface._replace(nodes=x)))
    title = (
        f"curling chip, {x0.shape[0]:,} nodes, r = {scene.radius:.3g}, self-contact "
        f"({int(chip.sum()):,} chip nodes moved {CHIP_SHIFT:g} h)"
    )
    return title, tuple(frames), scene.radius, {"pairs": Pairs(scene.slave_node, self_contact=True)}


def table(rows) -> list[str]:
    lines = [
        "| scene | variant | median ms | p10-p90 ms | vs. plain | compile s | check |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for entry in rows:
        t = entry["timing"]
        lines.append(
            f"| {entry['scene']} | {entry['method']} | {t.median_s * 1e3:.2f} "
            f"| {t.p10_s * 1e3:.2f}-{t.p90_s * 1e3:.2f} | {entry['ratio']:.2f}x "
            f"| {entry['compile']:.2f} | {entry['check']} |"
        )
    return lines


def parts_table(parts, steps) -> list[str]:
    lines = [
        "| scene | piece | median ms | p10-p90 ms | of the plain step | compile s |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for title, name, t in parts:
        base = steps[title]
        lines.append(
            f"| {title} | {name} | {t.median_s * 1e3:.3f} | {t.p10_s * 1e3:.3f}-"
            f"{t.p90_s * 1e3:.3f} | {t.median_s / base:.2f}x | {t.compile_s:.2f} |"
        )
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, a smoke test")
    parser.add_argument("--repeats", type=int, default=None, help="timed rounds (20; quick 5)")
    parser.add_argument("--warmup", type=int, default=2, help="untimed steps of each first")
    args = parser.parse_args(argv)
    repeats = args.repeats or (5 if args.quick else 20)
    both = (False, True)
    if args.quick:  # one form each, the pieces on the first: under a minute
        plan = [(cutting_frames, 2_000, (True,), True), (chip_frames, 2_000, (False,), False)]
    else:
        plan = [
            (cutting_frames, 10_000, both, True),
            (cutting_frames, 81_939, both, True),
            (chip_frames, 10_000, both, True),
        ]

    start = time.perf_counter()
    rows, parts, notes, contacts, steps = [], [], [], {}, {}
    for frames_of, num_nodes, forms, with_parts in plan:
        title, frames, radius, pairing = frames_of(num_nodes)
        for compact in forms:
            name = title + ", compact" * compact
            found, plain = scene_part(
                name, frames, radius, compact, pairing, repeats, args.warmup, contacts, notes
            )
            rows += found
            steps[name] = found[0]["timing"].median_s
            if with_parts:
                parts += parts_part(name, frames, radius, compact, plain, repeats, args.warmup)

    command = "python benchmarks/friction.py" + " --quick" * args.quick
    if args.repeats:
        command += f" --repeats {args.repeats}"
    lines = [
        "## Slip tracking, Coulomb friction and smooth normals: cost per step",
        "",
        f"`{command}`; {machine()}; float32; median of {repeats} interleaved rounds per scene "
        f"after {args.warmup} warm-up steps, compile apart; each step called with the carry it "
        "returned last, on frames alternating `x0, x1`. `vs. plain`: the median over that of "
        "`Search.closest` + `penalty` on the same scene and form. Checks on two fresh steps "
        "(`x0`, then `x1`).",
        "",
        *table(rows),
        "",
        "Where the extra time goes: the pieces, each jitted alone on the plain variant's "
        "contact of the second step (`of the plain step`: over the plain variant's median).",
        "",
        *parts_table(parts, steps),
        "",
        *[f"- {note}" for note in notes],
        f"- Stiffness {STIFFNESS:g}, tangent stiffness {TANGENT_STIFFNESS:g}, mu {MU:g}; cutting "
        f"frames moved {CUT_SHIFT:g} in x; states allocated for both frames, no skin.",
        f"- Whole run {time.perf_counter() - start:.0f} s.",
    ]
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
