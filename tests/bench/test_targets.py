"""benchmarks/targets.py, size_scaling.py and against.py at tiny sizes: every answer checked,
a wrong answer reported as wrong, the record's tables, and a figure drawn from the record
alone whose series all have a look of their own (``benchmarks.harness.style``).

The timings themselves are not tested (a loaded machine makes any bound flaky).
"""

import argparse
import subprocess
import types

import jax
import numpy as np
import pytest

from benchmarks import against, size_scaling, targets
from benchmarks.harness import report, style
from jaxcontact.scenes import cutting_scene
from tests.support.tolerances import FLAT_SLOPE_ATOL


def _args(tmp_path, **more):
    return argparse.Namespace(quick=True, out=str(tmp_path), repeats=2, **more)


def _drawn_labels(module, found, tmp_path) -> list[str]:
    """The record of ``found`` saved, its figure drawn by ``module.draw`` from the JSON read
    back; the labels of the figure's series."""
    plt = pytest.importorskip("matplotlib.pyplot")
    suite = module.__name__.rsplit(".", 1)[-1]
    rec = report.record(suite, found["title"], found["tables"], data=found["data"], argv=[])
    report.save(rec, tmp_path)  # the JSON alone
    figure = module.draw(report.load(tmp_path / f"{suite}.json"), plt)
    labels = [label for axes in figure.axes for label in axes.get_legend_handles_labels()[1]]
    plt.close(figure)
    unknown = {style.canonical(label) for label in labels} - set(style.STYLES)
    assert not unknown, unknown
    return labels


def _table(found, title_start):
    (tab,) = [t for t in found["tables"] if (t["title"] or "").startswith(title_start)]
    return [dict(zip(tab["columns"], row, strict=True)) for row in tab["rows"]]


def test_targets_rows_programs_and_figure(tmp_path, monkeypatch):
    """One tiny cutting scene through ``run``: the four Search steps, checked against the
    whole-search dense form's (the numba grid left out: compiling it takes 10 s or more)."""
    monkeypatch.setattr(targets, "QUICK", (("cutting, tool in", 400, 18.0),))
    monkeypatch.setattr(targets, "PEERS", ())
    x64 = jax.config.jax_enable_x64
    found = targets.run(_args(tmp_path))
    assert jax.config.jax_enable_x64 == x64  # run turns it off for float32, then back
    timed = _table(found, "Time per call")
    assert [row["method"] for row in timed] == list(targets.SEARCHES)
    assert all(row["check"] == "equal" for row in timed), timed
    programs = _table(found, "The compiled Search.closest steps")
    assert [row["method"] for row in programs] == list(targets.SEARCHES)
    for row in programs:
        assert row["compile s"] > 0 and row["kernels"] > 0, row
        assert row["loop trips"] is None or row["loop trips"] == "unknown" or row["loop trips"] > 0
        assert row["in + out MiB"] > 0 and row["accessed MiB"] > 0, row
    labels = _drawn_labels(targets, found, tmp_path)
    assert set(targets.SEARCHES) <= set(labels)


def test_targets_checks_report_wrong_answers():
    segment = np.array([0, 1, 2, -1])
    found = segment >= 0
    gap = np.array([0.1, 0.2, 0.3, 0.0])
    reference = (segment, found, gap)
    assert targets.search_check((segment, found, gap), reference) == "equal"
    other = np.array([0, 2, 2, -1])
    assert "other segment 1" in targets.search_check((other, found, gap), reference)
    missed = found & (segment != 0)
    assert "missed 1" in targets.search_check((segment, missed, gap), reference)
    assert targets.numba_check((segment, gap, found), reference) == "equal"
    wrong = targets.numba_check((segment, gap, ~found), reference)
    assert wrong == "missed 3, false 1, other segment 0"


