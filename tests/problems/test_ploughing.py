"""The ploughing simulation: sanity and energy checks, candidate reuse, gradients, the demo.

One small float64 run (a 2,997-node workpiece, 156 steps, the tool in
contact for most of them) is shared by the checks; each other configuration
compiles its own scan, so there are few of them.
"""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import QuerySizes, _cli
from jaxcontact.problems.ploughing import (
    Ploughing,
    mean_cutting_force,
    scan,
    setup,
    simulate,
    tool_outline,
)
from jaxcontact.problems.ploughing.demo import run_demo
from jaxcontact.scenes import cutting_tool_outline
from tests.support.tolerances import FLOAT64_RTOL, FLOAT64_STEPS_RTOL, RERUN_ATOL

pytestmark = [pytest.mark.simulation, pytest.mark.slow, pytest.mark.x64]

# The stated bound on penetration, as a fraction of the grid spacing (the
# search radius): the default penalty (10 E per node) keeps it below this.
PENETRATION_FRACTION = 0.15
# Relative tolerance of the gradient check against central differences.
GRADIENT_RTOL = 1e-6


@pytest.fixture(scope="module")
def small():
    mesh, controls, config = setup(Ploughing(3_000, travel=0.2, dtype="float64"))
    final, history = scan(mesh, controls, config)
    return mesh, controls, config, final, jax.tree.map(np.asarray, history)


def test_tool_outline_is_the_cutting_scenes():
    for x_tip in (20.5, 13.25):
        np.testing.assert_allclose(
            tool_outline(jnp.float64(x_tip), jnp.float64(math.radians(10))),
            cutting_tool_outline(x_tip),
            rtol=0,
            atol=FLOAT64_RTOL,
        )


def test_the_run_has_contact(small):
    # Guards the premise of every check below: the tool is in the workpiece
    # for most of the run, pushing several slaves.
    *_, config, final, history = small
    assert not bool(final.overflow)
    assert history.active.max() >= 2
    assert (history.active > 0).mean() > 0.5
    assert history.force[:, 0].mean() > 0


def test_no_contact_leaves_the_workpiece_at_rest(small):
    *_, history = small
    before = np.arange(len(history.active)) < np.argmax(history.active > 0)
    assert before.sum() >= 3  # the tool starts clear of the workpiece
    # Nothing touched yet: no force, and exactly no motion (energy exactly 0).
    assert (history.force[before] == 0).all()
    assert (history.energy[before] == 0).all()
    assert (history.energy[~before][1:] > 0).all()


def test_tool_force_opposes_the_motion(small):
    *_, config, _, history = small
    touching = history.active > 0
    # The tool moves in -x: the workpiece pushes it in +x whenever they touch,
    # so the tool's power (force . velocity) is never positive.
    assert (history.force[touching, 0] > 0).all()
    assert (history.force[:, 0] * -config.speed <= 0).all()


