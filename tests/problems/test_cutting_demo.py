"""``jaxcontact demo`` for the cutting simulation: its options, and one tiny cut end to end."""

import argparse
import json
import math
import pathlib
import re

import pytest

from jaxcontact import _cli
from jaxcontact.problems import cutting
from jaxcontact.problems.cutting import demo as cutting_demo
from tests.problems.test_machining import KIENZLE_BAND_AT_0_1_MM
from tests.support.tolerances import HAND_FIGURE_RTOL

# What summary.json must hold (cutting.summary's keys and the demo's own).
REQUIRED = {
    "material",
    "cutting_speed_m_per_min",
    "uncut_chip_thickness_mm",
    "rake_deg",
    "friction",
    "cutting_force_N_per_mm",
    "thrust_force_N_per_mm",
    "chip_thickness_ratio",
    "shear_angle_deg",
    "max_penetration_over_element",
    "nodes",
    "steps",
    "steps_per_second",
    "merchant_cutting_force_N_per_mm",
    "merchant_thrust_force_N_per_mm",
    "kienzle_cutting_force_N_per_mm",
    "kienzle_band_N_per_mm",
    "eroded_elements",
}


DOCS = pathlib.Path(__file__).resolve().parents[2] / "docs" / "simulation.md"


def documented_keys() -> list[str]:
    """The keys docs/simulation.md's table "The demo's summary.json" documents, in order."""
    section = DOCS.read_text().split("### The demo's summary.json\n", 1)[1].split("\n#", 1)[0]
    return re.findall(r"^\| `(\w+)` \|", section, re.M)


def test_the_documented_keys_are_each_one_row():
    keys = documented_keys()
    assert len(keys) == len(set(keys)) and REQUIRED <= set(keys)


def _demo_args(*argv: str) -> argparse.Namespace:
    return _cli._parser().parse_args(["demo", *argv])


def test_defaults_are_the_cutting_scene():
    args = _demo_args()
    assert args.scene == "cutting" and args.out == "jaxcontact-demo"
    assert cutting_demo.check(args) is None
    cut = cutting_demo.make_cut(args)
    assert cut == cutting.Cutting(
        speed=100.0, uncut=0.10, travel=0.8, element=0.025, mass_scaling=400.0, dtype="float32"
    )
    assert (args.rake, args.mu, args.frames) == (0.0, cutting.MU, 40)
    assert not (args.fine or args.no_pictures or args.no_gif)


def test_options_make_the_cut():
    args = _demo_args(
        "--speed", "200", "--uncut", "0.05", "--rake", "-30", "--mu", "0", "--element", "0.025",
        "--fine", "--travel", "0.3", "--mass-scaling", "100", "--dtype", "float64",
        "--edge-radius", "0.03",
    )  # fmt: skip
    cut = cutting_demo.make_cut(args)
    assert (cut.speed, cut.uncut, cut.travel, cut.mass_scaling) == (200.0, 0.05, 0.3, 100.0)
    assert cut.edge_radius == 0.03
    assert cut.element == 0.0125 and cut.dtype == "float64"
    assert (args.rake, args.mu) == (-30.0, 0.0)


def test_curl_is_the_chip_breaker_cut_unless_told_otherwise():
    cut = cutting_demo.make_cut(_demo_args("--curl"))
    want = cutting_demo.CURL
    assert cut.breaker == want["breaker"] and cut.ahead == want["ahead"]
    assert (cut.element, cut.travel) == (want["element"], want["travel"])
    assert cut.edge_radius == want["edge_radius"] != cutting.Cutting().edge_radius
    # What is given is kept; the breaker and the room ahead stay.
    cut = cutting_demo.make_cut(_demo_args("--curl", "--travel", "1", "--element", "0.025"))
    assert (cut.element, cut.travel, cut.breaker) == (0.025, 1.0, want["breaker"])
    assert cutting_demo.make_cut(_demo_args("--curl", "--fine")).element == want["element"] / 2
    # Only the cutting scene takes it.
    with pytest.raises(SystemExit):
        _cli.main(["demo", "--scene", "paper", "--curl"])


def test_standalone_parser_takes_the_shared_options():
    parser = argparse.ArgumentParser()
    cutting_demo.add_arguments(parser)
    args = parser.parse_args(["--out", "there", "--no-gif"])
    assert (args.travel, args.out, args.dtype, args.no_gif) == (None, "there", "float32", True)
    assert cutting_demo.make_cut(args).travel == cutting.Cutting().travel


