"""The cost of bodies and friction: each feature's time beside the plain search's.

Self-contact, several bodies in one call, a radius per slave, slip tracking, Coulomb
friction and smooth normals.

Float32, every step jitted and compiled ahead of the runs (its compile time reported apart),
``--warmup`` untimed runs, then the median and the 10th-90th percentile of ``--repeats``
rounds, the methods of one part run round-robin in this one process
(``benchmarks.harness.timing.time_interleaved``), every call ended by ``block_until_ready``.
The measurements and their checks are ``benchmarks/harness/features.py``.

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

import numpy as np

from benchmarks.harness import _run, features, report, style

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
FRAMES = {"cutting": features.cutting_frames, "chip": features.chip_frames}
OPTIONS = (
    (("--warmup",), {"type": int, "default": 2, "help": "untimed runs of each first"}),
    (("--seed",), {"type": int, "default": 0, "help": "the sample and the radii"}),
)


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
            features.verdict(entry["checks"]),
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
            features.verdict(entry["checks"]),
        )
        for entry in rows
    ]
    note = (
        f"Float32; median of {repeats} interleaved rounds per scene and form after {warmup} "
        "warm-up steps, compile apart; each step called with the carry it returned last, on "
        "frames alternating `x0, x1`. `× plain`: the median over that of `Search.closest` + "
        "`penalty` on the same scene and form. Checks on two fresh steps (`x0`, then `x1`). "
        f"Stiffness {features.STIFFNESS:g}, tangent stiffness {features.TANGENT_STIFFNESS:g}, "
        f"mu {features.MU:g}; the cutting frames moved {features.CUT_SHIFT:g} in x; states "
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
            found, plain = features.scene_part(
                title, frames, radius, compact, pairing, repeats, warmup, contacts, notes, moved
            )
            steps.extend(found)
            if with_pieces:
                form, plain_s = found[0]["form"], found[0]["timing"].median_s
                pieces.extend(
                    {"scene": title, "form": form, "piece": name, "timing": t, "plain_s": plain_s}
                    for name, t in features.pieces_part(frames, compact, plain, repeats, warmup)
                )

    # The sample's rows, then the radii: drawn from one generator in this order.
    parts = [
        *(
            lambda n=n: bodies.extend(
                features.self_contact_part(n, plan["sample"], repeats, warmup, rng, notes)
            )
            for n in plan["chips"]
        ),
        lambda: bodies.extend(features.bodies_part(plan["blocks"], repeats, warmup, notes)),
        lambda: bodies.extend(features.radius_part(plan["cutting"], repeats, warmup, rng, notes)),
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
    (and ``all_to_all`` doing the same job), log scale; a scene's name heads its features."""
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