@pytest.mark.x64  # the reference is all_to_all in float64
def test_size_scaling_rows_slopes_tables_and_figure(tmp_path, monkeypatch):
    """One tiny rough die through the library's two programs (all_to_all over its pair
    budget), then a sweep made up from its rows: the slopes, tables and figure."""
    monkeypatch.setattr(size_scaling, "PAIR_BUDGET", 1_000)
    names = (size_scaling.LIBRARY, size_scaling.SEARCH, size_scaling.DENSE)
    rows = size_scaling.run_scene(400, 40, repeats=2, slow_s=60, names=names)
    by_method = {row["method"]: row for row in rows}
    assert by_method[size_scaling.DENSE]["note"].startswith("not run: N*M too large")
    assert by_method[size_scaling.DENSE]["median_ms"] is None
    for name in (size_scaling.LIBRARY, size_scaling.SEARCH):
        row = by_method[name]
        assert row["median_ms"] > 0 and row["runs"] == 2 and row["compile_s"] > 0
        assert row["temp_mib"] > 0 and row["out_mib"] > 0  # XLA's account of the program
        assert row["missed"] == row["false"] == row["wrong_segment"] == 0, row
        assert isinstance(row["ratio"], float)
    assert by_method[size_scaling.SEARCH]["rebuilds"] == 0  # the state was reused

    def grown(by_nodes, by_segments):  # the same rows at a larger size, time as size**0.75
        factor = (by_nodes * by_segments) ** 0.75
        return [
            {
                **row,
                "nodes": row["nodes"] * by_nodes,
                "segments": row["segments"] * by_segments,
                "scene_key": [400 * by_nodes, 40 * by_segments],
                "median_ms": row["median_ms"] and row["median_ms"] * factor,
            }
            for row in rows
        ]

    made_up = rows + grown(10, 1) + grown(100, 1) + grown(1, 10)
    sweeps = size_scaling.Sweeps((400, 4_000, 40_000), 40, (40, 400), 400)
    found = size_scaling.found(made_up, sweeps, "made up")
    slopes = {row["method"]: row for row in _table(found, "Slopes")}
    library = slopes[size_scaling.LIBRARY]
    for column in ("time in N: all points", "last decade", "time in M: all points"):
        assert library[column] == pytest.approx(0.75)
    assert (library["points in N"], library["points in M"]) == (3, 2)
    memory = library["memory in N: last decade"]  # memory kept: a flat line
    assert memory == pytest.approx(0.0, abs=FLAT_SLOPE_ATOL)
    dense = slopes[size_scaling.DENSE]
    assert dense["points in N"] == 0 and dense["time in N: all points"] is None
    answers = _table(found, "Answers")
    assert answers[0][size_scaling.DENSE] == "not run"
    assert answers[0][size_scaling.LIBRARY] == "same contacts"
    labels = _drawn_labels(size_scaling, found, tmp_path)
    assert size_scaling.LIBRARY in labels and size_scaling.DENSE not in labels


@pytest.fixture(scope="module")
def head():
    """This checkout's committed package, extracted as the other revision."""
    try:
        return against.extracted("HEAD")
    except (subprocess.CalledProcessError, FileNotFoundError) as error:
        pytest.skip(f"no git checkout to extract HEAD from: {error}")


def test_against_itself_same_answers_and_program(tmp_path, monkeypatch, head):
    """This tree against its own HEAD on a tiny scene, two forms: equal answers, the same
    XLA program, every column of the table filled; the figure from the record."""
    scene = {"cutting 400": lambda: cutting_scene(400, 18.0, x_tip_prev=18.2)}
    monkeypatch.setattr(against, "SCENES", scene)
    monkeypatch.setattr(against, "QUICK", tuple(scene))
    monkeypatch.setattr(against, "FORMS", (against.ALL_TO_ALL, against.WHOLE))
    found = against.run(_args(tmp_path, against="HEAD"))
    rows = _table(found, "This tree against HEAD")
    assert [row["form"] for row in rows] == [against.ALL_TO_ALL, against.WHOLE]
    for row in rows:
        assert row["answers"] == "equal" and row["XLA program"] == "same", row
        assert row["ratio"] > 0 and row["itself"] > 0 and row["compile HEAD s"] > 0
    assert set(_drawn_labels(against, found, tmp_path)) == {against.ALL_TO_ALL, against.WHOLE}


def test_against_reports_other_answers_and_programs():
    def contact(segment):  # the two fields compared, as a Contact holds them
        segment = np.asarray(segment)
        return types.SimpleNamespace(segment=segment, found=segment >= 0)

    assert against.compared(contact([0, 1, -1]), contact([0, 1, -1]), 3) == "equal"
    assert against.compared(contact([0, 2, -1]), contact([0, 1, 1]), 3) == "2 rows differ"
    x = np.ones(8, np.float32)
    double = jax.jit(lambda x: x * 2.0).lower(x).compile().as_text()
    again = jax.jit(lambda y: y * 2.0).lower(x).compile().as_text()
    halve = jax.jit(lambda x: x / 2.0).lower(x).compile().as_text()
    assert against.same_program(double, again) == "same"
    assert against.same_program(double, halve).startswith("differs")