def test_other_scenes_keep_their_options():
    args = _demo_args("--scene", "ploughing", "--nodes", "3000", "--travel", ".2", "--repeats", "1")
    args.check(args)  # no error
    assert (args.nodes, args.travel, args.repeats) == (3000, 0.2, 1)
    args = _demo_args("--scene", "paper", "--n", "9", "--dtype", "float64")
    args.check(args)
    assert (args.n, args.dtype, args.travel) == (9, "float64", None)
    args = _demo_args("--scene", "hertz", "--across", "48")
    args.check(args)
    assert (args.across, args.n) == (48, 250)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--rake", "31"], "argument --rake: must be at most 30"),
        (["--rake", "-30.5"], "argument --rake: must be at least -30"),
        (["--speed", "0"], "argument --speed: must be more than 0"),
        (["--speed", "-100"], "argument --speed: must be more than 0"),
        (["--uncut", "nan"], "argument --uncut: must be finite"),
        (["--element", "inf"], "argument --element: must be finite"),
        (["--mass-scaling", "lots"], "argument --mass-scaling: not a number"),
        (["--mu", "-0.1"], "argument --mu: must be at least 0"),
        (["--travel", "0"], "argument --travel: must be more than 0"),
        (["--frames", "1"], "argument --frames: must be at least 2"),
        (["--uncut", "0.1", "--element", "0.03"], "--uncut 0.1 mm must be a whole number"),
        (["--uncut", "0.01"], "--uncut 0.01 mm must be a whole number"),
        (["--uncut", "0.1", "--element", "0.05", "--fine"], None),  # 0.025: fine
        (["--nodes", "3000"], "--nodes is an option of --scene ploughing, not of --scene cutting"),
        (["--scene", "ploughing", "--rake", "5"], "--rake is an option of --scene cutting"),
        (["--scene", "paper", "--travel", "1"], "--travel is an option of --scene cutting and"),
        (["--scene", "paper", "--nodes", "3000"], "--nodes is an option of --scene ploughing"),
        (["--scene", "cutting", "--n", "9"], "--n is an option of --scene paper"),
        (["--across", "12"], "--across is an option of --scene hertz, not of --scene cutting"),
        (["--scene", "hertz", "--n", "9"], "--n is an option of --scene paper"),
        (["--scene", "hertz", "--travel", "1"], "--travel is an option of --scene cutting and"),
        (["--scene", "hertz", "--across", "1"], "argument --across: must be at least 2"),
    ],
)
def test_bad_options_are_argparse_errors(argv, message, capsys):
    if message is None:
        args = _demo_args(*argv)
        args.check(args)
        assert cutting_demo.element_size(args) == 0.025
        return
    with pytest.raises(SystemExit) as exit_:
        # Refused before anything runs: parsing and the scene's check.
        _cli.main(["demo", *argv])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: jaxcontact demo") and message in err, err


@pytest.mark.slow
def test_tiny_cut_end_to_end(tmp_path, capsys):
    # 80 nodes, 616 steps, 0.05 mm of travel: too short for a steady chip
    # (its thickness is null), long enough for the tool to cut 0.025 mm.
    # Most of the time is compiling the step.
    argv = ["demo", "--travel", "0.05", "--element", "0.05", "--uncut", "0.1", "--frames", "4"]
    assert _cli.main([*argv, "--out", str(tmp_path)]) == 0
    steps = cutting.Cutting(travel=0.05, element=0.05).steps
    captured = capsys.readouterr()
    assert "100%" in captured.err and "steps" in captured.err  # the progress bar
    assert "cutting_force_N_per_mm" in captured.out and "detection_share" not in captured.out
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert list(summary) == documented_keys()  # every key in docs/simulation.md's table
    # The header's steps are the steps run, the travel the travel asked.
    assert f"{steps:,} steps of dt" in captured.out and summary["steps"] == steps
    assert "forces: no steady state in the run" in captured.out
    assert summary["forces_steady"] is False and summary["force_window_mm"][1] == pytest.approx(
        0.05, abs=cutting.Cutting(travel=0.05, element=0.05).velocity * 1e-7
    )
    assert summary["cutting_force_N_per_mm"] > 0
    assert all(math.isfinite(summary[key]) for key in ("thrust_force_N_per_mm", "steps_per_second"))
    assert summary["elements"] == 54
    assert summary["overflow"] is False
    # The band for Ck45 at the run's 0.1 mm, worked by hand (tests/problems/test_machining.py).
    assert summary["kienzle_band_N_per_mm"] == pytest.approx(
        KIENZLE_BAND_AT_0_1_MM, rel=HAND_FIGURE_RTOL
    )
    pytest.importorskip("matplotlib")
    for name in ("chip.png", "forces.png", "chip.gif"):
        assert (tmp_path / name).stat().st_size > 0, name
