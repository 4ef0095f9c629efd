"""One look per method across every benchmark figure, and legends outside the data.

``STYLES`` maps each series a benchmark figure draws to a ``(colour,
marker)``. jaxcontact's own forms (``all_to_all``, the bucket sort and its
sized, compact and precision variants, ``Search``, ``swept``, the stability
study's precisions) are drawn in blues, greens, teals and purples with solid
lines and filled markers; the peers (NumPy, cKDTree, shapely, jax-md, libigl,
numba, IPC Toolkit) in reds, oranges, browns, golds and pinks with dashed
lines and open markers; guide lines (a Pareto front, a slope, a bound, the
paper's averages) in greys and black, without markers. No two entries share a
colour and a marker, and no figure draws two series in one colour.

``style(name, used)`` is a series' matplotlib keyword arguments; ``used``, one
dict per figure, keeps a colour to one series in that figure: a name not in
the table (or a second name whose table colour the figure already drew)
takes the first colour of its family's ``SPARE`` list that neither the table
nor the figure holds, then evenly spaced hues; its marker, the next of
``SPARE_MARKERS``. Deterministic: the same names in the same order, the same
looks. ``legend_outside`` puts one legend for a whole figure
to the right of (or below) its axes, never over the data.

Example:
  >>> used = {}
  >>> style("bucket_sort (sized)", used)["color"] == style("bucket_sort f32", used)["color"]
  True
  >>> style("a new peer", used)["linestyle"], style("a new peer", used)["markerfacecolor"]
  ('--', 'none')
  >>> style("a new peer", used)["color"] != style("another new peer", used)["color"]
  True
"""

from __future__ import annotations

import colorsys
import re

# jaxcontact's own forms: solid lines, filled markers, cool colours.
JAXCONTACT = {
    "all_to_all": ("#1f77b4", "o"),
    "all_to_all f64": ("#08306b", "h"),
    "bucket_sort": ("#2ca02c", "s"),
    "bucket_sort f64": ("#00441b", "D"),
    "bucket_sort (compact)": ("#17becf", "d"),
    "Search.closest (reused state)": ("#9467bd", "^"),
    "Search.closest (compact, reused state)": ("#4a1486", "v"),
    "swept": ("#6baed6", "P"),
    "bucket_swept": ("#74c476", "X"),
    "Search.swept (compact)": ("#225ea8", "8"),
    "Search.swept": ("#0570b0", "p"),
    "Search.closest (whole search)": ("#8073ac", "o"),
    "Search.closest (compact, whole search)": ("#2d004b", "s"),
    "Search.closest (whole search, cell lists in chunks)": ("#dd3497", "H"),
    # The Hertz indentation (benchmarks/simulations.py): meshes and errors.
    "FE, 12 elements across 2a": ("#2171b5", "o"),
    "FE, 24 elements across 2a": ("#238b45", "s"),
    "FE, 48 elements across 2a": ("#6a51a3", "D"),
    "FE a against Hertz's": ("#084594", "^"),
    "FE p0 against Hertz's": ("#02818a", "v"),
    "FE p(x), relative L2": ("#7a0177", "P"),
    "jax.grad dp0/dR against Hertz's": ("#5e3c99", "X"),
    "jax.grad dp0/dE against Hertz's": ("#003c30", "h"),
    # benchmarks/simulations.py: the cutting runs.
    "simulation, 400x mass": ("#08519c", "o"),
    "simulation, 200x mass": ("#41ab5d", "s"),
    "simulation, half the element": ("#807dba", "D"),
    # time_vs_error's bucket sorts with shrunk sizes: a hue per kind of size, darker as it shrinks.
    "bucket_sort f32, blocks x0.75": ("#9e9ac8", "<"),
    "bucket_sort f32, blocks x0.5": ("#756bb1", ">"),
    "bucket_sort f32, blocks x0.25": ("#54278f", "p"),
    "bucket_sort f32 cells, per-cell capacity x0.5": ("#41b6c4", "*"),
    "bucket_sort f32 cells, per-cell capacity x0.25": ("#01665e", "X"),
    "bucket_sort f32 cells, cell edge x0.5": ("#9ebcda", "P"),
    "bucket_sort f32 cells, cell edge x2.0": ("#3f5d7d", "^"),
    # benchmarks/stability.py: all_to_all and swept in each precision.
    "float32": ("#88419d", "o"),
    "float64": ("#1d91c0", "s"),
    "float32 corner": ("#8c6bb1", "^"),
    "float32 parallel": ("#4d004b", "v"),
    "float64 corner": ("#3690c0", "D"),
    "float64 parallel": ("#0c2c84", "d"),
}
# The peers: dashed lines, open markers, warm colours.
PEERS = {
    "NumPy dense": ("#d62728", "o"),
    "NumPy box-then-dense": ("#f08080", "s"),
    "NumPy box-then-dense, (N, M, 2)": ("#99000d", "D"),
    "cKDTree ball + NumPy projection": ("#ff7f0e", "^"),
    "cKDTree pairs + NumPy projection": ("#b35806", "v"),
    "shapely STRtree": ("#bcbd22", "p"),
    "jax-md cell list": ("#e377c2", "*"),
    "libigl point_mesh_squared_distance": ("#e6ab02", "h"),
    "numba grid (1 thread)": ("#8c564b", "<"),
    "numba grid (prange, 2 threads)": ("#543005", ">"),
    "IPC Toolkit LBVH + NumPy projection": ("#ae017e", "X"),
    "IPC Toolkit LBVH + Tight Inclusion CCD": ("#f768a1", "P"),
}
# Guide lines, not methods: no markers, greys; (colour, linestyle).
GUIDES = {
    "Pareto front": ("#000000", "--"),
    "slope 1": ("#7f7f7f", ":"),
    "one float32 ulp of o": ("#525252", ":"),
    "bucket sort (paper)": ("#404040", "--"),
    "all-to-all (paper)": ("#969696", "-."),
    "float32 bound": ("#b58cc7", ":"),
    "float64 bound": ("#74b9dc", ":"),
    "Merchant": ("#4d4d4d", "--"),
    "Kienzle (Ck45)": ("#a6761d", "-."),
    "Hertz (Johnson 1985)": ("#1a1a1a", "-"),
}
# Other names for a series of the table: the benchmarks' labels over time.
ALIASES = {
    "all_to_all f32": "all_to_all",
    "bucket_sort f32": "bucket_sort",
    "bucket_sort compact": "bucket_sort (compact)",
    "bucket_swept f32": "bucket_swept",
    "swept f32": "swept",
    "Search.swept, compact": "Search.swept (compact)",
}
STYLES = {**JAXCONTACT, **PEERS, **{name: (colour, "") for name, (colour, _) in GUIDES.items()}}

