"""The simulation parts a user composes: tools, the contact coupling, materials behind one
protocol, and the 0.7.5 names that now forward to them with a warning."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact.problems.cutting import Cutting
from jaxcontact.sim import coupling, explicit, materials, tools
from jaxcontact.sim.elements import q4
from tests.support.tolerances import CLOSED_FORM_RTOL, FLOAT32_ATOL, FLOAT32_RTOL, FLOAT64_RTOL

TOOL_FIELDS = {"edge_radius": 0.05, "clearance": 7.0, "rake_face": 1.0, "flank": 0.5}
TOOL = tools.Tool(**TOOL_FIELDS, arc_segments=12)


def test_a_tool_placed_by_its_tip_or_by_its_lowest_point_is_one_outline():
    rake = jnp.float32(math.radians(6.0))
    by_tip = np.asarray(tools.outline(TOOL, rake, tip=jnp.asarray([1.0, 2.0])))
    # The edge's lowest point: its centre, less a radius.
    centre = _circle_centre(by_tip[: TOOL.arc_segments + 1].astype(np.float64))
    by_lowest = np.asarray(
        tools.outline(TOOL, rake, lowest=jnp.asarray(centre - [0.0, TOOL.edge_radius]))
    )
    np.testing.assert_allclose(by_lowest, by_tip, atol=FLOAT32_ATOL)


def _circle_centre(points: np.ndarray) -> np.ndarray:
    """The least-squares circle's centre through ``points`` (Kasa's fit)."""
    a = np.column_stack([2 * points, np.ones(len(points))])
    b = np.sum(points**2, axis=1)
    solution, *_ = np.linalg.lstsq(a, b, rcond=None)
    return solution[:2]


@pytest.mark.x64
def test_the_edge_is_tangent_to_both_faces_at_any_rake_and_differentiable_in_it():
    for degrees in (-20.0, 0.0, 15.0):
        rake = jnp.float64(math.radians(degrees))
        nodes = np.asarray(tools.outline(TOOL, rake, tip=jnp.zeros(2)))
        centre = _circle_centre(nodes[: TOOL.arc_segments + 1])
        rake_end, flank_end = nodes[-1], nodes[TOOL.arc_segments + 1]
        for end in (rake_end, flank_end):  # each face runs from the tip to its end
            direction = end / np.linalg.norm(end)
            distance = abs(direction[0] * centre[1] - direction[1] * centre[0])
            np.testing.assert_allclose(distance, TOOL.edge_radius, rtol=FLOAT64_RTOL)
        np.testing.assert_allclose(np.linalg.norm(rake_end), TOOL.rake_face, rtol=FLOAT64_RTOL)
        np.testing.assert_allclose(np.linalg.norm(flank_end), TOOL.flank, rtol=FLOAT64_RTOL)
    slope = jax.jacfwd(lambda r: tools.outline(TOOL, r, tip=jnp.zeros(2)))(jnp.float64(0.1))
    assert np.isfinite(np.asarray(slope)).all() and np.abs(np.asarray(slope)).max() > 0


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (dict(edge_radius=0.0), "edge_radius"),
        (dict(clearance=95.0), "clearance"),
        (dict(rake_face=-1.0), "rake_face"),
        (dict(arc_segments=0), "arc_segments"),
        (dict(breaker=(0.2, 95.0, 0.5)), "0 < angle < 90"),
        (dict(breaker=(0.2, 30.0)), r"\(land mm, angle degrees, length mm\)"),
    ],
)
def test_a_tool_refuses_impossible_geometry(change, message):
    with pytest.raises(ValueError, match=message):
        tools.Tool(
            **{"edge_radius": 0.05, "clearance": 7.0, "rake_face": 1.0, "flank": 0.5} | change
        )


def test_a_tool_is_placed_by_exactly_one_point():
    with pytest.raises(ValueError, match="exactly one of tip= and lowest="):
        tools.outline(TOOL, 0.0)


def test_zorev_slides_below_the_limit_and_sticks_above_it_with_finite_gradients():
    law = coupling.Zorev(mu=0.5, limit=200.0, share=0.1)  # a cap of 20 N/mm
    normal = jnp.asarray([0.0, 10.0, 40.0, 100.0])
    mu = np.asarray(law.coefficient(normal))
    np.testing.assert_allclose(mu, [0.5, 0.5, 0.5, 0.2], rtol=FLOAT32_RTOL)
    friction = normal * law.coefficient(normal)
    np.testing.assert_allclose(np.asarray(friction), [0.0, 5.0, 20.0, 20.0], rtol=FLOAT32_RTOL)
    grad = jax.grad(lambda n: jnp.sum(n * law.coefficient(n)))(normal)
    assert np.isfinite(np.asarray(grad)).all()
    coulomb = coupling.Coulomb(0.3).coefficient(normal)
    np.testing.assert_allclose(np.asarray(coulomb), np.full(4, 0.3), rtol=FLOAT32_RTOL)


def test_the_mass_penalty_is_the_mass_over_the_step_squared():
    mass = jnp.asarray([1.0, 2.0])
    np.testing.assert_allclose(np.asarray(coupling.mass_penalty(mass, 0.5, 0.2)), [0.8, 1.6])


def test_the_guards_leave_out_the_open_end_and_the_deep_contacts_and_say_which():
    # An open outline along y = 0 from x = 0 to 2, its inside below; three
    # slaves: past the open end, just inside, and deep inside.
    surface = jaxcontact.Surface(
        jnp.asarray([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), jnp.asarray([[1, 0], [2, 1]])
    )
    slaves = jnp.asarray([[2.05, -0.01], [1.5, -0.01], [0.5, -0.4]])
    contact = jaxcontact.all_to_all(slaves, surface, radius=0.5)
    assert np.asarray(contact.active).all()
    guarded = coupling.guard(contact, surface, depth=0.1)
    np.testing.assert_array_equal(np.asarray(guarded.open_end), [True, False, False])
    np.testing.assert_array_equal(np.asarray(guarded.deep), [False, False, True])
    np.testing.assert_array_equal(np.asarray(guarded.contact.active), [False, True, False])


@pytest.mark.x64
def test_an_elastic_material_through_a_q4_element_is_hooke():
    material = materials.Elastic(young=200_000.0, poisson=0.25)
    mesh = q4.grid_mesh(1.0, 1.0, 1, 1, material.density, jnp.float64)
    moved = mesh.nodes * jnp.asarray([[1.0 + 1e-4, 1.0 - 2e-4]])
    state = materials.PointState.at_rest((1, 4), material, jnp.float64)
    state, plastic = q4.step_material(material, mesh, state, mesh.nodes, moved, 1e-6)
    lam, mu = material.lame
    # The midpoint strain of a stretch s is s / (1 + s / 2).
    exx, eyy = 1e-4 / (1 + 0.5e-4), -2e-4 / (1 - 1e-4)
    expected = [lam * (exx + eyy) + 2 * mu * exx, lam * (exx + eyy) + 2 * mu * eyy]
    stress = np.asarray(state.stress)[0, :, :2]
    np.testing.assert_allclose(stress, [expected] * 4, rtol=CLOSED_FORM_RTOL)
    np.testing.assert_array_equal(np.asarray(plastic), 0.0)


def test_the_presets_carry_their_sources_fits():
    for preset, a in (
        (materials.AISI_1045, 553.1),
        (materials.AISI_4340, 792.0),
        (materials.OFHC_COPPER, 90.0),
    ):
        # At no plastic strain, the reference rate and room temperature: A.
        np.testing.assert_allclose(float(preset.flow_stress(0.0, 1.0, preset.room)), a)
        assert float(preset.flow_stress(0.0, 1.0, preset.melting)) == 0.0


def test_mass_scaling_slows_the_waves_and_leaves_the_heating_alone():
    scaled = materials.AISI_1045._replace(mass_scale=100.0)
    ratio = materials.wave_speed(materials.AISI_1045) / materials.wave_speed(scaled)
    np.testing.assert_allclose(ratio, 10.0, rtol=FLOAT64_RTOL)
    state = materials.PointState.at_rest((), scaled, jnp.float32)
    strain = jnp.asarray([0.02, -0.02, 0.0])
    hot, _ = scaled.update(state, strain, 1e-6)
    cold, _ = materials.AISI_1045.update(state, strain, 1e-6)
    np.testing.assert_array_equal(np.asarray(hot.temperature), np.asarray(cold.temperature))


PACKAGES = ("jaxcontact.sim", "jaxcontact.problems.cutting")


def _removed_cases():
    from jaxcontact import _removed

    return [
        (package, old[len(package) + 1 :], entry)
        for old, entry in _removed.REMOVED.items()
        for package in PACKAGES
        if old.startswith(f"{package}.")
    ]


def test_the_removed_cases_are_every_kind_of_the_two_packages():
    # The parametrisation below is over the table: an emptied table would pass it.
    names = {f"{package}.{name}" for package, name, _ in _removed_cases()}
    assert len(names) == 29
    assert {
        "jaxcontact.sim.cutting",
        "jaxcontact.sim.explicit.step(fixed=)",
        "jaxcontact.problems.cutting.STEEL",
        "jaxcontact.problems.cutting.Cutting.material",
    } <= names


@pytest.mark.parametrize(("package", "name", "entry"), _removed_cases(), ids=lambda v: str(v))
def test_every_removed_name_raises_naming_its_replacement(package, name, entry):
    import importlib

    replacement, deprecated, removed = entry
    assert (deprecated, removed) in (("1.2", "2.0"), ("2.0", "2.0"))
    assert replacement.startswith("use ")
    expected = f"{package}.{name} was removed in 2.0: {replacement}"
    module = importlib.import_module(package)
    if "(" in name:  # a keyword a function no longer takes
        function, keyword = name[:-2].split("(")
        owner, _, attribute = function.rpartition(".")
        call = getattr(importlib.import_module(f"{package}.{owner}"), attribute)
        with pytest.raises(TypeError) as raised:
            call(None, None, None, None, None, **{keyword: None})
    else:
        owner, _, attribute = name.rpartition(".")
        target = getattr(module, owner)() if owner else module
        with pytest.raises(AttributeError) as raised:
            getattr(target, attribute)
    assert str(raised.value) == expected


def test_a_fixed_array_where_the_boundary_goes_is_refused():
    with pytest.raises(TypeError, match=r"boundary must be an explicit\.Boundary"):
        explicit.step(None, None, None, None, None, np.zeros((2, 2), bool))


def test_an_unknown_name_is_an_ordinary_attribute_error():
    import jaxcontact.sim as sim

    with pytest.raises(AttributeError, match="module 'jaxcontact.sim' has no attribute 'nothing'"):
        sim.nothing  # noqa: B018
    with pytest.raises(AttributeError, match="'Cutting' object has no attribute 'nothing'"):
        Cutting().nothing  # noqa: B018
    with pytest.raises(TypeError, match="unexpected keyword argument 'nothing'"):
        explicit.step(None, None, None, None, None, nothing=1)
