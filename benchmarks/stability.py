"""Numerical stability: how far jaxcontact's answers are from the exact ones, and where.

Every reference value comes from the exact rational oracle of the test suite
(``tests/support/oracle.py``, ``fractions.Fraction``) evaluated on the very inputs the
library sees (already rounded to float32 or float64), so an error here is the
library's rounding alone. Four studies, each in float32 and float64, one panel
of the figure each:

1. gap error against the coordinates' offset from the origin (unit segment,
   slaves within 0.5 of it, the whole scene shifted by 0 .. 1e7);
2. gap error against the segment length (1e-9 .. 1) for slaves about a unit
   away, in absolute terms and in units of eps times the local scale
   |x - a| + |b - a|;
3. crossing-time error against the angle between path and segment
   (1e-8 .. 1 rad), against the conditioning bound eps / sin(angle);
4. the rate of segment choices that differ from the oracle's near a tie
   (slaves at a relative distance delta from the bisector of a corner, or from
   the midline between two parallel faces), and how many of those are NOT
   explained by the float bound (the oracle's two distances differing by
   more than it): that count must be zero.

Seeded and exact: the numbers are the same on any machine. Writes
``<out>/stability.json`` and ``<out>/stability.png`` (default ``--out
benchmarks/results``) and prints the record's markdown.

    python benchmarks/stability.py            # the full study (a few minutes)
    python benchmarks/stability.py --quick    # fewer samples, a smoke test
    taskset -c 0 python benchmarks/stability.py --out benchmarks/results/pinned
"""

from __future__ import annotations

import math
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # tests.support, benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

import jaxcontact
from benchmarks.harness import _run, report
from tests.support import oracle

DTYPES = {"float32": np.float32, "float64": np.float64}
ULPS = 8  # the constant of the bounds the property tests assert (tests/core/test_properties.py)
OFFSETS = (0.0, *(10.0**k for k in range(0, 8)))
LENGTHS = tuple(10.0**k for k in range(-9, 1))
ANGLES = tuple(min(10.0**k, np.pi / 2) for k in range(-8, 1))
DELTAS = tuple(10.0**k for k in range(-16, -1, 2))

# Table columns: the figure reads its points back from the record by these names.
ERROR = "max gap error"
IN_EPS = "max error / (eps scale)"
T_ERROR = "max t error"
T_IN_EPS = "max t error / (eps conditioning)"
BOUND = "eps / sin(angle)"
RATE = "wrong choice rate"

contact = jax.jit(lambda x, s: jaxcontact.all_to_all(x, s, radius=1e30))
crossing = jax.jit(jaxcontact.swept)


def _surface(nodes, segments, dtype):
    return jaxcontact.Surface(
        jnp.asarray(np.asarray(nodes, dtype)), jnp.asarray(np.asarray(segments, np.int32))
    )


def _largest(values) -> float | None:
    """The largest of ``values`` ignoring NaN, None when there is none (a JSON null)."""
    values = np.asarray(values, np.float64)
    values = values[~np.isnan(values)]
    return float(values.max()) if values.size else None


def _gap_errors(x, nodes, segments, dtype):
    """(|gap - exact| f64[N], local scale f64[N]) for slaves ``x`` and one surface."""
    x, nodes = np.asarray(x, dtype), np.asarray(nodes, dtype)
    got = contact(jnp.asarray(x), _surface(nodes, segments, dtype))
    exact = oracle.oracle_contact(x, nodes, segments, radius=1e30)
    # A segment that rounds to a point is no segment (segment -1): NaN rows.
    scale = np.array(
        [
            next(p.scale for p in oracle.exact_pairs(row, nodes, segments) if p.segment == k)
            if k >= 0
            else np.nan
            for row, k in zip(x, exact.segment, strict=True)
        ]
    )
    same = np.asarray(got.segment) == exact.segment
    error = np.abs(np.asarray(got.gap, np.float64) - exact.gap)
    return np.where(same, error, np.nan), scale


def _unit_segment(rng, count):
    """A unit segment at a random angle and ``count`` slaves within 0.5 of it (f64)."""
    angle = rng.uniform(0, 2 * np.pi)
    direction = np.array([np.cos(angle), np.sin(angle)])
    normal = np.array([direction[1], -direction[0]])
    a = rng.uniform(-0.5, 0.5, 2)
    along, off = rng.uniform(-0.2, 1.2, count), rng.uniform(-0.5, 0.5, count)
    x = a + along[:, None] * direction + off[:, None] * normal
    return x, np.stack([a, a + direction])


