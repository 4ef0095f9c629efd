"""The benchmark report is generated, and stays so: every stored table and figure matches its JSON.

``benchmarks/report.py`` writes ``benchmarks/RESULTS.md`` and the generated blocks of
``docs/performance.md`` from the suites' JSON records, and each figure carries the digest of the
record it was drawn from. Nothing here runs a benchmark.
"""

import json
import pathlib
import shutil

import pytest

from benchmarks import report as generator
from benchmarks.harness import report

ROOT = pathlib.Path(__file__).resolve().parent.parent
PROVENANCE = ("command", "commit", "machine", "device", "versions", "date", "pinned", "quick")


def test_every_stored_page_and_figure_matches_its_json():
    assert generator.stale() == [], "rerun `python benchmarks/report.py` (--figures for a PNG)"


def test_at_most_ten_maintained_suites_each_one_script():
    scripts = {p.stem for p in (ROOT / "benchmarks").glob("*.py")} - {"__init__", "report"}
    assert scripts == set(generator.SUITES)
    assert len(scripts) <= 10


@pytest.mark.parametrize("path", report.stored(), ids=lambda p: str(p.relative_to(report.RESULTS)))
def test_every_record_names_its_run(path):
    rec = report.load(path)
    assert rec["suite"] == path.stem and rec["suite"] in generator.SUITES
    assert all(rec[key] not in ("", None) for key in PROVENANCE if key not in ("pinned", "quick"))
    words = rec["command"].split()
    out = words[words.index("--out") + 1] if "--out" in words else "benchmarks/results"
    assert out == path.parent.relative_to(ROOT).as_posix(), "rerun, it would write elsewhere"
    assert f"benchmarks/{path.stem}.py" in rec["command"]
    assert rec["pinned"] == rec["command"].startswith("taskset")
    assert not rec["quick"], "a stored record is a full run"
    assert "+changes" not in rec["commit"], "stored from a tree with uncommitted changes"
    for tab in rec["tables"]:
        assert all(len(row) == len(tab["columns"]) for row in tab["rows"])


def test_every_suite_has_a_record_on_the_performance_page():
    page = generator.PERFORMANCE.read_text()
    named = {m.group(2) for m in generator.BLOCK.finditer(page)}
    assert {f"{suite}.json" for suite in generator.SUITES} <= named


def _scene(tmp_path):
    """A results folder holding one small record and its figure, and the two pages from it."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    results = tmp_path / "results"
    tab = report.table(["method", "median ms"], [["bucket_sort", 1.5], ["all_to_all", 12.25]])
    rec = report.record("peers", "A title", [tab], data={"x": [1, 2]}, argv=["--out", "r"])
    report.save(rec, results)
    stored = report.load(results / "peers.json")
    figure, axes = plt.subplots()
    axes.plot(stored["data"]["x"])
    report.save_figure(figure, stored, results / "peers.png")
    results_page = tmp_path / "RESULTS.md"
    results_page.write_text(generator.results_md(results, results_page))
    performance = tmp_path / "performance.md"
    performance.write_text("Prose.\n\n<!-- report: peers.json -->\nold\n<!-- /report -->\n")
    performance.write_text(generator.performance_md(performance.read_text(), results, performance))
    return results, results_page, performance


def test_a_changed_record_makes_its_table_and_figure_stale(tmp_path):
    results, results_page, performance = _scene(tmp_path)
    assert generator.stale(results, results_page, performance) == []
    text = performance.read_text()
    assert "| bucket_sort | 1.5 |" in text and "Prose." in text and "old" not in text
    assert "![A title](results/peers.png)" in text
    rec = json.loads((results / "peers.json").read_text())
    rec["tables"][0]["rows"][0][1] = 1.6
    (results / "peers.json").write_text(json.dumps(rec))
    assert generator.stale(results, results_page, performance) == [
        "RESULTS.md: not generated from the stored JSON",
        "performance.md: a block differs from its JSON",
        "peers.png: not drawn from peers.json as stored",
    ]


def test_a_figure_copied_from_another_record_is_stale(tmp_path):
    results, results_page, performance = _scene(tmp_path)
    (results / "pinned").mkdir()
    shutil.copy(results / "peers.json", results / "pinned" / "peers.json")
    rec = report.load(results / "pinned" / "peers.json")
    rec["pinned"] = not rec["pinned"]  # another run of the same suite
    (results / "pinned" / "peers.json").write_text(json.dumps(rec))
    shutil.copy(results / "peers.png", results / "pinned" / "peers.png")
    results_page.write_text(generator.results_md(results, results_page))
    assert generator.stale(results, results_page, performance) == [
        "peers.png: not drawn from peers.json as stored"
    ]


def test_cells_are_formatted_one_way():
    assert [report.cell(v) for v in (None, 12_345, 0.012345, 3.14159, 141.4, True, "a|b")] == [
        "–",
        "12,345",
        "0.0123",
        "3.14",
        "141",
        "yes",
        "a\\|b",
    ]
