"""benchmarks/costs.py at tiny sizes: its checks, its tables and its figure.

The timings themselves are not tested (a loaded machine makes any bound flaky); what is
tested is that every answer is checked, that a wrong answer is reported as wrong, and that
the figure draws from a record alone with every series in the style table. Few programs are
compiled: one part of the bodies' measurements and one friction step.
"""

import json

import jax
import numpy as np
import pytest

from benchmarks import costs
from benchmarks.harness import report, style
from jaxcontact import Pairs, Search, all_to_all
from jaxcontact.forces import Friction
from jaxcontact.scenes import curling_chip


def test_verdict_sums_up_the_checks():
    right, wrong = costs.check("a", True, "1"), costs.check("b", False, "2 rows differ")
    assert costs.verdict([right]) == "right"
    assert costs.verdict([right, right, costs.info("found", "3")]) == "all 2 right"
    assert costs.verdict([costs.info("found", "3")]) is None
    assert costs.verdict([right, wrong]) == "WRONG: b (2 rows differ)"
    assert "b FAILED: 2 rows differ" in costs.words([right, wrong])


@pytest.mark.x64  # the sample's reference is all_to_all in float64
def test_a_wrong_self_contact_answer_is_reported_as_wrong():
    scene = curling_chip(300)
    x, surface, radius, node = scene.x, scene.surface, scene.radius, scene.slave_node
    contact = all_to_all(x, surface, radius=radius, pairs=Pairs(node, self_contact=True))
    pressed = np.asarray(scene.pressed)
    assert costs.pressed_check(contact, pressed)["ok"]
    assert costs.against("=", contact, contact)["ok"]
    rows = np.arange(x.shape[0])
    sample = costs.sampled_reference(x, surface, rows, radius, slave_node=node)
    scale = float(np.abs(np.asarray(x)).max())
    assert costs.against_sample(contact, x, rows, sample, radius, scale)[0]["ok"]

    first = int(np.flatnonzero(np.asarray(contact.found))[0])
    moved = contact._replace(segment=contact.segment.at[first].set(contact.segment[first] + 1))
    assert not costs.against("=", moved, contact)["ok"]
    checked, bad = costs.against_sample(moved, x, rows, sample, radius, scale)
    assert not checked["ok"] and bad.tolist() == [first]
    assert not costs.pressed_check(contact, ~pressed)["ok"]
    deeper = contact._replace(gap=contact.gap.at[first].add(1e-3))
    assert not costs.against("=", deeper, contact)["ok"]
    assert not costs.overflow_check(contact._replace(overflow=np.True_))["ok"]


def test_two_bodies_part_checks_every_answer_and_builds_its_table():
    notes = []
    rows = costs.bodies_part(8, repeats=1, warmup=0, notes=notes)
    assert [r["method"] for r in rows] == [
        "one Search.closest over the union (slave_body)",
        "two Search.closest, each body against the other's outline",
        "all_to_all with the labels",
    ]
    for entry in rows:
        assert costs.verdict(entry["checks"]).endswith("right"), costs.words(entry["checks"])
    whats = [c["what"] for c in rows[0]["checks"]]
    assert {"active = pressed", "= the two searches", "= all_to_all", "no overflow"} <= set(whats)
    assert "two blocks, 64 nodes" in notes[0]

    table = costs.bodies_table(rows, repeats=1, warmup=0)
    assert table["columns"][-1] == "answer" and len(table["rows"]) == 3
    json.dumps(table, allow_nan=False)  # JSON scalars only
    points = costs.figure_points(rows)
    assert [p["series"] for p in points] == [costs.DENSE, costs.EXHAUSTIVE]
    assert points[0]["scene"] == "two blocks, 64 nodes"


@pytest.fixture(scope="module")
def coulomb_steps():
    """Two fresh steps (x0, then x1) of the richest variant (track + Coulomb) on a small
    cutting scene, and what its checks take."""
    title, frames, radius, pairing, _ = costs.cutting_frames(300)
    (x0, s0), (x1, s1) = frames
    count = x0.shape[0]
    search = Search(radius=radius, track=True)
    sizes = search.allocate(x1, s1, at_least=search.allocate(x0, s0)).sizes
    carry = (search.init(x0, s0, sizes=sizes), Friction.zeros(count, x0.dtype))
    step = jax.jit(costs.make_step(search, "coulomb", count))
    carry, first = step(carry, x0, s0, pairing)
    _, second = step(carry, x1, s1, pairing)
    plain = costs.dense(second[0], count)
    return first, second, plain, frames, s1, count


def test_friction_checks_pass_on_the_step_and_fail_on_a_wrong_one(coulomb_steps):
    first, second, plain, frames, surface, count = coulomb_steps

    def verdict(out):
        checks = costs.step_checks(out, plain, None, first, frames, surface, count, False)
        return costs.verdict(checks)

    assert verdict(second) == "all 9 right"
    assert int(np.sum(second[0].active)) > 0  # something to check
    contact, pushed, slip, friction = second
    unbalanced = pushed._replace(on_master=pushed.on_master * 2)
    assert "forces balance" in verdict((contact, unbalanced, slip, friction))
    slid = slip._replace(slip=slip.slip + 1e-3 * contact.found)
    assert "slip = the host's on one segment" in verdict((contact, pushed, slid, friction))
    pulled = pushed._replace(on_slaves=pushed.on_slaves * 1.5)
    assert "normal part = penalty's" in verdict((contact, pulled, slip, friction))
    other = plain._replace(segment=np.where(plain.found, -7, plain.segment))
    checks = costs.step_checks(second, other, None, first, frames, surface, count, False)
    assert "segments = plain" in costs.verdict(checks)


def _record(points):
    return report.record("costs", costs.TITLE, [], data={"figure": points}, quick=True)


def test_the_figure_draws_from_the_record_alone():
    plt = report.pyplot()
    feature = "self-contact, over the plain search"
    bodies = [
        {"scene": "curling chip, 2,000 nodes", "feature": feature, "series": s, "ratio": r}
        for s, r in ((costs.DENSE, 1.3), (costs.COMPACT, 1.2), (costs.EXHAUSTIVE, 22.0))
    ]
    friction = [
        {"scene": scene, "feature": name, "series": series, "ratio": 1.1 + 0.1 * k}
        for scene in ("cutting scene, 2,002 nodes", "curling chip, 2,000 nodes")
        for k, name in enumerate(("slip tracking", "tracking + Coulomb"))
        for series in (costs.DENSE, costs.COMPACT)
    ]
    record = json.loads(json.dumps(_record({"bodies": bodies, "friction": friction})))
    figure = costs.draw(record, plt)
    try:
        figure.canvas.draw()
        labels = {
            line.get_label()
            for axes in figure.axes
            for line in axes.lines
            if not line.get_label().startswith("_")
        }
        assert labels == {costs.DENSE, costs.COMPACT, costs.EXHAUSTIVE}
        assert {style.canonical(label) for label in labels} <= set(style.STYLES)
        legend = figure.axes[0].get_legend()
        for axes in figure.axes:
            assert not legend.get_window_extent().overlaps(axes.bbox)
        ticks = [t.get_text() for t in figure.axes[1].get_yticklabels()]
        assert ticks == [
            "cutting scene, 2,002 nodes",
            "slip tracking",
            "tracking + Coulomb",
            "curling chip, 2,000 nodes",
            "slip tracking",
            "tracking + Coulomb",
        ]
    finally:
        plt.close(figure)
