"""The cost of bodies and friction: each feature's time beside the plain search's.

Self-contact, several bodies in one call, a radius per slave, slip tracking, Coulomb
friction and smooth normals.

Float32, every step jitted and compiled ahead of the runs (its compile time reported apart),
``--warmup`` untimed runs, then the median and the 10th-90th percentile of ``--repeats``
rounds, the methods of one part run round-robin in this one process
(``benchmarks.harness.timing.time_interleaved``), every call ended by ``block_until_ready``.
Each part (``self_contact_part``, ``bodies_part``, ``radius_part``, ``scene_part``,
``pieces_part``) returns rows (dicts): ``scene``, ``method``, ``timing`` (a ``Timing``),
``ratio`` (the median over that of the part's comparator), ``compile`` (seconds; None where
nothing is compiled), ``checks`` (``check`` and ``info`` items, ``verdict`` sums them up)
and, for the figure, ``feature`` (what the row adds over its comparator) and ``series`` (a
``style.STYLES`` name; None: not drawn).

Bodies (the first table), each part beside its comparator:

1. **Self-contact** of the curling chip (``scenes.curling_chip``: one closed outline whose
   every node is a slave, radius ``2 h``) at 10^4 and 10^5 nodes: ``Search.closest`` with
   ``Pairs(self_contact=True)`` (the dense ``Contact`` and the compact ``ContactList``)
   beside the plain ``Search.closest`` on the same nodes and radius without the pair rule
   (every node then finds its own segments). References: ``all_to_all`` with the rule (and
   without it, the rule's cost there) where N * M <= 2e8 pairs, and with the rule in
   float64 on a random sample of 2,000 slaves, its time per slave extrapolated to N.
   Checked: the active nodes equal the scene's analytic ``pressed`` set; the search's answer
   equals ``all_to_all``'s on every row (segment, found, vertex; gaps to 1e-5) and the
   float64 sample's on the sample plus every row the search finds (segment, found; gaps to
   1e-5; a row within 8 float32 ulps of the coordinates' magnitude of its radius may be
   found either way); no overflow.
2. **Two bodies in one call**: ``scenes.two_blocks(1250)``, the upper block pressed
   ``2 / n`` into the lower one (radius ``4 / n``), 10^4 nodes. One ``Search.closest``
   over the union with ``slave_body`` against what a user wrote before: two searches in one
   jitted step, each body's nodes against the other body's outline alone, and
   ``all_to_all`` with the labels. Checked: the three answers agree row for row (segments
   mapped to the union's numbering) and the active nodes equal ``pressed``.
3. **A radius per slave** on the cutting scene (81,939 nodes, tool tip at ``x = 18``):
   ``Search(radius=0.1).closest(..., radius=r)`` with ``r`` f[N] uniform in [0.05, 0.1]
   over the same call with the traced scalar 0.1, and ``all_to_all`` with the f[N] radius
   (the reference). Checked: the answers equal ``all_to_all``'s, and calls with new radii
   trace the jitted steps no more.

Friction (the second and third tables): one simulation step ``step(carry, x, surface)``
that returns what a simulation needs (the contact, the forces on the slaves and the master's
nodes, the slip where tracked) and the carry (the ``SearchState``, the ``Friction`` for
Coulomb), called with the carry it returned last on positions that alternate between two
frames ``x0, x1, x0, ...``, so every step has slip to compute. Five variants: **plain**
(``Search.closest`` + ``forces.penalty``), **track** (``Search(track=True)`` + penalty),
**track + Coulomb** (``forces.coulomb``, the ``Friction`` carried), **smooth normals**
(``Search(normals=Smooth())`` + penalty), **all** (track, smooth, Coulomb). Scenes, each
in the dense and the compact form: the cutting scene at 10^4 and 81,939 nodes, the frames
the grid and the grid moved ``+0.01`` in x; the curling chip at 10^4 nodes with the
self-contact rule, the frames the chip and the chip moved ``0.75 h`` in x. States
allocated for both frames, no skin (the whole bucket sort every step); stiffness and
tangent stiffness ``1e3``, ``mu = 0.3``. Checked on two fresh steps (``x0`` then ``x1``) of
every variant: segments and found rows equal the plain variant's (smooth normals change the
normal and the gap only) and the compact form's the dense form's; the slip and anchors are
finite and equal, to 1e-5, the slave's move relative to the material point on the rows that
stayed on one segment's interior and the path length along the outline on the rows that
changed segment (both computed on the host in float64); the forces on the slaves and the
master sum to zero (1e-5 of their magnitudes); Coulomb's normal part equals the penalty's,
its tangential part is within ``mu f_n`` and its dissipation ``>= 0``; no overflow. The
third table times the pieces the variants add, each jitted alone on the plain variant's
contact, beside a jitted call that returns one row of ``x`` (the floor of one call).

The figure: each feature's time over its comparator's (log scale), per scene.

    python benchmarks/costs.py                                            # about 8 min on 2 cores
    taskset -c 0 python benchmarks/costs.py --out benchmarks/results/pinned
    python benchmarks/costs.py --quick                                    # small sizes
"""

from __future__ import annotations

