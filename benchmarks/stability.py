"""Stability study: how far jaxcontact's answers are from the exact ones, and where.

Every reference value comes from the exact rational oracle of the test suite
(``tests/oracle.py``, ``fractions.Fraction``) evaluated on the very inputs the
library sees (already rounded to float32 or float64), so an error here is the
library's rounding alone. Four studies, each in float32 and float64:

1. gap error against the coordinates' offset from the origin (unit segment,
   slaves within 0.5 of it, the whole scene shifted by 0 .. 1e7);
2. gap error against the segment length (1e-9 .. 1) for slaves about a unit
   away, in absolute terms and in ulps of the local scale |x - a| + |b - a|;
3. crossing-time error against the angle between path and segment
   (1e-8 .. pi/2 rad), against the conditioning bound eps / sin(angle);
4. the rate of segment choices that differ from the oracle's near a tie
   (slaves at a relative distance delta from the bisector of a corner, or from
   the midline between two parallel faces), and how many of those are NOT
   explained by the float bound (the oracle's two distances differing by
   more than it): that count must be zero.

Writes one CSV per study and one PNG per study into ``--out`` (default
``benchmarks/out/stability/``) and prints markdown tables.

    python benchmarks/stability.py            # the full study (a few minutes)
    python benchmarks/stability.py --quick    # fewer samples, a smoke test
"""

from __future__ import annotations

import argparse
import csv
import math
import pathlib
import sys

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402

import jaxcontact  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the repo root: tests.oracle, benchmarks.*
from tests import oracle  # noqa: E402

DTYPES = {"float32": np.float32, "float64": np.float64}
ULPS = 8  # the constant of the bounds the property tests assert (tests/test_properties.py)

contact = jax.jit(lambda x, s: jaxcontact.all_to_all(x, s, radius=1e30))
crossing = jax.jit(jaxcontact.swept)


def _surface(nodes, segments, dtype):
    return jaxcontact.Surface(
        jnp.asarray(np.asarray(nodes, dtype)), jnp.asarray(np.asarray(segments, np.int32))
    )


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


def study_offset(rng, samples):
    rows = []
    for name, dtype in DTYPES.items():
        for offset in [0.0] + [10.0**k for k in range(0, 8)]:
            errors, scales = [], []
            for _ in range(samples):
                x, nodes = _unit_segment(rng, 64)
                error, scale = _gap_errors(x + offset, nodes + offset, [[0, 1]], dtype)
                errors.append(error)
                scales.append(scale)
            error, scale = np.concatenate(errors), np.concatenate(scales)
            eps = float(np.finfo(dtype).eps)
            rows.append(
                {
                    "dtype": name,
                    "offset": offset,
                    "max_gap_error": float(np.nanmax(error)),
                    "max_error_in_eps_of_scale": float(np.nanmax(error / (eps * scale))),
                    "bound_in_eps_of_scale": ULPS,
                    # What rounding the inputs to the dtype costs, before any
                    # arithmetic: the geometry itself moves by this much.
                    "input_rounding": float(np.spacing(dtype(offset))) / 2,
                }
            )
    return rows


def study_length(rng, samples):
    rows = []
    for name, dtype in DTYPES.items():
        eps = float(np.finfo(dtype).eps)
        for exponent in range(-9, 1):
            length = 10.0**exponent
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
            row = {"dtype": name, "length": length, "collapsed": collapsed}
            if errors:
                error, scale = np.concatenate(errors), np.concatenate(scales)
                row.update(
                    max_gap_error=float(np.nanmax(error)),
                    max_error_in_eps_of_scale=float(np.nanmax(error / (eps * scale))),
                )
            else:
                row.update(max_gap_error=math.nan, max_error_in_eps_of_scale=math.nan)
            rows.append(row)
    return rows


def study_angle(rng, samples):
    rows = []
    for name, dtype in DTYPES.items():
        eps = float(np.finfo(dtype).eps)
        for exponent in [-8, -7, -6, -5, -4, -3, -2, -1, 0]:
            angle = min(10.0**exponent, np.pi / 2)
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
                    "angle": angle,
                    "max_t_error": float(error.max()) if error.size else math.nan,
                    "max_error_in_eps_of_conditioning": float(np.max(error / (eps * conditioning)))
                    if error.size
                    else math.nan,
                    "eps_over_sin_angle": eps / math.sin(angle),
                    "decisions_differing": missed,
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


def study_ties(rng, samples):
    rows = []
    for name, dtype in DTYPES.items():
        eps = float(np.finfo(dtype).eps)
        for kind in ("corner", "parallel"):
            for exponent in range(-16, -1, 2):
                delta = 10.0**exponent
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
                        unexplained += abs(d[0] - d[1]) > bound
                rows.append(
                    {
                        "dtype": name,
                        "tie": kind,
                        "delta": delta,
                        "wrong_choice_rate": wrong / total,
                        "unexplained": unexplained,
                    }
                )
    return rows