# Spare colours for names not in the table, by family; then evenly spaced hues.
SPARE = {
    "jaxcontact": ("#4eb3d3", "#2b8cbe", "#8c96c6", "#66c2a4", "#238443", "#3f007d", "#0868ac"),
    "peer": ("#e31a1c", "#fd8d3c", "#cc4c02", "#dd3497", "#993404", "#fec44f", "#67001f"),
    "guide": ("#252525", "#737373", "#bdbdbd"),
}
SPARE_MARKERS = "os^vD<>ph*PXd8H"
# A name starting so is one of jaxcontact's forms.
OWN = ("all_to_all", "bucket_sort", "bucket_swept", "swept", "Search", "jaxcontact", "float")


def canonical(name: str) -> str:
    """The table's name for ``name``: "(sized)" dropped (the sizes are an implementation detail
    of the timing, not another method), a leading "jaxcontact " dropped, aliases followed.

    Example:
      >>> canonical("bucket_sort (sized, compact)"), canonical("bucket_sort (sized) f32")
      ('bucket_sort (compact)', 'bucket_sort')
      >>> canonical("jaxcontact bucket_swept (sized)")
      'bucket_swept'
    """
    name = name.strip()
    name = name.removeprefix("jaxcontact ")
    name = re.sub(r" \(sized\)", "", name)
    name = re.sub(r"\(sized, ", "(", name)
    return ALIASES.get(name, name)


def family(name: str) -> str:
    """``"jaxcontact"``, ``"peer"`` or ``"guide"``: how ``name`` is drawn."""
    name = canonical(name)
    if name in GUIDES:
        return "guide"
    if name in JAXCONTACT or (name not in PEERS and name.startswith(OWN)):
        return "jaxcontact"
    return "peer"


def _hues():
    """Evenly spread colours (golden-ratio hue steps), for figures past every spare colour."""
    hue = 0.0
    while True:
        hue = (hue + 0.618033988749895) % 1.0
        red, green, blue = colorsys.hsv_to_rgb(hue, 0.75, 0.75)
        yield f"#{round(red * 255):02x}{round(green * 255):02x}{round(blue * 255):02x}"


def _pick(name: str, kind: str, used: dict) -> tuple[str, str]:
    """``(colour, marker)`` for ``name`` in a figure whose series so far are ``used`` (name ->
    (colour, marker)): its table entry unless another series of the figure has that colour,
    else the first spare colour of its family that neither the figure nor the table holds."""
    if name in used:
        return used[name]
    drawn = {colour for colour, _ in used.values()}
    known = STYLES.get(name)
    if known and known[0] not in drawn:
        return known
    table = {colour for colour, _ in STYLES.values()}
    spare = (c for c in SPARE[kind] if c not in drawn and c not in table)
    colour = next(spare, None) or next(c for c in _hues() if c not in drawn and c not in table)
    marker = "" if kind == "guide" else SPARE_MARKERS[len(used) % len(SPARE_MARKERS)]
    return colour, marker


