"""One record format for every maintained suite: a JSON file, its tables, a figure drawn from it.

A suite's run ends in ``save(record, out, draw)``:

- ``<out>/<suite>.json``: the record. Its provenance (``command``, ``commit``, ``machine``,
  ``versions``, ``date``, ``pinned``, ``quick``), its ``tables`` (title, columns, rows of JSON
  scalars, a note) and any figure-only ``data``.
- ``<out>/<suite>.png``: ``draw(record, pyplot)`` draws the figure from the record as read back
  from the JSON, never from the run's memory, so the figure can be redrawn from the file alone
  (``python benchmarks/report.py --figures``). ``save_figure`` writes the provenance under
  it and stamps the PNG with the record's digest (a PNG text chunk, ``STAMP``).

``markdown(record, figure_link)`` renders a record's tables and figure, captioned with the same
provenance; ``benchmarks/report.py`` assembles the performance page's generated blocks and
``benchmarks/RESULTS.md`` from it. ``tests/test_report.py`` fails when a stored figure's stamp
or a stored table no longer matches its JSON.

This module uses the standard library only: the test reads records and stamps without
jax or matplotlib.
"""

from __future__ import annotations

import datetime
import hashlib
import importlib.metadata
import json
import os
import pathlib
import platform
import struct
import subprocess
import sys
import zlib

ROOT = pathlib.Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results"
STAMP = "jaxcontact-record"  # PNG text key: the sha256 of the record the figure was drawn from
VERSIONED = ("jax", "jaxlib", "numpy", "scipy", "shapely", "matplotlib", "numba", "ipctk", "libigl")


def table(columns, rows, *, title: str | None = None, note: str | None = None) -> dict:
    """One table of a record: ``rows`` are sequences in ``columns``' order (dicts are read by
    column name); cells are JSON scalars (``None`` is shown as a dash)."""
    columns = list(columns)
    cells = [[r.get(c) for c in columns] if isinstance(r, dict) else list(r) for r in rows]
    for cell_row in cells:
        if len(cell_row) != len(columns):
            shape = f"a row of {len(cell_row)} cells, {len(columns)} columns"
            raise ValueError(f"table {title!r}: {shape}")
    return {"title": title, "columns": columns, "rows": cells, "note": note}


def _commit() -> str:
    def git(*args):
        done = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
        return done.stdout.strip()

    # A copy of the tree without its .git (a lent accelerator's) names its commit itself.
    commit = git("rev-parse", "--short", "HEAD") or os.environ.get("BENCH_COMMIT", "unknown")
    # Changed code (the package's or the benchmarks') makes the commit a lie; stored results
    # rewritten by an earlier suite of the same session do not.
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", "*.py")
    return commit + ("+changes" if dirty else "")


def cpu() -> str:
    """The CPU's model name, with its family and model: "AMD EPYC" alone has named machines
    whose speeds differed 3x."""
    name = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            fields = {}
            for line in info:
                key, _, value = line.partition(":")
                fields.setdefault(key.strip(), value.strip())
    except OSError:
        return name
    name = fields.get("model name", name)
    if "cpu family" in fields:
        name += f" (family {fields['cpu family']}, model {fields.get('model', '?')})"
    return name


def _machine() -> str:
    memory = "memory unknown"
    try:
        with open("/proc/meminfo") as info:
            kib = int(next(line.split()[1] for line in info if line.startswith("MemTotal")))
            memory = f"{kib / 2**20:.0f} GiB"
    except (OSError, StopIteration):
        pass
    return f"{cpu()}; {os.cpu_count()} cores; {memory}"


def _allowed() -> list[int] | None:
    try:
        return sorted(os.sched_getaffinity(0))
    except AttributeError:
        return None