import math
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness import _run, report, style
from benchmarks.harness.internals import (
    _normals,
    _outline,
    _track,
    check_surface,
    resolve_segments,
)
from benchmarks.harness.timing import time_interleaved
from jaxcontact import Contact, ContactList, Pairs, Search, Smooth, Surface, all_to_all
from jaxcontact.forces import Friction, coulomb, penalty
from jaxcontact.scenes import curling_chip, cutting_scene, two_blocks

TITLE = "The cost of bodies and friction"
FULL = {
    "chips": (10_000, 100_000),
    "sample": 2_000,
    "blocks": 1_250,
    "cutting": 81_939,
    # (frames, nodes, forms (compact?), with the pieces)
    "friction": (
        ("cutting", 10_000, (False, True), True),
        ("cutting", 81_939, (False, True), True),
        ("chip", 10_000, (False, True), True),
    ),
}
QUICK = {
    "chips": (2_000,),
    "sample": 500,
    "blocks": 100,
    "cutting": 10_000,
    "friction": (("cutting", 2_000, (True,), True), ("chip", 2_000, (False,), False)),
}
OPTIONS = (
    (("--warmup",), {"type": int, "default": 2, "help": "untimed runs of each first"}),
    (("--seed",), {"type": int, "default": 0, "help": "the sample and the radii"}),
)

DENSE_PAIRS = 2e8  # all_to_all runs at or below this many pairs
GAP_TOLERANCE = 1e-5
STIFFNESS = 1e3
TANGENT_STIFFNESS = 1e3
MU = 0.3
CUT_SHIFT = 0.01  # the cutting scene's second frame: the grid moved this far in x
CHIP_SHIFT = 0.75  # the curling chip's: the chip moved this many node spacings h in x
TIP = 18.0  # the cutting tool's tip, in the radius part and the friction scenes alike
FORCE_TOLERANCE = 1e-5  # |sum of the forces| over the sum of their magnitudes
SLIP_TOLERANCE = 1e-5  # |slip - the host's| on rows that stayed on one segment's interior

# The figure's series: the library's search in each form, and all_to_all doing the same job.
DENSE, COMPACT = "Search.closest (reused state)", "Search.closest (compact, reused state)"
EXHAUSTIVE = "all_to_all"

VARIANTS = {  # name -> (Search keywords, forces, what it adds over plain: the figure's label)
    "plain: closest + penalty": ({}, "penalty", None),
    "track: closest(track) + penalty": ({"track": True}, "penalty", "slip tracking"),
    "track + Coulomb": ({"track": True}, "coulomb", "tracking + Coulomb"),
    "smooth normals: closest(normals=Smooth()) + penalty": (
        {"normals": Smooth()},
        "penalty",
        "smooth normals",
    ),
    "all: track + smooth + Coulomb": (
        {"track": True, "normals": Smooth()},
        "coulomb",
        "tracking + smooth + Coulomb",
    ),
}
PLAIN = next(iter(VARIANTS))


# -- checks ------------------------------------------------------------------------


def check(what: str, ok, detail: str = "") -> dict:
    """One check of an answer: ``what`` was compared, whether it held, the numbers."""
    return {"what": what, "ok": bool(ok), "detail": detail}


def info(what: str, detail: str) -> dict:
    """A number the run reports beside its checks (nothing to hold)."""
    return {"what": what, "ok": None, "detail": detail}


def verdict(checks) -> str | None:
    """A row's checks in a table cell: ``right`` (``all N right``), or ``WRONG:`` and what failed;
    None where the row has nothing to check."""
    judged = [c for c in checks if c["ok"] is not None]
    failed = [c for c in judged if not c["ok"]]
    if not judged:
        return None
    if failed:
        return "WRONG: " + "; ".join(f"{c['what']} ({c['detail']})" for c in failed)
    return "right" if len(judged) == 1 else f"all {len(judged)} right"


def words(checks) -> str:
    """Every check and number of a row, in words (the record's data keeps them)."""
    marks = {True: "", False: " FAILED", None: ""}
    return "; ".join(f"{c['what']}{marks[c['ok']]}: {c['detail']}".rstrip(": ") for c in checks)


def dense(result, num_rows: int) -> Contact:
    """The dense ``Contact`` of a result (a ``ContactList`` expanded, a state dropped)."""
    if isinstance(result, tuple) and not isinstance(result, (Contact, ContactList)):
        result = result[0]
    return result.to_contact(num_rows) if isinstance(result, ContactList) else result


def against(what: str, contact: Contact, reference: Contact) -> dict:
    """Rows whose segment, found or vertex differ, and the largest gap difference where both
    found: right when no row differs and the gaps agree to ``GAP_TOLERANCE``."""
    segment = np.asarray(contact.segment) != np.asarray(reference.segment)
    found = np.asarray(contact.found) != np.asarray(reference.found)
    vertex = np.asarray(contact.vertex) != np.asarray(reference.vertex)
    both = np.asarray(contact.found) & np.asarray(reference.found)
    gaps = np.abs(np.asarray(contact.gap, np.float64) - np.asarray(reference.gap, np.float64))
    worst = float(gaps[both].max()) if both.any() else 0.0
    differ = int(np.sum(segment | found))
    detail = f"{differ} rows differ"
    if vertex.any():
        detail += f", {int(vertex.sum())} vertices differ"
    detail += f", max gap diff {worst:.1e}"
    return check(what, differ == 0 and not vertex.any() and worst <= GAP_TOLERANCE, detail)


