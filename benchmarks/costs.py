"""Self-contact, several deformable bodies in one call, and a radius per slave.

Three parts, float32, every step jitted and compiled ahead of the runs (its
compile time reported apart), two warm-up runs, then the median and the
10th-90th percentile of ``--repeats`` rounds, the methods of one part run
round-robin in this one process (``benchmarks.harness.timing.time_interleaved``),
every call ended by ``block_until_ready``:

1. **Self-contact** of the curling chip (``scenes.curling_chip``: one closed
   outline whose every node is a slave, radius ``2 h``) at 10^4 and 10^5
   nodes: ``Search.closest`` with ``Pairs(self_contact=True)`` (the dense ``Contact`` and the
   compact ``ContactList``) beside the plain ``Search.closest`` on the same
   nodes and radius without the pair rule (every node then finds its own
   segments). References: ``all_to_all(..., pairs=Pairs(..., self_contact=True))`` (and the
   plain ``all_to_all``, the rule's cost there) where N * M <= 2e8 pairs,
   and the same in float64 on a random sample of 2,000 slaves
   (``sampled_reference``), its time per slave extrapolated to N. Checked:
   the active nodes equal the scene's analytic ``pressed`` set; the search's answer equals
   ``all_to_all``'s on every row (segment, found, vertex; gaps to 1e-5) and
   the float64 sample's on the sample plus every row the search finds
   (segment, found; gaps to 1e-5).
2. **Two bodies in one call**: ``scenes.two_blocks(n)``, the upper block
   pressed ``2 / n`` into the lower one (radius ``4 / n``, two node
   spacings of depth at most), ``8 n`` nodes. One ``Search.closest`` over the
   union with ``slave_body`` and ``surface.body``, against what a user wrote
   before: two searches in one jitted step, each body's nodes against the
   other body's outline alone (two ``Search`` states), and ``all_to_all``
   with the labels. Checked: the three answers agree row for row (segments
   mapped to the union's numbering) and the active nodes equal ``pressed``.
3. **A radius per slave** on the cutting scene (81,939 nodes, tool tip at
   ``x = 18``): ``Search(radius=0.1).closest(..., radius=r)`` with ``r`` f[N]
   uniform in [0.05, 0.1], the same call with the traced scalar 0.1, and
   ``all_to_all`` with the f[N] radius (the reference). Traces of the jitted
   step are counted over calls with new radii.

    python benchmarks/bodies.py                 # full sizes, about 5 minutes on 2 cores
    taskset -c 0 python benchmarks/bodies.py    # pinned to one core
    python benchmarks/bodies.py --quick         # small sizes, a smoke test
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
from benchmarks.harness.timing import time_interleaved
from jaxcontact import Contact, Pairs, Search, Surface, all_to_all
from jaxcontact.scenes import curling_chip, cutting_scene, two_blocks

DENSE_PAIRS = 2e8  # all_to_all runs at or below this many pairs
GAP_TOLERANCE = 1e-5


# -- the reference on a sample: the library's own pair rule in float64 ------------


def sampled_reference(x, surface, rows, radius, *, slave_node):
    """Slaves ``rows`` searched in float64 by ``all_to_all`` with
    ``pairs=Pairs(slave_node, self_contact=True)`` (the library's pair rule,
    checked against the exact oracle by the tests), on those rows alone:
    ``(segment, found, gap, distance)``, ``distance`` inf where not found.
    """
    rows = np.asarray(rows)
    radius = np.broadcast_to(np.asarray(radius, np.float64), (len(x),))
    with jax.enable_x64(True):
        nodes = jnp.asarray(np.asarray(surface.nodes), jnp.float64)
        contact = all_to_all(
            jnp.asarray(np.asarray(x)[rows], jnp.float64),
            surface._replace(nodes=nodes),
            radius=radius[rows],
            pairs=Pairs(np.asarray(slave_node)[rows], self_contact=True),
        )
        found = np.asarray(contact.found)
        offset = np.asarray(x, np.float64)[rows] - np.asarray(contact.point)
    distance = np.where(found, np.linalg.norm(offset, axis=-1), np.inf)
    return np.asarray(contact.segment), found, np.asarray(contact.gap), distance


# -- checks ----------------------------------------------------------------------


def dense(result, num_rows: int) -> Contact:
    """The dense ``Contact`` of a result (a ``ContactList`` expanded, a state dropped)."""
    result = result[0] if isinstance(result, tuple) and not isinstance(result, Contact) else result
    return result if isinstance(result, Contact) else result.to_contact(num_rows)


def against(contact: Contact, reference: Contact) -> str:
    """Rows whose segment, found or vertex differ; the largest gap difference where found."""
    segment = np.asarray(contact.segment) != np.asarray(reference.segment)
    found = np.asarray(contact.found) != np.asarray(reference.found)
    vertex = np.asarray(contact.vertex) != np.asarray(reference.vertex)
    both = np.asarray(contact.found) & np.asarray(reference.found)
    gaps = np.abs(np.asarray(contact.gap, np.float64) - np.asarray(reference.gap, np.float64))
    worst = float(gaps[both].max()) if both.any() else 0.0
    text = f"{int(np.sum(segment | found))} rows differ"
    if vertex.any():
        text += f", {int(vertex.sum())} vertices differ"
    return text + f", max gap diff {worst:.1e}" + " (over 1e-5!)" * (worst > GAP_TOLERANCE)


def against_sample(contact: Contact, x, rows, sample, radius, scale) -> tuple[str, np.ndarray]:
    """``sample`` (segment, found, gap, distance on ``rows``) against ``contact``: words and
    the rows that disagree. A slave whose distance (the sample's, else its own in
    ``contact``) lies within 8 float32 ulps of the coordinates' magnitude ``scale`` of its
    radius may be found either way: counted apart."""
    segment, found, gap, distance = sample
    radius = np.broadcast_to(np.asarray(radius, np.float64), (np.asarray(contact.gap).shape[0],))
    mine_segment = np.asarray(contact.segment)[rows]
    mine_found = np.asarray(contact.found)[rows]
    mine_gap = np.asarray(contact.gap, np.float64)[rows]
    own = np.asarray(x, np.float64)[rows] - np.asarray(contact.point, np.float64)[rows]
    distance = np.where(found, distance, np.linalg.norm(own, axis=-1))
    at_radius = np.abs(distance - radius[rows]) <= 8 * np.finfo(np.float32).eps * scale
    found_differs = (mine_found != found) & ~at_radius
    segment_differs = mine_found & found & (mine_segment != segment)
    gap_differs = mine_found & found & (np.abs(mine_gap - gap) > GAP_TOLERANCE)
    bad = found_differs | segment_differs | gap_differs
    text = f"{int(bad.sum())} of {len(rows)} rows differ ({int(found.sum())} found)"
    if (at_radius & (mine_found != found)).any():
        text += f", {int((at_radius & (mine_found != found)).sum())} at the radius to rounding"
    return text, np.asarray(rows)[bad]


# -- the three parts ---------------------------------------------------------------


def timed(calls, repeats, warmup):
    timings = time_interleaved(calls, repeats=repeats, warmup=warmup)
    results = {name: jax.block_until_ready(fn(*args)) for name, (fn, args) in calls.items()}
    return timings, results


def row(scene, name, timing, ratio, check, compile_s=None) -> dict:
    return {
        "scene": scene,
        "method": name,
        "timing": timing,
        "ratio": ratio,
        "check": check,
        "compile": timing.compile_s if compile_s is None else compile_s,
    }


def self_contact_part(num_nodes: int, sample: int, repeats: int, warmup: int, rng, notes):
    scene = curling_chip(num_nodes)
    x, surface, radius = scene.x, scene.surface, scene.radius
    n, m = x.shape[0], surface.segments.shape[0]
    node = scene.slave_node
    title = f"curling chip, {n:,} nodes, r = {radius:.3g}"
    allocated, sizes = {}, {}

    def allocate(search, pairs=None):
        start = time.perf_counter()
        state = search.allocate(x, surface, pairs=pairs)
        allocated[search] = time.perf_counter() - start
        sizes[search] = state.sizes
        return state

    searches = {
        "Search.closest, Pairs(self_contact=True)": Search(radius=radius),
        "Search(compact=True).closest, Pairs(self_contact=True)": Search(
            radius=radius, compact=True
        ),
    }
    calls = {}
    for name, search in searches.items():
        state = allocate(search, Pairs(node, self_contact=True))

        def step(state, x, surface, node, search=search):
            return search.closest(state, x, surface, pairs=Pairs(node, self_contact=True))

        calls[name] = (jax.jit(step), (state, x, surface, node))
    plain = Search(radius=radius)
    calls["plain Search.closest (no pair rule)"] = (
        jax.jit(plain.closest),
        (allocate(plain), x, surface),
    )
    dense_reference = n * m <= DENSE_PAIRS
    if dense_reference:

        def exhaustive(x, surface, node):
            rule = Pairs(node, self_contact=True)
            return all_to_all(x, surface, radius=radius, pairs=rule)

        calls["all_to_all, Pairs(self_contact=True)"] = (jax.jit(exhaustive), (x, surface, node))
        calls["all_to_all (no pair rule)"] = (
            jax.jit(lambda x, surface: all_to_all(x, surface, radius=radius)),
            (x, surface),
        )

    # The float64 reference on a random sample, timed in the same rounds.
    nodes64 = np.asarray(x, np.float64)
    rows = np.sort(rng.choice(n, size=min(sample, n), replace=False))

    def reference_sample(rows=rows):
        return sampled_reference(x, surface, rows, radius, slave_node=node)

    calls[f"all_to_all f64, {len(rows):,} sampled slaves"] = (reference_sample, ())
    timings, results = timed(calls, repeats, warmup)

    names = list(calls)
    contacts = {name: dense(results[name], n) for name in names[:3]}
    self_dense = contacts[names[0]]
    pressed = np.asarray(scene.pressed)
    base = timings[names[2]].median_s
    lines = []
    for name in names[:2]:
        contact = contacts[name]
        active = np.asarray(contact.active)
        check = (
            f"active = pressed: {bool((active == pressed).all())} "
            f"({int(active.sum())} of {int(pressed.sum())}); found {int(contact.found.sum())}"
            f"; overflow {bool(contact.overflow)}"
        )
        if name != names[0]:
            check += f"; against the dense form: {against(contact, self_dense)}"
        lines.append(row(title, name, timings[name], timings[name].median_s / base, check))
    plain_contact = contacts[names[2]]
    lines.append(
        row(
            title,
            names[2],
            timings[names[2]],
            1.0,
            f"found {int(plain_contact.found.sum())} (own segments), "
            f"active {int(plain_contact.active.sum())}",
        )
    )
    if dense_reference:
        name = names[3]
        reference = results[name]
        check = (
            f"active = pressed: {bool((np.asarray(reference.active) == pressed).all())}; "
            f"self-contact Search against it: {against(self_dense, reference)}; "
            f"compact: {against(contacts[names[1]], reference)}"
        )
        lines.append(row(title, name, timings[name], timings[name].median_s / base, check))
        name = names[4]
        lines.append(
            row(
                title,
                name,
                timings[name],
                timings[name].median_s / base,
                f"found {int(results[name].found.sum())} (own segments); self-contact "
                f"all_to_all / this = {timings[names[3]].median_s / timings[name].median_s:.1f}x",
            )
        )
    else:
        notes.append(
            f"{title}: `all_to_all` not run ({n:,} x {m:,} = {n * m:.1e} pairs > "
            f"{DENSE_PAIRS:.0e})."
        )
    # Check on the sample and on every row the search finds (the latter untimed).
    name = names[-1]
    found_rows = np.flatnonzero(np.asarray(self_dense.found))
    checked = np.union1d(rows, found_rows)
    reference = reference_sample(checked)
    scale = float(np.abs(nodes64).max())
    words, bad = against_sample(self_dense, x, checked, reference, radius, scale)
    compact = contacts[names[1]]
    compact_words, compact_bad = against_sample(compact, x, checked, reference, radius, scale)
    per_slave = timings[name].median_s / len(rows)
    extrapolated = per_slave * n
    lines.append(
        row(
            title,
            name,
            timings[name],
            timings[name].median_s / base,
            f"time per slave {per_slave * 1e3:.3f} ms, extrapolated to all {n:,}: "
            f"{extrapolated:.1f} s ({extrapolated / base:.0f}x plain); "
            f"on the sample + the {len(found_rows)} found rows: dense {words}; "
            f"compact {compact_words}",
            compile_s=float("nan"),
        )
    )
    for label, wrong in (("dense", bad), ("compact", compact_bad)):
        if len(wrong):
            notes.append(
                f"{title}: {label} rows that differ from all_to_all in float64: "
                f"{wrong[:20].tolist()} (reproduce: `curling_chip({num_nodes})`, "
                "`sampled_reference` of benchmarks/bodies.py on those rows)."
            )
    ratio = timings[names[0]].median_s / base
    compact_ratio = timings[names[1]].median_s / base
    notes.append(
        f"{title}: self-contact / plain = {ratio:.2f}x dense, {compact_ratio:.2f}x compact "
        f"(target <= 2x). Allocation (host, untimed above): "
        + ", ".join(
            f"{'self-contact' if s.self_contact else 'plain'}"
            f"{' compact' if s.compact else ''} {seconds:.1f} s"
            for s, seconds in allocated.items()
        )
        + f". Sizes of the plain search: {cells(sizes[plain])} (cell edge "
        f"{sizes[plain].cell_size / radius:.0f} r); the self-contact search's: "
        f"{cells(sizes[searches[names[0]]])}."
    )
    return lines


def cells(sizes):
    if not sizes.use_cells:
        return "no cells"
    shape = "x".join(map(str, sizes.grid_shape))
    hashed = f" hashed into {sizes.buckets:,} lists" if sizes.buckets else ""
    return f"{shape} cells of {sizes.cell_size:.3g}{hashed}, at most {sizes.cell_capacity} segments"


def split(scene):
    """Per body: (node slice, local segments, the union index of each local segment)."""
    node_body = np.asarray(scene.slave_body)
    segments = np.asarray(scene.surface.segments)
    body = np.asarray(scene.body)
    parts = []
    for label in np.unique(node_body):
        at = np.flatnonzero(node_body == label)
        if not np.array_equal(at, np.arange(at[0], at[-1] + 1)):
            raise ValueError("each body's nodes must be consecutive")
        ids = np.flatnonzero(body == label)
        parts.append((slice(int(at[0]), int(at[-1]) + 1), segments[ids] - at[0], ids))
    return parts


def bodies_part(n: int, repeats: int, warmup: int, notes):
    scene = two_blocks(n, overlap=2.0 / n)
    x, surface, radius = scene.x, scene.surface, scene.radius
    count, m = x.shape[0], surface.segments.shape[0]
    title = f"two blocks, {count:,} nodes, r = {radius:.3g}"
    search = Search(radius=radius)
    union_state = search.allocate(x, surface, pairs=Pairs(slave_body=scene.slave_body))

    def one_call(state, x, surface, slave_body):
        return search.closest(state, x, surface, pairs=Pairs(slave_body=slave_body))

    (first, segments0, ids0), (second, segments1, ids1) = split(scene)
    segments0, segments1 = jnp.asarray(segments0), jnp.asarray(segments1)
    # Body 0's nodes against body 1's outline alone, and body 1's against body 0's.
    states = (
        search.allocate(x[first], Surface(x[second], segments1)),
        search.allocate(x[second], Surface(x[first], segments0)),
    )

    def two_searches(states, x, segments0, segments1):
        c0, s0 = search.closest(states[0], x[first], Surface(x[second], segments1))
        c1, s1 = search.closest(states[1], x[second], Surface(x[first], segments0))
        return (c0, c1), (s0, s1)

    def exhaustive(x, surface, slave_body):
        return all_to_all(x, surface, radius=radius, pairs=Pairs(slave_body=slave_body))

    calls = {
        "one Search.closest over the union (slave_body)": (
            jax.jit(one_call),
            (union_state, x, surface, scene.slave_body),
        ),
        "two Search.closest, each body against the other's outline": (
            jax.jit(two_searches),
            (states, x, segments0, segments1),
        ),
    }
    if count * m <= DENSE_PAIRS:
        calls["all_to_all with the labels"] = (
            jax.jit(exhaustive),
            (x, surface, scene.slave_body),
        )
    timings, results = timed(calls, repeats, warmup)
    names = list(calls)
    union = dense(results[names[0]], count)
    (c0, c1), _ = results[names[1]]
    # The two answers in the union's numbering: rows in order, segments mapped.
    ids = (jnp.asarray(ids1), jnp.asarray(ids0))  # body 0's rows met body 1's segments
    pieces = [
        c._replace(
            segment=jnp.where(c.segment >= 0, mapping[jnp.maximum(c.segment, 0)], -1),
            vertex=jnp.where(c.vertex >= 0, c.vertex + offset, -1),
        )
        for c, mapping, offset in ((c0, ids[0], second.start), (c1, ids[1], first.start))
    ]
    pair = Contact(
        *(jnp.concatenate([a, b]) for a, b in zip(pieces[0][:-1], pieces[1][:-1], strict=True)),
        pieces[0].overflow | pieces[1].overflow,
    )
    pressed = np.asarray(scene.pressed)
    base = timings[names[1]].median_s
    out = []
    for name, contact in ((names[0], union), (names[1], pair)):
        active = np.asarray(contact.active)
        check = (
            f"active = pressed: {bool((active == pressed).all())} ({int(active.sum())} of "
            f"{int(pressed.sum())}); found {int(contact.found.sum())}; "
            f"overflow {bool(contact.overflow)}"
        )
        if name == names[0]:
            check += f"; against the two searches: {against(union, pair)}"
        out.append(row(title, name, timings[name], timings[name].median_s / base, check))
    if len(names) > 2:
        reference = results[names[2]]
        out.append(
            row(
                title,
                names[2],
                timings[names[2]],
                timings[names[2]].median_s / base,
                f"one call against it: {against(union, reference)}; two searches: "
                f"{against(pair, reference)}",
            )
        )

    blocks = -(-count // union_state.sizes.block_size)
    notes.append(
        f"{title}: one call / two searches = {timings[names[0]].median_s / base:.2f}x. "
        f"Blocks of {union_state.sizes.block_size} rows kept: one call "
        f"{union_state.sizes.block_capacity} of {blocks} (every node lies on its own outline, "
        "so the broad phase keeps every block and the pair rule is left to the narrow phase), "
        f"two searches {states[0].sizes.block_capacity} + {states[1].sizes.block_capacity}. "
        f"Cells: one call {cells(union_state.sizes)}; two searches {cells(states[0].sizes)} "
        f"and {cells(states[1].sizes)}: each search's grid spans only its kept slaves (a thin "
        "band along the contact), and the other body's segments outside it are clamped into "
        "the edge cells (`_cells.cell_of`), so the slaves near the corners search those cells."
    )
    return out


def radius_part(num_nodes: int, repeats: int, warmup: int, rng, notes):
    scene = cutting_scene(num_nodes, 18.0)
    x, surface = scene.x, scene.surface
    count = x.shape[0]
    title = f"cutting scene, {count:,} nodes, R = 0.1"
    search = Search(radius=0.1)
    state = search.allocate(x, surface)
    traces = {"f[N]": 0, "scalar": 0}

    def per_slave(state, x, surface, r):
        traces["f[N]"] += 1
        return search.closest(state, x, surface, radius=r)

    def scalar(state, x, surface, r):
        traces["scalar"] += 1
        return search.closest(state, x, surface, radius=r)

    def exhaustive(x, surface, r):
        return all_to_all(x, surface, radius=r)

    def draw():
        return jnp.asarray(rng.uniform(0.05, 0.1, count), x.dtype)

    r = draw()
    tenth = jnp.asarray(0.1, x.dtype)
    per_slave_jit, scalar_jit = jax.jit(per_slave), jax.jit(scalar)
    calls = {
        "Search(radius=0.1).closest(radius=r), r f[N] in [0.05, 0.1]": (
            per_slave_jit,
            (state, x, surface, r),
        ),
        "Search(radius=0.1).closest(radius=0.1), traced scalar": (
            scalar_jit,
            (state, x, surface, tenth),
        ),
        "all_to_all(radius=r), r f[N]": (jax.jit(exhaustive), (x, surface, r)),
    }
    timings, results = timed(calls, repeats, warmup)
    names = list(calls)
    base = timings[names[1]].median_s
    reference = results[names[2]]
    scalar_reference = all_to_all(x, surface, radius=0.1)
    by_rank = dense(results[names[0]], count)
    at_tenth = dense(results[names[1]], count)
    # New radii: the same jitted functions, called (not lowered) with fresh values.
    before = dict(traces)
    for _ in range(4):
        jax.block_until_ready(per_slave_jit(state, x, surface, draw()))
        jax.block_until_ready(
            scalar_jit(state, x, surface, jnp.asarray(rng.uniform(0.05, 0.1), x.dtype))
        )
    after = {key: traces[key] - before[key] for key in traces}
    out = [
        row(
            title,
            names[0],
            timings[names[0]],
            timings[names[0]].median_s / base,
            f"against all_to_all(r): {against(by_rank, reference)}; found "
            f"{int(by_rank.found.sum())}; overflow {bool(by_rank.overflow)}",
        ),
        row(
            title,
            names[1],
            timings[names[1]],
            1.0,
            f"against all_to_all(0.1): {against(at_tenth, scalar_reference)}; found "
            f"{int(at_tenth.found.sum())}; overflow {bool(at_tenth.overflow)}",
        ),
        row(
            title,
            names[2],
            timings[names[2]],
            timings[names[2]].median_s / base,
            f"found {int(reference.found.sum())}",
        ),
    ]
    notes.append(
        f"{title}: after the compile (1 trace each), 4 calls with new f[N] radii traced "
        f"{after['f[N]']} more times and 4 with new scalar radii {after['scalar']}: "
        f"{'a new radius compiles nothing' if not any(after.values()) else 'RETRACED'}."
    )
    return out


def table(rows) -> list[str]:
    lines = [
        "| scene | method | median ms | p10-p90 ms | vs. first of part | compile s | check |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for entry in rows:
        t = entry["timing"]
        compile_s = "-" if np.isnan(entry["compile"]) else f"{entry['compile']:.2f}"
        lines.append(
            f"| {entry['scene']} | {entry['method']} | {t.median_s * 1e3:.2f} "
            f"| {t.p10_s * 1e3:.2f}-{t.p90_s * 1e3:.2f} | {entry['ratio']:.2f}x "
            f"| {compile_s} | {entry['check']} |"
        )
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, a smoke test")
    parser.add_argument("--repeats", type=int, default=None, help="timed rounds (20; quick 10)")
    parser.add_argument("--warmup", type=int, default=2, help="untimed runs of each first")
    parser.add_argument("--seed", type=int, default=0, help="the sample and the radii")
    args = parser.parse_args(argv)
    repeats = args.repeats or (10 if args.quick else 20)
    rng = np.random.default_rng(args.seed)
    chips = (2_000, 10_000) if args.quick else (10_000, 100_000)
    blocks = 100 if args.quick else 1_250
    cutting = 10_000 if args.quick else 81_939
    sample = 500 if args.quick else 2_000

    start = time.perf_counter()
    notes, rows = [], []
    for num_nodes in chips:
        rows += self_contact_part(num_nodes, sample, repeats, args.warmup, rng, notes)
    rows += bodies_part(blocks, repeats, args.warmup, notes)
    rows += radius_part(cutting, repeats, args.warmup, rng, notes)

    command = "python benchmarks/bodies.py" + " --quick" * args.quick
    if args.repeats:
        command += f" --repeats {args.repeats}"
    lines = [
        "## Bodies, self-contact and a radius per slave",
        "",
        f"`{command}`; {machine()}; float32; median of {repeats} interleaved rounds per part "
        f"after {args.warmup} warm-up runs, compile apart. `vs.`: the median over that of the "
        "part's comparator (plain `Search.closest`; the two searches; the scalar radius).",
        "",
        *table(rows),
        "",
        *[f"- {note}" for note in notes],
        "- Sampled reference: `all_to_all(..., self_contact=True)` in float64 on the sample's "
        "slaves against every segment (the library's pair rule, which the tests check against "
        "the exact oracle); its time per slave is extrapolated linearly to N. "
        f"Sample drawn with seed {args.seed}. A row whose float64 distance lies "
        "within 8 float32 ulps of the coordinates' magnitude of the radius may be found either "
        "way and is not counted as differing.",
        f"- Whole run {time.perf_counter() - start:.0f} s.",
    ]
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
