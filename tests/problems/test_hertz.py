"""A rigid cylinder pressed into an elastic block against Hertz (jaxcontact.problems.hertz).

One solve of the small mesh (12 elements across the contact width 2a) is shared
by the checks: it compiles the equilibrium program once, which the central
differences and the demo reuse; the gradient compiles one more. Float64 only
(the penetration is some 1e-5 of a).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import _cli
from jaxcontact.problems import hertz
from jaxcontact.sim.elements.triangle import internal_forces, strain_energy
from jaxcontact.sim.materials import Elastic
from tests.support.tolerances import (
    CLOSED_FORM_RTOL,
    FLOAT64_RTOL,
    FLOAT64_STEPS_RTOL,
    FORCE_ATOL,
    HERTZ_FD_RTOL,
    HERTZ_FORCE_RTOL,
    HERTZ_GRADIENT_RTOL,
    HERTZ_L2,
    HERTZ_PENETRATION,
    HERTZ_RTOL,
    MIDPOINT_RULE_RTOL,
)

pytestmark = [pytest.mark.x64]

SMALL = 12  # elements across 2a: the "ten or more"
# A steel cylinder on aluminium, besides the default steel on steel: R, P, E, nu.
OTHER = hertz.Indentation(radius=25.0, force=300.0, young=70_000.0, poisson=0.33)


@pytest.fixture(scope="module")
def small():
    return hertz.run(hertz.Indentation(), SMALL)


@pytest.mark.parametrize("problem", [hertz.Indentation(), OTHER])
def test_hertz_is_johnsons_line_contact(problem):
    exact = hertz.hertz(problem)
    modulus = problem.young / (1 - problem.poisson**2)
    assert exact.modulus == pytest.approx(modulus, rel=CLOSED_FORM_RTOL)
    # a² = 4PR / (π E*), p0 = 2P / (π a) = sqrt(P E* / (π R)) (Johnson 1985, eq. 4.43-4.45)
    assert math.pi * modulus * exact.half_width**2 == pytest.approx(
        4 * problem.force * problem.radius, rel=CLOSED_FORM_RTOL
    )
    assert exact.peak == pytest.approx(
        math.sqrt(problem.force * modulus / (math.pi * problem.radius)), rel=CLOSED_FORM_RTOL
    )
    # The elliptical pressure carries P: ∫ p dx = π a p0 / 2, by the midpoint rule here.
    edges = np.linspace(-exact.half_width, exact.half_width, 200_001)
    middles = (edges[1:] + edges[:-1]) / 2
    carried = float(np.sum(exact.pressure(middles)) * (edges[1] - edges[0]))
    assert carried == pytest.approx(problem.force, rel=MIDPOINT_RULE_RTOL)
    assert exact.pressure(1.01 * exact.half_width) == 0


def test_the_block_is_graded_towards_the_contact():
    problem = hertz.Indentation()
    a = hertz.hertz(problem).half_width
    block = hertz.setup(problem, SMALL, growth=1.25)
    nodes = np.asarray(block.mesh.nodes)
    x = nodes[np.asarray(block.top), 0]
    h = float(block.element)
    assert h == pytest.approx(2 * a / SMALL, rel=FLOAT64_RTOL)
    np.testing.assert_allclose(x, -x[::-1], atol=FLOAT64_RTOL * a)  # symmetric about 0
    assert x[int(block.centre)] == 0
    assert x[0] == pytest.approx(-10 * a) and nodes[:, 1].min() == pytest.approx(-10 * a)
    assert float(block.tributary.sum()) == pytest.approx(20 * a, rel=FLOAT64_RTOL)
    steps = np.diff(x)
    uniform = np.abs(x[1:] + x[:-1]) / 2 < 1.5 * a
    np.testing.assert_allclose(steps[uniform], h, rtol=FLOAT64_RTOL)
    ratios = np.maximum(steps[1:] / steps[:-1], steps[:-1] / steps[1:])
    assert ratios.max() <= 1.25 * (1 + 1e-9)
    # The bottom is fixed, nothing else; the free unknowns are the other nodes' two each.
    bottom = np.isclose(nodes[:, 1], -10 * a)
    assert (np.asarray(block.mesh.free) == ~bottom).all()
    assert block.free_dofs.shape == (2 * int((~bottom).sum()),)
    # The arc covers |x| <= 3a in segments of about h / 2, an odd count.
    angles = np.asarray(block.angles)
    segments = len(angles) - 1
    assert segments % 2 == 1
    assert problem.radius * math.sin(angles[-1]) == pytest.approx(3 * a)
    assert problem.radius * np.diff(angles).max() <= h / 2


def test_strain_energy_is_the_internal_forces_potential():
    block = hertz.setup(hertz.Indentation(), 4)
    material = Elastic(young=70_000.0, poisson=0.33)
    u = 1e-3 * jax.random.normal(jax.random.key(0), block.mesh.nodes.shape, jnp.float64)
    forces = -jax.grad(strain_energy, argnums=1)(block.mesh, u, material)
    np.testing.assert_allclose(forces, internal_forces(block.mesh, u, material), atol=FORCE_ATOL)
    energy = float(strain_energy(block.mesh, u, material))
    assert energy == pytest.approx(-0.5 * float(jnp.sum(u * forces)), rel=FLOAT64_RTOL)


@pytest.mark.slow
def test_the_small_mesh_meets_hertz(small):
    exact = small.exact
    a = exact.half_width
    assert small.across >= 10 and 2 * a / small.element == pytest.approx(small.across)
    assert small.active >= small.across - 1  # the pressed nodes span the contact
    assert abs(small.half_width_error) < HERTZ_RTOL
    assert abs(small.peak_error) < HERTZ_RTOL
    assert small.l2_error < HERTZ_L2
    assert 0 < small.penetration < HERTZ_PENETRATION * a
    assert small.force == pytest.approx(small.problem.force, rel=HERTZ_FORCE_RTOL)
    assert small.residual <= hertz.Solver().tol * small.problem.force
    # The errors are what they say: recomputed from the nodal pressures.
    assert small.peak == small.pressure[np.argmin(np.abs(small.x))]
    fitted, _ = hertz.fit_half_width(small.x, small.pressure)
    assert small.half_width_error == pytest.approx(fitted / a - 1, rel=FLOAT64_RTOL)
    # Nothing presses beyond the element past Hertz's edge.
    assert (small.pressure[np.abs(small.x) > a + small.element] == 0).all()


@pytest.mark.slow
def test_the_peak_pressures_gradient(small):
    problem = hertz.Indentation()
    block = hertz.setup(problem, SMALL)
    value, grads = jax.value_and_grad(hertz.peak_pressure, argnums=1)(block, problem)
    # Another program (the forward pass of the gradient's) through the same Newton steps.
    assert float(value) == pytest.approx(small.peak, rel=FLOAT64_STEPS_RTOL)
    p0 = hertz.hertz(problem).peak
    analytic = {"radius": -p0 / (2 * problem.radius), "young": p0 / (2 * problem.young)}
    for name, expected in analytic.items():
        found = float(getattr(grads, name))
        nominal = getattr(problem, name)
        step = 1e-5 * nominal
        # The jitted equilibrium the fixture compiled: plain floats, the same program.
        up, down = (
            float(hertz.peak_pressure(block, problem._replace(**{name: nominal + change})))
            for change in (step, -step)
        )
        assert found == pytest.approx((up - down) / (2 * step), rel=HERTZ_FD_RTOL), name
        assert found == pytest.approx(expected, rel=HERTZ_GRADIENT_RTOL), name


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: hertz.hertz(hertz.Indentation(radius=0.0)), "problem.radius must be"),
        (lambda: hertz.hertz(hertz.Indentation(force=float("nan"))), "problem.force must be"),
        (lambda: hertz.hertz(hertz.Indentation(young=-1.0)), "problem.young must be"),
        (lambda: hertz.hertz(hertz.Indentation(poisson=0.5)), "problem.poisson must be in"),
        (lambda: hertz.hertz((10.0, 1e3, 2e5, 0.3)), "problem must be an Indentation; got tuple"),
        (lambda: hertz.run(across=1), "across must be an integer >= 2; got 1"),
        (lambda: hertz.run(across=12.0), "across must be an integer >= 2; got 12.0"),
        (lambda: hertz.run(width=6.0), "width must be a finite number > 6"),
        (lambda: hertz.run(depth=1.0), "depth must be a finite number > 1.5"),
        (lambda: hertz.setup(growth=1.0), "growth must be in (1, 2]; got 1.0"),
        (lambda: hertz.run(hertz.Indentation(force=3e5)), "problem must give Hertz's a / R at"),
        (lambda: hertz.run(solver="fast"), "solver must be a Solver; got str"),
        (lambda: hertz.Solver(penalty=0.0), "Solver.penalty must be a finite number > 0"),
        (lambda: hertz.Solver(cg_steps=0), "Solver.cg_steps must be an integer >= 1"),
        (lambda: hertz.fit_half_width([0.0, 1.0], [1.0, 0.0]), "pressure must be > 0 at two"),
    ],
)
def test_bad_input_names_the_argument(call, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call()


def test_float32_is_refused():
    with jax.enable_x64(False), pytest.raises(ValueError, match="needs float64"):
        hertz.run()


@pytest.mark.slow
def test_demo_command(small, tmp_path, capsys):
    # --across 12: the fixture's mesh, so its compiled equilibrium is reused.
    args = ["demo", "--scene", "hertz", "--across", str(SMALL), "--out", str(tmp_path)]
    assert _cli.main(args) == 0
    printed = capsys.readouterr().out
    assert f"{small.across} elements across 2a" in printed
    assert f"{100 * small.peak_error:+.2f} %" in printed and "relative L2 error" in printed
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert "PNG skipped" in printed
        return
    assert [path.name for path in tmp_path.iterdir()] == [f"hertz_pressure_{SMALL}.png"]