def pressed_check(contact: Contact, pressed: np.ndarray) -> dict:
    active = np.asarray(contact.active)
    return check(
        "active = pressed",
        (active == pressed).all(),
        f"{int(active.sum())} active, {int(pressed.sum())} pressed",
    )


def overflow_check(contact) -> dict:
    return check("no overflow", not bool(contact.overflow), f"overflow {bool(contact.overflow)}")


def found_info(contact) -> dict:
    return info("found", f"{int(np.sum(contact.found))}, active {int(np.sum(contact.active))}")


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


def against_sample(contact: Contact, x, rows, sample, radius, scale) -> tuple[dict, np.ndarray]:
    """``sample`` (segment, found, gap, distance on ``rows``) against ``contact``: the check
    and the rows that disagree. A slave whose distance (the sample's, else its own in
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
    detail = f"{int(bad.sum())} of {len(rows)} rows differ ({int(found.sum())} found)"
    if (at_radius & (mine_found != found)).any():
        detail += f", {int((at_radius & (mine_found != found)).sum())} at the radius to rounding"
    return check("= all_to_all f64 on the sample", not bad.any(), detail), np.asarray(rows)[bad]


# -- bodies: self-contact, two bodies, a radius per slave ---------------------------


def timed(calls, repeats, warmup):
    timings = time_interleaved(calls, repeats=repeats, warmup=warmup)
    results = {name: jax.block_until_ready(fn(*args)) for name, (fn, args) in calls.items()}
    return timings, results


def row(scene, name, timing, ratio, checks, *, compile_s=False, feature=None, series=None):
    """A part's row; ``compile_s`` False: the timing's own."""
    return {
        "scene": scene,
        "method": name,
        "timing": timing,
        "ratio": ratio,
        "compile": timing.compile_s if compile_s is False else compile_s,
        "checks": checks,
        "feature": feature,
        "series": series,
    }


def cells(sizes) -> str:
    if not sizes.use_cells:
        return "no cells"
    shape = "x".join(map(str, sizes.grid_shape))
    hashed = f" hashed into {sizes.buckets:,} lists" if sizes.buckets else ""
    return f"{shape} cells of {sizes.cell_size:.3g}{hashed}, at most {sizes.cell_capacity} segments"


def self_contact_part(num_nodes: int, sample: int, repeats: int, warmup: int, rng, notes):
    """The curling chip, every node a slave: ``Search.closest`` with the self-contact rule
    (dense and compact) over the plain search, ``all_to_all`` with and without the rule where
    it fits, and ``all_to_all`` in float64 on a sample of slaves (the reference)."""
    scene = curling_chip(num_nodes)
    x, surface, radius = scene.x, scene.surface, scene.radius
    n, m = x.shape[0], surface.segments.shape[0]
    node = scene.slave_node
    title = f"curling chip, {n:,} nodes, r = {radius:.3g}"
    allocated, sizes = {}, {}

    def allocate(label, search, pairs=None):
        start = time.perf_counter()
        state = search.allocate(x, surface, pairs=pairs)
        allocated[label] = time.perf_counter() - start
        sizes[label] = state.sizes["closest"]
        return state

    names = {
        "dense": "Search.closest, Pairs(self_contact=True)",
        "compact": "Search(compact=True).closest, Pairs(self_contact=True)",
        "plain": "plain Search.closest (no pair rule)",
        "exhaustive": "all_to_all, Pairs(self_contact=True)",
        "exhaustive plain": "all_to_all (no pair rule)",
    }
    calls = {}
    for form, compact in (("dense", False), ("compact", True)):
        search = Search(radius=radius, compact=compact)
        state = allocate(f"self-contact {form}", search, Pairs(node, self_contact=True))

        def step(state, x, surface, node, search=search):
            return search.closest(state, x, surface, pairs=Pairs(node, self_contact=True))

        calls[names[form]] = (jax.jit(step), (state, x, surface, node))
    plain = Search(radius=radius)
    calls[names["plain"]] = (jax.jit(plain.closest), (allocate("plain", plain), x, surface))
    dense_reference = n * m <= DENSE_PAIRS
    if dense_reference:

        def exhaustive(x, surface, node):
            return all_to_all(x, surface, radius=radius, pairs=Pairs(node, self_contact=True))

        calls[names["exhaustive"]] = (jax.jit(exhaustive), (x, surface, node))
        calls[names["exhaustive plain"]] = (
            jax.jit(lambda x, surface: all_to_all(x, surface, radius=radius)),
            (x, surface),
        )

    # The float64 reference on a random sample, timed in the same rounds.
    rows = np.sort(rng.choice(n, size=min(sample, n), replace=False))

    def reference_sample(rows=rows):
        return sampled_reference(x, surface, rows, radius, slave_node=node)

    names["sample"] = f"all_to_all f64, {len(rows):,} sampled slaves"
    calls[names["sample"]] = (reference_sample, ())
    timings, results = timed(calls, repeats, warmup)

    contacts = {form: dense(results[names[form]], n) for form in ("dense", "compact", "plain")}
    pressed = np.asarray(scene.pressed)
    base = timings[names["plain"]].median_s

    # The sample's reference on the sample and on every row the search finds (untimed).
    found_rows = np.flatnonzero(np.asarray(contacts["dense"].found))
    checked = np.union1d(rows, found_rows)
    reference = reference_sample(checked)
    scale = float(np.abs(np.asarray(x, np.float64)).max())
    checks = {}
    for form in ("dense", "compact"):
        contact = contacts[form]
        checks[form] = [pressed_check(contact, pressed), found_info(contact)]
        checks[form].append(overflow_check(contact))
        if form == "compact":
            checks[form].append(against("= the dense form", contact, contacts["dense"]))
        if dense_reference:
            checks[form].append(against("= all_to_all", contact, results[names["exhaustive"]]))
        sampled, wrong = against_sample(contact, x, checked, reference, radius, scale)
        checks[form].append(sampled)
        if len(wrong):
            notes.append(
                f"{title}: {form} rows that differ from all_to_all in float64: "
                f"{wrong[:20].tolist()} (reproduce: `curling_chip({num_nodes})`, "
                "`sampled_reference` of benchmarks/costs.py on those rows)."
            )
    out = [
        row(
            title,
            names[form],
            timings[names[form]],
            timings[names[form]].median_s / base,
            checks[form],
            feature="self-contact, over the plain search",
            series={"dense": DENSE, "compact": COMPACT}[form],
        )
        for form in ("dense", "compact")
    ]
    own = [info("found", f"{int(contacts['plain'].found.sum())} (own segments)")]
    out.append(row(title, names["plain"], timings[names["plain"]], 1.0, own))
    if dense_reference:
        name = names["exhaustive"]
        exhaustive_checks = [pressed_check(results[name], pressed), found_info(results[name])]
        out.append(
            row(
                title,
                name,
                timings[name],
                timings[name].median_s / base,
                exhaustive_checks,
                feature="self-contact, over the plain search",
                series=EXHAUSTIVE,
            )
        )
        name = names["exhaustive plain"]
        rule = timings[names["exhaustive"]].median_s / timings[name].median_s
        plain_checks = [
            info("found", f"{int(results[name].found.sum())} (own segments)"),
            info("self-contact all_to_all / this", f"{rule:.1f}x"),
        ]
        out.append(row(title, name, timings[name], timings[name].median_s / base, plain_checks))
    else:
        notes.append(
            f"{title}: `all_to_all` not run ({n:,} x {m:,} = {n * m:.1e} pairs > "
            f"{DENSE_PAIRS:.0e})."
        )
    name = names["sample"]
    per_slave = timings[name].median_s / len(rows)
    extrapolated = per_slave * n
    sample_info = [
        info("time per slave", f"{per_slave * 1e3:.3f} ms"),
        info(
            f"extrapolated to all {n:,}", f"{extrapolated:.1f} s ({extrapolated / base:.0f}x plain)"
        ),
        info("checked rows", f"the sample and the {len(found_rows)} found rows"),
    ]
    out.append(
        row(title, name, timings[name], timings[name].median_s / base, sample_info, compile_s=None)
    )
    ratio = timings[names["dense"]].median_s / base
    compact_ratio = timings[names["compact"]].median_s / base
    notes.append(
        f"{title}: self-contact / plain = {ratio:.2f}x dense, {compact_ratio:.2f}x compact "
        f"(target <= 2x). Allocation (host, untimed above): "
        + ", ".join(f"{label} {seconds:.1f} s" for label, seconds in allocated.items())
        + f". Sizes of the plain search: {cells(sizes['plain'])} (cell edge "
        f"{sizes['plain'].cell_size / radius:.0f} r); the self-contact search's: "
        f"{cells(sizes['self-contact dense'])}."
    )
    return out


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
    """Two blocks pressed together: one ``Search.closest`` over the union with ``slave_body``,
    against two searches (each body against the other's outline) and ``all_to_all``."""
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

    names = [
        "one Search.closest over the union (slave_body)",
        "two Search.closest, each body against the other's outline",
        "all_to_all with the labels",
    ]
    calls = {
        names[0]: (jax.jit(one_call), (union_state, x, surface, scene.slave_body)),
        names[1]: (jax.jit(two_searches), (states, x, segments0, segments1)),
    }
    if count * m <= DENSE_PAIRS:
        calls[names[2]] = (jax.jit(exhaustive), (x, surface, scene.slave_body))
    timings, results = timed(calls, repeats, warmup)
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
    answers = {names[0]: union, names[1]: pair}
    checks = {
        name: [pressed_check(contact, pressed), found_info(contact), overflow_check(contact)]
        for name, contact in answers.items()
    }
    checks[names[0]].append(against("= the two searches", union, pair))
    if names[2] in calls:
        reference = results[names[2]]
        checks[names[0]].append(against("= all_to_all", union, reference))
        checks[names[1]].append(against("= all_to_all", pair, reference))
        checks[names[2]] = [pressed_check(reference, pressed), found_info(reference)]
    series = {names[0]: DENSE, names[2]: EXHAUSTIVE}
    out = [
        row(
            title,
            name,
            timings[name],
            timings[name].median_s / base,
            checks[name],
            feature="two bodies in one call, over two searches",
            series=series.get(name),
        )
        for name in calls
    ]
    one, first, second = (state.sizes["closest"] for state in (union_state, *states))
    blocks = -(-count // one.block_size)
    notes.append(
        f"{title}: one call / two searches = {timings[names[0]].median_s / base:.2f}x. "
        f"Blocks of {one.block_size} rows kept: one call {one.block_capacity} of {blocks} "
        "(every node lies on its own outline, so the broad phase keeps every block and the "
        "pair rule is left to the narrow phase), "
        f"two searches {first.block_capacity} + {second.block_capacity}. "
        f"Cells: one call {cells(one)}; two searches {cells(first)} "
        f"and {cells(second)}: each search's grid spans only its kept slaves (a thin "
        "band along the contact), and the other body's segments outside it are clamped into "
        "the edge cells (`_cells.cell_of`), so the slaves near the corners search those cells."
    )
    return out


def radius_part(num_nodes: int, repeats: int, warmup: int, rng, notes):
    """The cutting scene: ``Search(radius=0.1).closest`` with a radius per slave over the
    same call with a traced scalar radius, ``all_to_all`` with the radii the reference; and
    the traces of the jitted steps counted over calls with new radii."""
    scene = cutting_scene(num_nodes, TIP)
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
    names = [
        "Search(radius=0.1).closest(radius=r), r f[N] in [0.05, 0.1]",
        "Search(radius=0.1).closest(radius=0.1), traced scalar",
        "all_to_all(radius=r), r f[N]",
    ]
    calls = {
        names[0]: (per_slave_jit, (state, x, surface, r)),
        names[1]: (scalar_jit, (state, x, surface, tenth)),
        names[2]: (jax.jit(exhaustive), (x, surface, r)),
    }
    timings, results = timed(calls, repeats, warmup)
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
    checks = [
        [
            against("= all_to_all(r)", by_rank, reference),
            found_info(by_rank),
            overflow_check(by_rank),
            check("new radii compile nothing", after["f[N]"] == 0, f"{after['f[N]']} retraces"),
        ],
        [
            against("= all_to_all(0.1)", at_tenth, scalar_reference),
            found_info(at_tenth),
            overflow_check(at_tenth),
            check("new radii compile nothing", after["scalar"] == 0, f"{after['scalar']} retraces"),
        ],
        [found_info(reference)],
    ]
    out = [
        row(
            title,
            name,
            timings[name],
            timings[name].median_s / base,
            found,
            feature="a radius per slave, over a scalar radius",
            series=series,
        )
        for name, found, series in zip(names, checks, (DENSE, None, EXHAUSTIVE), strict=True)
    ]
    notes.append(
        f"{title}: after the compile (1 trace each), 4 calls with new f[N] radii traced "
        f"{after['f[N]']} more times and 4 with new scalar radii {after['scalar']}: "
        f"{'a new radius compiles nothing' if not any(after.values()) else 'RETRACED'}."
    )
    return out


# -- friction: the steps ---------------------------------------------------------


def make_step(search: Search, forces: str, num_slaves: int):
    """``step(carry, x, surface, pairing) -> (carry, out)``: one simulation step.

    ``carry`` is the state (and the ``Friction`` for Coulomb); ``out`` the
    contact, the ``Forces`` and, with tracking, the ``Slip``.
    """

    def step(carry, x, surface, pairing):
        state, friction = carry if forces == "coulomb" else (carry, None)
        contact, state = search.closest(state, x, surface, **pairing)
        slip = state.slip  # None without tracking
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


# -- friction: checks ------------------------------------------------------------


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


def same_rows(contact, other) -> bool:
    return np.array_equal(contact.segment, other.segment) and np.array_equal(
        contact.found, other.found
    )


def step_checks(out, plain, dense_plain, first, frames, surface, num_rows, compact) -> list:
    """The checks of one variant's second step ``out`` against the plain variant's."""
    contact, pushed, slip = dense(out[0], num_rows), out[1], out[2]
    contact, plain = host(contact), host(plain)
    found = [check("segments = plain", same_rows(contact, plain), "segment and found per row")]
    if compact and dense_plain is not None:
        same = same_rows(contact, host(dense_plain))
        found.append(check("= the dense form", same, "segment and found per row"))
    if not np.array_equal(contact.gap, plain.gap):
        both = contact.found & plain.found
        worst = np.abs(contact.gap.astype(np.float64) - plain.gap)[both].max(initial=0.0)
        changed = int(np.sum(contact.active != plain.active))
        found.append(info("gap change", f"up to {worst:.1e}, active changed on {changed} rows"))
    found.append(found_info(contact))
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
        found += [
            check(
                "slip and anchors finite",
                finite,
                f"largest slip {np.abs(slip.slip).max(initial=0):.2e}",
            ),
            info("persisted", f"{int(slip.persisted.sum())}"),
            check(
                "slip = the host's on one segment",
                error <= SLIP_TOLERANCE,
                f"{int(rows.sum())} rows, max error {error:.1e}",
            ),
            check(
                "slip = the host's walk",
                walk_error <= SLIP_TOLERANCE,
                f"{int(walked.sum())} of the {moved} rows that changed segment, "
                f"max error {walk_error:.1e}",
            ),
        ]
    balance = force_balance(pushed)
    found.append(
        check("forces balance", balance <= FORCE_TOLERANCE, f"sum {balance:.1e} of magnitude")
    )
    if len(out) == 4:  # Coulomb: its normal part against the penalty's
        friction = host(out[3])
        reference = host(penalty(out[0], surface, STIFFNESS, num_slaves=num_rows))
        f = np.asarray(pushed.on_slaves, np.float64)
        normal = np.asarray(contact.normal, np.float64)
        along = np.sum(f * normal, axis=-1)
        want = np.sum(np.asarray(reference.on_slaves, np.float64) * normal, axis=-1)
        scale = max(np.abs(want).max(initial=0.0), 1e-30)
        normal_error = np.abs(along - want).max(initial=0) / scale
        tangential = np.abs(normal[:, 0] * f[:, 1] - normal[:, 1] * f[:, 0])
        over = int(np.sum(tangential > MU * np.maximum(along, 0) * (1 + 1e-5) + 1e-6 * scale))
        least = float(friction.dissipated.min(initial=0))
        found += [
            check(
                "normal part = penalty's",
                normal_error <= FORCE_TOLERANCE,
                f"to {normal_error:.1e} of the largest",
            ),
            check("|f_t| <= mu f_n", over == 0, f"over on {over} rows"),
            check("dissipation >= 0", least >= 0, f"least {least:.1e}"),
            info(
                "stuck",
                f"{int(friction.stuck.sum())}, sliding "
                f"{int(np.sum(contact.active & ~friction.stuck))}",
            ),
        ]
    found.append(overflow_check(contact))
    return found


# -- friction: one scene ---------------------------------------------------------


def scene_part(title, frames, radius, compact, pairing, repeats, warmup, contacts, notes, moved=""):
    """Times the five variants of one scene round-robin; returns the rows and the plain
    variant's two fresh steps (the pieces' inputs)."""
    (x0, surface0), (x1, surface1) = frames
    num_rows = x0.shape[0]
    # One allocation for both frames; each variant starts its own state with those sizes.
    start = time.perf_counter()
    sizing = Search(radius=radius, compact=compact)
    allocated = sizing.allocate(x0, surface0, **pairing)
    sizes = sizing.allocate(x1, surface1, at_least=allocated, **pairing).sizes
    allocate_s = time.perf_counter() - start
    calls, compiles, steps, fresh = {}, {}, {}, {}
    for name, (keywords, forces, _) in VARIANTS.items():
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
    dense_plain = contacts.get(title)
    if not compact:
        contacts[title] = plain
    base = timings[PLAIN].median_s
    form = "compact" if compact else "dense"
    notes.append(
        f"{title}, {form}"
        + f" ({moved})" * bool(moved)
        + f": allocated (host, untimed) in {allocate_s:.1f} s: "
        f"{sizes.block_capacity} blocks of {sizes.block_size} rows kept, {cells(sizes)}"
        + f", {sizes.contact_capacity} entries" * compact
        + ". Over plain: "
        + ", ".join(
            f"{name.split(':')[0]} {(timings[name].median_s - base) * 1e3:+.2f} ms"
            for name in list(VARIANTS)[1:]
        )
        + "."
    )
    rows = []
    for name, (_, _, feature) in VARIANTS.items():
        first, second = results[name]
        checks = step_checks(second, plain, dense_plain, first, frames, surface1, num_rows, compact)
        entry = row(
            title,
            name,
            timings[name],
            timings[name].median_s / base,
            checks,
            compile_s=compiles[name],
            feature=feature,
            series=(COMPACT if compact else DENSE) if feature else None,
        )
        rows.append({**entry, "form": form})
    return rows, results[PLAIN]


def pieces_part(frames, compact, plain_results, repeats, warmup):
    """The pieces the variants add, each jitted alone on the plain variant's contact of the
    second step: ``(piece, Timing)`` pairs, the floor of one jitted call first."""
    (x0, _), (x1, surface1) = frames
    num_rows = x0.shape[0]
    first, second = plain_results
    before, now = first[0], second[0]
    history = _track.history_of(before, num_rows)
    slip = _track.track(history, now, surface1)
    friction = Friction.zeros(num_rows, x0.dtype)
    corner = _normals.CORNER_DEGREES

    def segments_of(surface):
        return resolve_segments(check_surface(surface, x0.dtype))

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
    return list(time_interleaved(calls, repeats=repeats, warmup=warmup).items())


# -- friction: the scenes ----------------------------------------------------------


def cutting_frames(num_nodes: int):
    """The cutting scene and the grid moved ``CUT_SHIFT`` in x (the cutting direction)."""
    scene = cutting_scene(num_nodes, TIP)
    x0 = scene.x
    x1 = x0.at[:, 0].add(CUT_SHIFT)
    title = f"cutting scene, {x0.shape[0]:,} nodes, R = {scene.radius:g}"
    moved = f"every node moved {CUT_SHIFT:g} in x"
    return title, ((x0, scene.surface), (x1, scene.surface)), scene.radius, {}, moved


def chip_frames(num_nodes: int):
    """The curling chip and the chip moved ``CHIP_SHIFT`` node spacings in x, its master
    moving with it; every node a slave, with the self-contact rule."""
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
    title = f"curling chip, {x0.shape[0]:,} nodes, r = {scene.radius:.3g}, self-contact"
    moved = f"{int(chip.sum()):,} chip nodes moved {CHIP_SHIFT:g} h"
    return (
        title,
        tuple(frames),
        scene.radius,
        {"pairs": Pairs(scene.slave_node, self_contact=True)},
        moved,
    )


FRAMES = {"cutting": cutting_frames, "chip": chip_frames}


def ms(seconds) -> float:
    return round(seconds * 1e3, 4)


def spread(timing) -> tuple:
    """A timing's ``median ms``, ``p10 ms`` and ``p90 ms`` cells, the columns every table has."""
    return ms(timing.median_s), ms(timing.p10_s), ms(timing.p90_s)


def bodies_table(rows, repeats: int, warmup: int) -> dict:
    """The bodies' rows: time, its ratio to the part's comparator, compile, the checks."""
    columns = (
        "scene",
        "method",
        "median ms",
        "p10 ms",
        "p90 ms",
        "× comparator",
        "compile s",
        "answer",
    )
    cells = [
        (
            entry["scene"],
            entry["method"],
            *spread(entry["timing"]),
            round(entry["ratio"], 3),
            None if entry["compile"] is None else round(entry["compile"], 2),
            verdict(entry["checks"]),
        )
        for entry in rows
    ]
    note = (
        f"Float32; median of {repeats} interleaved rounds per part after {warmup} warm-up "
        "runs, compile apart. `× comparator`: the median over that of the part's comparator: "
        "the plain `Search.closest` (curling chip), the two searches (two blocks), the traced "
        "scalar radius (cutting scene). `answer`: the row's checks (the record's "
        "`data.checks` says each in words)."
    )
    return report.table(
        columns, cells, title="Self-contact, two bodies, a radius per slave", note=note
    )


def steps_table(rows, repeats: int, warmup: int) -> dict:
    columns = (
        "scene",
        "form",
        "variant",
        "median ms",
        "p10 ms",
        "p90 ms",
        "× plain",
        "compile s",
        "answer",
    )
    cells = [
        (
            entry["scene"],
            entry["form"],
            entry["method"],
            *spread(entry["timing"]),
            round(entry["ratio"], 3),
            round(entry["compile"], 2),
            verdict(entry["checks"]),
        )
        for entry in rows
    ]
    note = (
        f"Float32; median of {repeats} interleaved rounds per scene and form after {warmup} "
        "warm-up steps, compile apart; each step called with the carry it returned last, on "
        "frames alternating `x0, x1`. `× plain`: the median over that of `Search.closest` + "
        "`penalty` on the same scene and form. Checks on two fresh steps (`x0`, then `x1`). "
        f"Stiffness {STIFFNESS:g}, tangent stiffness {TANGENT_STIFFNESS:g}, "
        f"mu {MU:g}; the cutting frames moved {CUT_SHIFT:g} in x; states "
        "allocated for both frames, no skin."
    )
    return report.table(
        columns,
        cells,
        title="Slip tracking, Coulomb friction and smooth normals: one step",
        note=note,
    )


def pieces_table(pieces) -> dict:
    columns = (
        "scene",
        "form",
        "piece",
        "median ms",
        "p10 ms",
        "p90 ms",
        "× plain step",
        "compile s",
    )
    cells = [
        (
            piece["scene"],
            piece["form"],
            piece["piece"],
            *spread(piece["timing"]),
            round(piece["timing"].median_s / piece["plain_s"], 3),
            round(piece["timing"].compile_s, 2),
        )
        for piece in pieces
    ]
    note = (
        "Where the extra time goes: each piece jitted alone on the plain variant's contact of "
        "the second step. `× plain step`: over the plain variant's median; a piece alone pays "
        "the floor of one jitted call, inside the step it does not."
    )
    return report.table(columns, cells, title="The pieces the friction variants add", note=note)


def short(scene: str) -> str:
    """A scene's name and size, without its radius and the rest."""
    return ", ".join(scene.split(", ")[:2])


def figure_points(rows) -> list[dict]:
    """The figure's points: a row's scene (name and size), feature, series (a
    ``style.STYLES`` name) and ratio, for every row that has a series."""
    return [
        {
            "scene": short(entry["scene"]),
            "feature": entry["feature"],
            "series": entry["series"],
            "ratio": round(entry["ratio"], 4),
        }
        for entry in rows
        if entry["series"]
    ]


def run(args) -> dict:
    plan = QUICK if args.quick else FULL
    repeats, warmup = args.repeats or (5 if args.quick else 20), args.warmup
    rng = np.random.default_rng(args.seed)
    start = time.perf_counter()
    notes, bodies, steps, pieces, contacts = [], [], [], [], {}

    def friction(frames_of, num_nodes, forms, with_pieces):
        title, frames, radius, pairing, moved = FRAMES[frames_of](num_nodes)
        for compact in forms:
            found, plain = scene_part(
                title, frames, radius, compact, pairing, repeats, warmup, contacts, notes, moved
            )
            steps.extend(found)
            if with_pieces:
                form, plain_s = found[0]["form"], found[0]["timing"].median_s
                pieces.extend(
                    {"scene": title, "form": form, "piece": name, "timing": t, "plain_s": plain_s}
                    for name, t in pieces_part(frames, compact, plain, repeats, warmup)
                )

    # The sample's rows, then the radii: drawn from one generator in this order.
    parts = [
        *(
            lambda n=n: bodies.extend(
                self_contact_part(n, plan["sample"], repeats, warmup, rng, notes)
            )
            for n in plan["chips"]
        ),
        lambda: bodies.extend(bodies_part(plan["blocks"], repeats, warmup, notes)),
        lambda: bodies.extend(radius_part(plan["cutting"], repeats, warmup, rng, notes)),
        *(lambda scene=scene: friction(*scene) for scene in plan["friction"]),
    ]
    for part in _run.progress(parts, "costs"):
        part()

    notes.append(f"Whole run {time.perf_counter() - start:.0f} s.")
    checks = [
        {"scene": e["scene"], "form": e.get("form"), "method": e["method"], "checks": e["checks"]}
        for e in bodies + steps
    ]
    return {
        "title": TITLE,
        "tables": [
            bodies_table(bodies, repeats, warmup),
            steps_table(steps, repeats, warmup),
            pieces_table(pieces),
        ],
        "data": {
            "checks": checks,
            "figure": {"bodies": figure_points(bodies), "friction": figure_points(steps)},
            "repeats": repeats,
            "warmup": warmup,
            "seed": args.seed,
        },
        "notes": notes,
    }


PANELS = (
    ("bodies", "Self-contact, two bodies in one call, a radius per slave (one search)"),
    ("friction", "Slip tracking, Coulomb friction, smooth normals (one step)"),
)
XLABELS = {
    "bodies": "time over the comparator's",
    "friction": "time over the plain step's (Search.closest + penalty), same scene and form",
}
NICE = (0.1, 0.2, 0.25, 0.5, 0.75, 1, 1.25, 1.5, 2, 3, 5, 10, 20, 50, 100, 200, 500, 1000)


def ratio_ticks(axis, low: float, high: float) -> None:
    """Labelled ticks at round ratios between ``low`` and ``high`` (1-2-5 past a decade)."""
    from matplotlib.ticker import FixedLocator, NullFormatter, StrMethodFormatter

    shown = [t for t in NICE if low <= t <= high]
    if high / low > 10:
        shown = [t for t in shown if round(t / 10 ** math.floor(math.log10(t)), 6) in (1, 2, 5)]
    axis.set_major_locator(FixedLocator(shown))
    axis.set_major_formatter(StrMethodFormatter("{x:g}"))
    axis.set_minor_formatter(NullFormatter())


def draw(record, plt):
    """Each feature's time over its comparator's, per scene: a dot per form of the search
    (and ``all_to_all`` doing the same job), log scale; a scene's name heads its"""
    points = record["data"]["figure"]
    layouts = {}
    for key, _ in PANELS:
        labels, at = [], {}
        for scene in dict.fromkeys(p["scene"] for p in points[key]):
            labels.append((scene, True))
            for feature in dict.fromkeys(p["feature"] for p in points[key] if p["scene"] == scene):
                at[scene, feature] = len(labels)
                labels.append((feature, False))
        layouts[key] = labels, at
    counts = [max(2, len(layouts[key][0])) for key, _ in PANELS]
    # At the dpi the PNG is written at (report.save_figure): tight_layout then measures the
    # tick labels as they are drawn (text does not scale exactly with the dpi).
    figure, panels = plt.subplots(
        2,
        1,
        figsize=(9.5, 1.6 + 0.3 * sum(counts)),
        dpi=120,
        gridspec_kw={"height_ratios": counts},
    )
    used = {}
    for axes, (key, title) in zip(panels, PANELS, strict=True):
        labels, at = layouts[key]
        top = len(labels) - 1
        for series in dict.fromkeys(p["series"] for p in points[key]):
            mine = [p for p in points[key] if p["series"] == series]
            looks = {**style.style(series, used), "linestyle": "none", "markersize": 7}
            y = [top - at[p["scene"], p["feature"]] for p in mine]
            axes.plot([p["ratio"] for p in mine], y, label=series, zorder=3, **looks)
        axes.axvline(1.0, color="#888888", linewidth=0.8, zorder=1)
        for k, (_, heading) in enumerate(labels):
            if heading and k:
                axes.axhline(top - k + 0.5, color="#cccccc", linewidth=0.8, zorder=0)
        axes.set_yticks([top - k for k in range(len(labels))], [text for text, _ in labels])
        for tick, (_, heading) in zip(axes.get_yticklabels(), labels, strict=True):
            tick.set_fontweight("bold" if heading else "normal")
            tick.set_fontsize(7.5)
        axes.tick_params(axis="y", length=0)
        axes.set_ylim(-0.6, top + 0.6)
        axes.set_xscale("log")
        ratios = [p["ratio"] for p in points[key]] or [1.0]
        low, high = min(0.8, min(ratios) / 1.2), max(1.25, max(ratios) * 1.2)
        axes.set_xlim(low, high)
        ratio_ticks(axes.xaxis, low, high)
        axes.grid(axis="x", which="major", color="#eeeeee", linewidth=0.6)
        axes.set_xlabel(XLABELS[key], fontsize=8)
        axes.set_title(title, fontsize=9.5)
    style.legend_outside(panels[0], "right")
    figure.suptitle(record["title"], fontsize=11)
    return figure


if __name__ == "__main__":
    sys.exit(_run.suite("costs", run, draw, __doc__.splitlines()[0], options=OPTIONS))