def study_offset(rng, samples, offsets=OFFSETS) -> list[dict]:
    rows = []
    for name, dtype in DTYPES.items():
        eps = float(np.finfo(dtype).eps)
        for offset in offsets:
            errors, scales = [], []
            for _ in range(samples):
                x, nodes = _unit_segment(rng, 64)
                error, scale = _gap_errors(x + offset, nodes + offset, [[0, 1]], dtype)
                errors.append(error)
                scales.append(scale)
            error, scale = np.concatenate(errors), np.concatenate(scales)
            rows.append(
                {
                    "dtype": name,
                    "offset": offset,
                    ERROR: _largest(error),
                    IN_EPS: _largest(error / (eps * scale)),
                    # What rounding the inputs to the dtype costs, before any
                    # arithmetic: the geometry itself moves by this much.
                    "input rounding": float(np.spacing(dtype(offset))) / 2,
                }
            )
    return rows


def study_length(rng, samples, lengths=LENGTHS) -> list[dict]:
    rows = []
    for name, dtype in DTYPES.items():
        eps = float(np.finfo(dtype).eps)
        for length in lengths:
            errors, scales, collapsed = [], [], 0
            for _ in range(samples):
                angle = rng.uniform(0, 2 * np.pi)
                a = rng.uniform(-0.5, 0.5, 2)
                b = a + length * np.array([np.cos(angle), np.sin(angle)])
                nodes = np.stack([a, b])
                if not np.any(nodes.astype(dtype)[0] != nodes.astype(dtype)[1]):
                    collapsed += 1  # rounds to a point: ignored, as a zero-length segment
                    continue
                x = a + rng.uniform(-1, 1, (64, 2))
                error, scale = _gap_errors(x, nodes, [[0, 1]], dtype)
                errors.append(error)
                scales.append(scale)
            error = np.concatenate(errors) if errors else np.array([])
            scale = np.concatenate(scales) if scales else np.array([])
            rows.append(
                {
                    "dtype": name,
                    "length": length,
                    "collapsed": collapsed,
                    ERROR: _largest(error),
                    IN_EPS: _largest(error / (eps * scale)),
                }
            )
    return rows


def study_angle(rng, samples, angles=ANGLES) -> list[dict]:
    rows = []
    for name, dtype in DTYPES.items():
        eps = float(np.finfo(dtype).eps)
        for angle in angles:
            errors, bounds, missed, unexplained = [], [], 0, 0
            for _ in range(samples):
                # A unit segment on the x axis, turned at random, and paths of
                # length 1 through random points of it at ``angle`` to it.
                turn = rng.uniform(0, 2 * np.pi)
                rotate = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
                hit = np.stack([rng.uniform(0.1, 0.9, 32), np.zeros(32)], -1)
                way = np.array([np.cos(angle), np.sin(angle)])
                share = rng.uniform(0.2, 0.8, 32)[:, None]
                start, end = hit - share * way, hit + (1 - share) * way
                nodes = np.array([[0.0, 0.0], [1.0, 0.0]]) @ rotate.T
                start, end = (start @ rotate.T).astype(dtype), (end @ rotate.T).astype(dtype)
                nodes = nodes.astype(dtype)
                got = crossing(
                    jnp.asarray(start), jnp.asarray(end), _surface(nodes, [[0, 1]], dtype)
                )
                exact = oracle.oracle_crossing(start, end, nodes, [[0, 1]])
                meetings = [
                    oracle.exact_meetings(s, e, nodes, [[0, 1]])[0]
                    for s, e in zip(start, end, strict=True)
                ]
                both = np.asarray(got.crossed) & exact.crossed
                differ = np.asarray(got.crossed) != exact.crossed
                missed += int(differ.sum())
                # Explained: an orientation test within its rounding of zero.
                fragile = np.array([min(m.orientations) <= ULPS * eps for m in meetings])
                unexplained += int(np.sum(differ & ~fragile))
                errors.append(np.abs(np.asarray(got.t, np.float64) - exact.t)[both])
                bounds.append(np.array([m.conditioning for m in meetings])[both])
            error, conditioning = np.concatenate(errors), np.concatenate(bounds)
            rows.append(
                {
                    "dtype": name,
                    "angle rad": angle,
                    T_ERROR: _largest(error),
                    T_IN_EPS: _largest(error / (eps * conditioning)),
                    BOUND: eps / math.sin(angle),
                    "decisions differing": missed,
                    "unexplained": unexplained,
                }
            )
    return rows