def test_workpiece_energy_never_exceeds_the_work_done(small):
    *_, config, _, history = small
    # Work done on the workpiece through each step: the reaction on it is
    # -force, moving with the tool's velocity (-speed, 0), over the step.
    work = np.cumsum(history.force[:, 0] * config.speed * config.dt)
    # The energy is leapfrog's (kinetic from the velocities either side of
    # the step). Damping dissipates and the penalty springs store some: the
    # workpiece holds less than the work, but most of it (a wrong sign or an
    # unstable step would break either bound; in this run 0.64 to 0.99).
    touched = work > 0
    ratio = history.energy[touched] / work[touched]
    assert (ratio <= 1).all(), ratio.max()
    assert (ratio[len(ratio) // 4 :] > 0.5).all(), ratio.min()


def test_penetration_stays_small_and_nothing_is_nan(small):
    *_, config, final, history = small
    assert history.penetration.max() < PENETRATION_FRACTION * config.search.radius
    for leaf in jax.tree.leaves((final, history)):
        assert np.isfinite(np.asarray(leaf, np.float64)).all()


def test_candidate_lists_are_reused(small):
    # Found again only every few steps, and the count is the flags'.
    _, _, config, final, history = small
    assert config.search.skin > 0
    assert 1 <= int(final.rebuilds) <= config.steps // 3
    assert int(final.rebuilds) == history.rebuilt.sum()


def test_reuse_surface_slaves_and_growing_sizes_change_nothing(small):
    # One run (one compilation) against the shared one: every node a slave,
    # the tool binned in cells, so that candidate lists are found within
    # ``radius + skin`` and reused, and sizes too small, which ``run`` flags
    # after the run and ``simulate`` grows. The same forces: reusing lists,
    # taking only surface slaves and growing the sizes miss nothing here.
    mesh, controls, config, _, history = small
    _, _, every_node = setup(Ploughing(3_000, travel=0.2, dtype="float64", slaves="all"))
    cramped = dataclasses.replace(
        every_node,
        search=dataclasses.replace(every_node.search, method="binned"),
        sizes=QuerySizes(
            {
                "closest": dataclasses.replace(
                    every_node.sizes["closest"], use_cells=True, block_size=8, block_capacity=1
                )
            }
        ),
    )
    assert bool(scan(mesh, controls, cramped)[0].overflow)
    final, history_again, held = simulate(mesh, controls, cramped)
    held_sizes = held.sizes["closest"]
    assert not bool(final.overflow) and held_sizes.block_capacity > 1 and held_sizes.use_cells
    # Found again only every few steps, and the count is the flags'.
    assert 1 <= int(final.rebuilds) <= config.steps // 3
    assert int(final.rebuilds) == history_again.rebuilt.sum()
    np.testing.assert_array_equal(history_again.active, history.active)
    np.testing.assert_allclose(
        history_again.force, history.force, rtol=FLOAT64_STEPS_RTOL, atol=RERUN_ATOL
    )


def test_gradient_matches_central_differences(small):
    # Where the contact set (which slaves are active, on which segments) is
    # the same at p - h and p + h, the run is one smooth function of p there:
    # the penalty force k (-g) n is zero when a slave becomes active, and the
    # gap is continuous across a change of segment. A change of segment does
    # turn the normal, so the check also asserts the contact history is the
    # same at p - h and p + h: then the difference quotient is that piece's.
    mesh, controls, plan, *_ = small
    value, grads = jax.value_and_grad(mean_cutting_force, argnums=1)(mesh, controls, plan)
    assert value > 0
    for name, step in (("rake", 1e-5), ("stiffness", 1e-5 * float(controls.stiffness))):
        runs = [
            scan(mesh, controls._replace(**{name: getattr(controls, name) + sign * step}), plan)[1]
            for sign in (1, -1)
        ]
        np.testing.assert_array_equal(runs[0].signature, runs[1].signature)
        np.testing.assert_array_equal(runs[0].active, runs[1].active)
        difference = (runs[0].force[:, 0].mean() - runs[1].force[:, 0].mean()) / (2 * step)
        analytic = float(getattr(grads, name))
        assert abs(analytic) > 0
        assert abs(difference - analytic) <= GRADIENT_RTOL * abs(analytic), (name, difference)


def test_demo_without_plots():
    # The shared run's set-up, so its compiled scan is reused.
    summary, _ = run_demo(3_000, 0.2, repeats=1, dtype=np.float64)
    assert summary.steps > 0 and summary.steps_per_s > 0
    # The 20-segment tool keeps no candidate lists: none are found again.
    assert summary.detection_share < 1 and summary.rebuilds >= 1
    assert summary.most_active >= 1 and summary.mean_force[0] > 0
    assert summary.penetration_ratio < PENETRATION_FRACTION


def test_demo_command(tmp_path, capsys):
    args = ["demo", "--scene", "ploughing", "--nodes", "3000", "--travel", "0.2", "--repeats", "1"]
    args += ["--dtype", "float64"]
    assert _cli.main([*args, "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "steps/s" in printed and "detection share" in printed
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert "PNGs skipped" in printed
        return
    assert {path.name for path in tmp_path.iterdir()} == {
        "ploughing_mesh.png",
        "ploughing_forces.png",
    }


def test_demo_paper_scene_still_runs(tmp_path, capsys):
    assert _cli.main(["demo", "--scene", "paper", "--n", "9", "--out", str(tmp_path)]) == 0
    assert "paper scene, Test 1: n=9 (100 nodes)" in capsys.readouterr().out


def test_demo_rejects_bad_sizes(capsys):
    with pytest.raises(SystemExit):
        _cli.main(["demo", "--nodes", "3"])
    assert "must be at least 4" in capsys.readouterr().err