def style(name: str, used: dict | None = None, kind: str | None = None) -> dict:
    """matplotlib ``plot`` keyword arguments for the series ``name``.

    ``used``: one dict per figure (series name -> (colour, marker)), updated
    here; pass the same dict for every series of a figure, so that a name
    drawn in several panels keeps its one style and no two names share a
    colour. ``kind`` overrides ``family(name)``: ``"jaxcontact"``,
    ``"peer"`` or ``"guide"``.

    Example:
      >>> style("NumPy dense")["color"], style("NumPy dense")["linestyle"]
      ('#d62728', '--')
    """
    used = {} if used is None else used
    key = canonical(name)
    kind = kind or family(key)
    colour, marker = used[key] = _pick(key, kind, used)
    if kind == "guide":
        linestyle = GUIDES[key][1] if key in GUIDES else ":"
        return {"color": colour, "linestyle": linestyle, "linewidth": 1.3, "marker": ""}
    own = kind == "jaxcontact"
    return {
        "color": colour,
        "marker": marker or "o",
        "linestyle": "-" if own else "--",
        "linewidth": 1.6 if own else 1.2,
        "markersize": 5 if own else 6,
        "markerfacecolor": colour if own else "none",
        "markeredgecolor": colour,
        "markeredgewidth": 1.0 if own else 1.3,
    }


def legend_outside(axes, where: str = "right", panels=None, fontsize: float = 7, **options):
    """One legend for every labelled series of ``panels`` (default: every axes of ``axes``'
    figure; each label once, in drawing order), outside ``axes``: to its right, level with its
    top (``where="right"``), or centred below its tick labels and x label (``"below"``).
    Attached to ``axes``, so ``tight_layout`` and the constrained layout make room for it
    instead of laying it over data. Returns the legend."""
    from matplotlib.transforms import offset_copy

    handles, labels = [], []
    for panel in axes.figure.axes if panels is None else panels:
        for handle, label in zip(*panel.get_legend_handles_labels(), strict=True):
            if label not in labels:
                handles.append(handle)
                labels.append(label)
    figure = axes.figure
    if where == "right":
        place = {"loc": "upper left", "bbox_to_anchor": (1.03, 1.0)}
    elif where == "below":
        # Below what hangs under the axes (tick labels, x label): measured in points, which
        # a later layout does not change.
        renderer = figure.canvas.get_renderer()
        hanging = axes.bbox.y0 - axes.get_tightbbox(renderer).y0
        drop = hanging * 72 / figure.dpi + 4
        place = {
            "loc": "upper center",
            "bbox_to_anchor": (0.5, 0.0),
            "bbox_transform": offset_copy(axes.transAxes, figure, y=-drop, units="points"),
        }
    else:
        raise ValueError(f"where: 'right' or 'below', not {where!r}")
    options = {**place, "borderaxespad": 0.0, "fontsize": fontsize, "frameon": False, **options}
    return axes.legend(handles, labels, **options)


def log_axis_from_zero(axis, zero_at: float, top: float) -> None:
    """A log ``axis`` (``axes.xaxis`` or ``axes.yaxis``) whose values include 0, drawn at
    ``zero_at`` (a decade below 1): ticks at ``zero_at`` (labelled "0") and 1, 10, ... up to
    ``top``, no minor ticks between ``zero_at`` and 1 (no value lies there)."""
    import math

    from matplotlib.ticker import FixedLocator, FuncFormatter

    decades = range(0, math.ceil(math.log10(max(top, 1))) + 1)
    minor = [m * 10**k for k in decades for m in range(2, 10) if m * 10**k <= top]
    axis.set_major_locator(FixedLocator([zero_at, *(10**k for k in decades)]))
    axis.set_minor_locator(FixedLocator(minor))

    def label(value, _):
        if value == zero_at:
            return "0"
        return f"{value:g}" if value < 100 else f"$10^{{{round(math.log10(value))}}}$"

    axis.set_major_formatter(FuncFormatter(label))


def plain_log_labels(axis) -> None:
    """Tick labels of a log ``axis`` as plain numbers (``2``, ``30``, ``0.5``) where they fit,
    powers of ten past 10^4 or below 10^-3; the 2..9 minor ticks labelled too when the axis
    spans less than two decades. Call once its limits are set."""
    import math

    from matplotlib.ticker import FuncFormatter, NullFormatter

    def plain(value, _=None):
        if value <= 0:
            return ""
        power = math.log10(value)
        if 1e-3 <= value <= 1e4:
            return f"{value:g}"
        if abs(power - round(power)) < 1e-9:
            return f"$10^{{{round(power)}}}$"
        return f"{value:.0e}"

    low, high = sorted(axis.get_view_interval())
    axis.set_major_formatter(FuncFormatter(plain))
    few = low > 0 and math.log10(high / low) < 2
    axis.set_minor_formatter(FuncFormatter(plain) if few else NullFormatter())


def count_axis(axes, top: float) -> None:
    """A y axis for counts (0 and up) spanning three decades or more: linear up to 1, log above
    (symlog, ``linthresh=1``), ticks 0, 1, 10, 100, ... up to ``top``; never a negative tick."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

    decades = 0
    while 10**decades < max(top, 1):
        decades += 1
    axes.set_yscale("symlog", linthresh=1, linscale=0.6)
    axes.set_ylim(-0.25, 10 ** (decades + 0.15))
    axes.yaxis.set_major_locator(FixedLocator([0, *(10**k for k in range(decades + 1))]))
    axes.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:,.0f}"))
    axes.yaxis.set_minor_locator(NullLocator())