# Printed with the tables, so that RESULTS.md (benchmarks/results.py) says
# what each one measured; what the figures mean is in benchmarks/results/notes.md.
INTRO = """Every reference value comes from the exact rational oracle of the test
suite (`tests/oracle.py`, `fractions.Fraction`) evaluated on the very inputs
the library sees (already rounded to float32 or float64), so an error here is
the library's arithmetic alone. The figures are not timings: seeded and
exact, they are the same on any machine. "scale" is `|x - a| + |b - a|` for
the chosen segment, the length the error is made of; the property tests
assert `|gap - exact| <= 8 eps scale`."""
STUDIES = {
    "offset": (
        "Gap error against the coordinates' offset",
        "A unit segment at a random angle, 64 slaves within 0.5 of it, the scene shifted by "
        "`offset` (`all_to_all`; `bucket_sort` evaluates the same kernel on the same pair). "
        "`input_rounding` is half an ulp of the offset: what rounding the inputs costs.",
    ),
    "length": (
        "Gap error against the segment length",
        "Segments of length 1e-9 to 1, slaves about a unit away; `collapsed` counts the "
        "segments that round to a point (and are then ignored, as zero-length segments are).",
    ),
    "angle": (
        "Crossing time against the angle between path and segment",
        "Paths of length 1 crossing a unit segment at an angle of 1e-8 to 1 rad, against the "
        "conditioning `eps / sin(angle)` (dotted in the plot); a differing crossed/not-crossed "
        "decision is explained when an orientation test lies within its rounding of zero "
        "(`unexplained` counts the others).",
    ),
    "ties": (
        "Segment choices near a tie",
        "Slaves at a relative distance delta from an exact tie: the bisector of a corner (faces "
        "meeting at 33 degrees) or the midline between two parallel faces, shifted by up to 2 "
        "from the origin. `unexplained` counts choices that differ from the oracle's although "
        "the two exact distances differ by more than the float bound (2 x 8 eps scale).",
    ),
}


def _write_csv(rows, path):
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _table(rows):
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for row in rows:
        cells = [f"{v:.3g}" if isinstance(v, float) else str(v) for v in row.values()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _plot(rows, x_key, y_keys, path, title, xlabel, ylabel, group="dtype", log_y=True):
    """One line per ``group`` and ``y_keys`` entry; an entry whose format has no marker (a
    bound) drawn as that group's guide. Looks from ``benchmarks.harness.style``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from benchmarks.harness import style

    figure, axes = plt.subplots(figsize=(8, 4), layout="constrained")
    used = {}
    for label in sorted({row[group] for row in rows}):
        mine = [row for row in rows if row[group] == label]
        for y_key, fmt in y_keys:
            bound = not any(marker in fmt for marker in "os^vD*+x.")
            looks = style.style(f"{label.split()[0]} bound" if bound else label, used)
            xs = [max(row[x_key], 1e-1) if x_key == "offset" else row[x_key] for row in mine]
            ys = [max(row[y_key], 1e-20) if log_y else row[y_key] for row in mine]
            axes.plot(xs, ys, **looks, label=f"{label}: {y_key}", clip_on=log_y)
    axes.set_xscale("log")
    if log_y:
        axes.set_yscale("log")
    else:
        axes.set_ylim(bottom=0)  # a rate: 0 and up, the zeros on the axis, no negative tick
    if x_key == "offset":  # 0 drawn at 0.1, labelled 0
        style.log_axis_from_zero(axes.xaxis, 0.1, max(row[x_key] for row in rows))
        xlabel = xlabel.replace(" (0 drawn at 0.1)", "")
    axes.set_title(title)
    axes.set_xlabel(xlabel)
    axes.set_ylabel(ylabel)
    axes.grid(True, which="major", alpha=0.3)
    style.legend_outside(axes)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples: a smoke test")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "stability"))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    samples = 2 if args.quick else 16
    rng = np.random.default_rng(args.seed)

    studies = {
        "offset": study_offset(rng, samples),
        "length": study_length(rng, samples),
        "angle": study_angle(rng, samples),
        "ties": study_ties(rng, samples),
    }
    print(INTRO)
    for name, rows in studies.items():
        _write_csv(rows, out / f"stability_{name}.csv")
        title, method = STUDIES[name]
        picture = f"![{title}](stability_{name}.png)"
        print(f"\n### {title}\n\n{method}\n\n{picture}\n\n{_table(rows)}")
    _plot(studies["offset"], "offset", [("max_gap_error", "o-")], out / "stability_offset.png",
          "Gap error against coordinate offset (unit segment)", "offset (0 drawn at 0.1)",
          "max |gap - exact|")  # fmt: skip
    _plot(studies["length"], "length", [("max_gap_error", "o-")], out / "stability_length.png",
          "Gap error against segment length (slaves ~1 away)", "segment length",
          "max |gap - exact|")  # fmt: skip
    _plot(studies["angle"], "angle", [("max_t_error", "o-"), ("eps_over_sin_angle", "k:")],
          out / "stability_angle.png", "Crossing-time error against path-segment angle",
          "angle (rad)", "max |t - exact|")  # fmt: skip
    ties = [dict(row, group=f"{row['dtype']} {row['tie']}") for row in studies["ties"]]
    _plot(ties, "delta", [("wrong_choice_rate", "o-")], out / "stability_ties.png",
          "Segment choices differing from the exact oracle near a tie",
          "relative distance from the tie", "rate", group="group", log_y=False)  # fmt: skip
    print(f"\nCSV and PNG files in {out}")


if __name__ == "__main__":
    main()