def provenance(suite: str, argv=None, *, quick: bool = False) -> dict:
    """What a record says of its run: the command as rerun from the repository root (with the
    ``taskset`` that pinned it), the commit, the machine, versions, date and devices."""
    argv = sys.argv[1:] if argv is None else list(argv)
    allowed = _allowed()
    pinned = allowed is not None and len(allowed) < (os.cpu_count() or 1)
    prefix = [f"taskset -c {','.join(map(str, allowed))}"] if pinned else []
    versions = {"python": platform.python_version()}
    for package in VERSIONED:
        try:
            versions[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            pass
    device = "cpu"
    if "jax" in sys.modules:
        device = sys.modules["jax"].devices()[0].device_kind
    return {
        "suite": suite,
        "command": " ".join([*prefix, "python", f"benchmarks/{suite}.py", *argv]),
        "commit": _commit(),
        "machine": _machine(),
        "device": device,
        "versions": versions,
        "date": datetime.date.today().isoformat(),
        "pinned": pinned,
        "quick": quick,
    }


def record(suite: str, title: str, tables, *, data=None, notes=(), argv=None, quick=False) -> dict:
    """A suite's whole record: provenance, ``tables`` (from ``table``), figure ``data``, notes."""
    return {
        **provenance(suite, argv, quick=quick),
        "title": title,
        "tables": list(tables),
        "data": data or {},
        "notes": list(notes),
    }


def digest(rec: dict) -> str:
    """The sha256 of ``rec`` in a canonical JSON form: what a figure's stamp holds."""
    text = json.dumps(rec, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def caption(rec: dict) -> str:
    """One line: command, commit, machine, device, date."""
    how = "pinned to one core" if rec["pinned"] else "not pinned"
    quick = " (--quick: small sizes)" if rec.get("quick") else ""
    return (
        f"`{rec['command']}`{quick} · commit {rec['commit']} · {rec['machine']}, {how}"
        f" · {rec['device']} · jax {rec['versions'].get('jax', '?')} · {rec['date']}"
    )


def save_figure(figure, rec: dict, path) -> str:
    """Writes ``figure`` to ``path`` with ``rec``'s provenance under it and its digest stamped."""
    import matplotlib.pyplot as plt

    figure.text(0.005, 0.004, caption(rec).replace("`", ""), fontsize=5.5, color="#555555")
    figure.set_dpi(120)  # laid out at the dpi it is saved at: text does not scale with dpi
    figure.tight_layout(rect=(0, 0.03, 1, 1))
    figure.savefig(path, dpi=120, metadata={STAMP: digest(rec)})
    plt.close(figure)
    return str(path)


def pyplot():
    """matplotlib's pyplot on the headless Agg backend, or None when it is not installed."""
    try:
        import matplotlib
    except ImportError:
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def load(path) -> dict:
    with open(path) as stream:
        return json.load(stream)


def save(rec: dict, out, draw=None) -> list[str]:
    """Writes ``<out>/<suite>.json``, then (with matplotlib and a ``draw``) its figure, drawn
    from the JSON as read back; returns the paths written."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{rec['suite']}.json"
    with open(path, "w") as stream:
        json.dump(rec, stream, indent=1, allow_nan=True)
        stream.write("\n")
    written = [str(path)]
    plt = pyplot()
    if draw is not None and plt is not None:
        stored = load(path)
        written.append(save_figure(draw(stored, plt), stored, out / f"{rec['suite']}.png"))
    return written


def stamp(png_path) -> str | None:
    """The ``STAMP`` text a PNG carries, or None: read from its chunks, no imaging library."""
    data = pathlib.Path(png_path).read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    at = 8
    while at + 8 <= len(data):
        (length,) = struct.unpack(">I", data[at : at + 4])
        kind, body = data[at + 4 : at + 8], data[at + 8 : at + 8 + length]
        at += 12 + length
        if kind == b"tEXt":
            key, _, text = body.partition(b"\0")
        elif kind == b"zTXt":
            key, _, rest = body.partition(b"\0")
            text = zlib.decompress(rest[1:])
        elif kind == b"iTXt":
            key, _, rest = body.partition(b"\0")
            text = rest[2:].split(b"\0", 2)[2]
        else:
            continue
        if key.decode("latin-1") == STAMP:
            return text.decode()
    return None


def cell(value) -> str:
    """A table cell: integers with thousands separators, floats to three significant figures
    (whole numbers from 100 up), ``None`` as a dash, text as it is."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        if value != value:
            return "nan"
        if abs(value) >= 100:
            return f"{value:,.0f}"
        return f"{value:.3g}"
    return str(value).replace("|", "\\|").replace("\n", " ")


def markdown_table(tab: dict) -> str:
    lines = []
    if tab.get("title"):
        lines += [f"**{tab['title']}**", ""]
    lines.append("| " + " | ".join(tab["columns"]) + " |")
    lines.append("|" + "---|" * len(tab["columns"]))
    lines += ["| " + " | ".join(cell(v) for v in r) + " |" for r in tab["rows"]]
    if tab.get("note"):
        lines += ["", tab["note"]]
    return "\n".join(lines)


def markdown(rec: dict, figure_link: str | None, tables=None, elsewhere: str | None = None) -> str:
    """A record as markdown: its provenance, notes, tables and figure (``figure_link``: the
    PNG's path relative to the page, None for none).

    ``tables``: the indices of the tables to show, figure first (a page's summary); None for
    every table, figure last (the full record). ``elsewhere``: a link to the full record, said
    where tables are left out.
    """
    parts = [f"Command: {caption(rec)}."]
    parts += list(rec.get("notes", ()))
    shown = rec["tables"] if tables is None else [rec["tables"][i] for i in tables]
    figure = [f"![{rec['title']}]({figure_link})"] if figure_link else []
    if tables is not None:
        parts += figure
    parts += [markdown_table(t) for t in shown]
    if tables is None:
        parts += figure
    left = len(rec["tables"]) - len(shown)
    if left and elsewhere:
        parts.append(f"{left} more table{'s' * (left > 1)} of this record: {elsewhere}.")
    return "\n\n".join(parts)


def stored(results=RESULTS) -> list[pathlib.Path]:
    """Every stored record: ``results/*.json`` then each subfolder's (``pinned/``, ``gpu/``)."""
    results = pathlib.Path(results)
    return sorted(results.glob("*.json")) + sorted(results.glob("*/*.json"))