def _tie_scene(kind, delta, count, rng):
    """Slaves at relative distance ``delta`` (signed, random) from an exact tie (f64)."""
    if kind == "corner":  # faces (1, 0.3) -> (0, 0) -> (1, -0.3): the tie is the x axis
        nodes = np.array([[1.0, 0.3], [0.0, 0.0], [1.0, -0.3]])
        segments = [[0, 1], [1, 2]]
        along = rng.uniform(0.2, 0.8, count)
        x = np.stack([along, along * delta * rng.choice([-1, 1], count)], -1)
    else:  # parallel faces y = +-0.5: the tie is the midline
        nodes = np.array([[0.0, 0.5], [1.0, 0.5], [1.0, -0.5], [0.0, -0.5]])
        segments = [[0, 1], [2, 3]]
        x = np.stack([rng.uniform(0.1, 0.9, count), 0.5 * delta * rng.choice([-1, 1], count)], -1)
    shift = rng.uniform(-2, 2, 2)
    return x + shift, nodes + shift, segments


def study_ties(rng, samples, deltas=DELTAS) -> list[dict]:
    rows = []
    for name, dtype in DTYPES.items():
        eps = float(np.finfo(dtype).eps)
        for kind in ("corner", "parallel"):
            for delta in deltas:
                wrong = unexplained = total = 0
                for _ in range(samples):
                    x, nodes, segments = _tie_scene(kind, delta, 64, rng)
                    x, nodes = x.astype(dtype), nodes.astype(dtype)
                    got = contact(jnp.asarray(x), _surface(nodes, segments, dtype))
                    exact = oracle.oracle_contact(x, nodes, segments, radius=1e30)
                    differ = np.flatnonzero(np.asarray(got.segment) != exact.segment)
                    total += len(x)
                    wrong += len(differ)
                    for row in differ:
                        pairs = oracle.exact_pairs(x[row], nodes, segments)
                        d = [math.sqrt(float(p.distance_squared)) for p in pairs]
                        bound = 2 * ULPS * eps * max(p.scale for p in pairs)
                        unexplained += int(abs(d[0] - d[1]) > bound)
                rows.append(
                    {
                        "dtype": name,
                        "tie": kind,
                        "delta": delta,
                        RATE: wrong / total,
                        "unexplained": unexplained,
                    }
                )
    return rows


INTRO = (
    "Every reference value comes from the exact rational oracle of the test suite "
    "(`tests/support/oracle.py`, `fractions.Fraction`) evaluated on the very inputs the "
    "library sees (already rounded to float32 or float64), so an error here is the library's "
    'arithmetic alone. Seeded and exact: the same on any machine. "scale" is `|x - a| + |b - a|` '
    "for the chosen segment, the length the error is made of; the property tests assert "
    f"`|gap - exact| <= {ULPS} eps scale`."
)
# Study -> (table title, what it did: the table's note).
STUDIES = {
    "offset": (
        "Gap error against the coordinates' offset",
        "A unit segment at a random angle, 64 slaves within 0.5 of it, the scene shifted by "
        "`offset` (`all_to_all`; `bucket_sort` evaluates the same kernel on the same pair). "
        "`input rounding` is half an ulp of the offset: what rounding the inputs costs.",
    ),
    "length": (
        "Gap error against the segment length",
        "Segments of length 1e-9 to 1, slaves about a unit away; `collapsed` counts the "
        "segments that round to a point (and are then ignored, as zero-length segments are).",
    ),
    "angle": (
        "Crossing time against the angle between path and segment",
        "Paths of length 1 crossing a unit segment at an angle of 1e-8 to 1 rad (`swept`), "
        "against the conditioning `eps / sin(angle)`; a differing crossed/not-crossed decision "
        "is explained when an orientation test lies within its rounding of zero "
        "(`unexplained` counts the others).",
    ),
    "ties": (
        "Segment choices near a tie",
        "Slaves at a relative distance delta from an exact tie: the bisector of a corner (faces "
        "meeting at 33 degrees) or the midline between two parallel faces, shifted by up to 2 "
        f"from the origin. `unexplained` counts choices that differ from the oracle's although "
        f"the two exact distances differ by more than the float bound (2 x {ULPS} eps scale).",
    ),
}


def verdict(studies) -> str:
    """The checks in one line: every gap error within the property tests' bound, and no
    decision or choice that the float bound does not explain."""
    worst = {
        name: max(
            (
                row[IN_EPS]
                for key in ("offset", "length")
                for row in studies[key]
                if row["dtype"] == name and row[IN_EPS] is not None
            ),
            default=0.0,
        )
        for name in DTYPES
    }
    unexplained = sum(row["unexplained"] for key in ("angle", "ties") for row in studies[key])
    within = all(value <= ULPS for value in worst.values())
    largest = ", ".join(f"{value:.3g} ({name})" for name, value in worst.items())
    return (
        f"Largest gap error in units of eps scale: {largest}; "
        + (f"within the bound {ULPS}. " if within else f"**above the bound {ULPS}**. ")
        + (
            "No differing decision or segment choice is left unexplained by the float bound."
            if unexplained == 0
            else f"**{unexplained} differing decisions or choices the float bound does not "
            "explain.**"
        )
    )


def run(args) -> dict:
    """The four studies, seeded (``--seed``); ``--quick`` takes 2 samples a point, not 16."""
    if not jax.config.jax_enable_x64:
        raise RuntimeError("the float64 studies need jax_enable_x64")
    samples = 2 if args.quick else 16
    rng = np.random.default_rng(args.seed)
    studies = {
        "offset": study_offset(rng, samples, OFFSETS),
        "length": study_length(rng, samples, LENGTHS),
        "angle": study_angle(rng, samples, ANGLES),
        "ties": study_ties(rng, samples, DELTAS),
    }
    tables = [
        report.table(list(studies[name][0]), studies[name], title=title, note=note)
        for name, (title, note) in STUDIES.items()
    ]
    return {
        "title": "Numerical stability against the exact oracle",
        "tables": tables,
        "data": {"samples per point": samples, "slaves per sample": 64, "seed": args.seed},
        "notes": [INTRO, verdict(studies)],
    }


def _table(record, study: str) -> list[dict]:
    """The rows of ``study``'s table in ``record``, as dicts by column."""
    title = STUDIES[study][0]
    (found,) = [t for t in record["tables"] if t["title"] == title]
    return [dict(zip(found["columns"], row, strict=True)) for row in found["rows"]]


def draw(record, plt):
    """Four panels, one per study, drawn from the record's tables; one legend for all."""
    from benchmarks.harness import style

    figure, panels = plt.subplots(2, 2, figsize=(12, 7.5))
    (offset, length), (angle, ties) = panels
    used = {}

    def series(axes, rows, x_key, y_key, group, label=None, floor=None, clip=True):
        for name in dict.fromkeys(row[group] for row in rows):
            points = [
                (row[x_key], row[y_key])
                for row in rows
                if row[group] == name and row[y_key] is not None
            ]
            if floor is not None:  # a log axis: 0 drawn at the floor
                points = [(max(x, floor), y) for x, y in points]
            shown = label(name) if label else name
            looks = style.style(shown, used)
            axes.plot(*zip(*points, strict=True), **looks, label=shown, clip_on=clip)

    shifted = _table(record, "offset")
    series(offset, shifted, "offset", ERROR, "dtype", floor=0.1)
    series(length, _table(record, "length"), "length", ERROR, "dtype")
    rows = _table(record, "angle")
    series(angle, rows, "angle rad", T_ERROR, "dtype")
    series(angle, rows, "angle rad", BOUND, "dtype", label=lambda name: f"{name} bound")
    rows = [{**row, "series": f"{row['dtype']} {row['tie']}"} for row in _table(record, "ties")]
    series(ties, rows, "delta", RATE, "series", clip=False)  # the zeros on the axis, whole

    offset.set(xscale="log", yscale="log", xlabel="offset of the coordinates")
    style.log_axis_from_zero(offset.xaxis, 0.1, max(row["offset"] for row in shifted))
    offset.set(ylabel="max |gap - exact|", title="Gap error against offset (unit segment)")
    length.set(xscale="log", yscale="log", xlabel="segment length")
    length.set(ylabel="max |gap - exact|", title="Gap error against segment length")
    angle.set(xscale="log", yscale="log", xlabel="angle between path and segment (rad)")
    angle.set(ylabel="max |t - exact|", title="Crossing-time error against angle")
    where = {"transform": angle.transAxes, "ha": "right", "va": "top"}
    angle.text(0.97, 0.95, "dotted: eps / sin(angle)", **where, fontsize=8, color="#555555")
    ties.set(xscale="log", xlabel="relative distance from the tie", ylabel="rate")
    ties.set_ylim(bottom=0)  # a rate: 0 and up, no negative tick
    ties.set_title("Segment choices differing from the oracle near a tie")
    for axes in (offset, length, angle, ties):
        axes.grid(True, which="major", alpha=0.3)
    style.legend_outside(length)
    return figure


OPTIONS = ((("--seed",), {"type": int, "default": 0, "help": "the studies' random seed"}),)

if __name__ == "__main__":
    sys.exit(_run.suite("stability", run, draw, __doc__.splitlines()[0], options=OPTIONS))
