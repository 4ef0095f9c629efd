"""The simulation parts a user composes: tools, the contact coupling, materials behind one
protocol, and the 0.7.5 names that now forward to them with a warning."""

from __future__ import annotations

import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact.sim import coupling, explicit, materials, tools
from jaxcontact.sim.elements import q4, triangle
from tests.support.tolerances import FLOAT32_ATOL, FLOAT64_EXACT_ATOL, FLOAT64_RTOL

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
    np.testing.assert_allclose(mu, [0.5, 0.5, 0.5, 0.2], rtol=1e-6)
    friction = normal * law.coefficient(normal)
    np.testing.assert_allclose(np.asarray(friction), [0.0, 5.0, 20.0, 20.0], rtol=1e-6)
    grad = jax.grad(lambda n: jnp.sum(n * law.coefficient(n)))(normal)
    assert np.isfinite(np.asarray(grad)).all()
    coulomb = coupling.Coulomb(0.3).coefficient(normal)
    np.testing.assert_allclose(np.asarray(coulomb), np.full(4, 0.3), rtol=1e-6)


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
    np.testing.assert_allclose(np.asarray(state.stress)[0, :, :2], [expected] * 4, rtol=1e-9)
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
    np.testing.assert_allclose(ratio, 10.0, rtol=1e-12)
    state = materials.PointState.at_rest((), scaled, jnp.float32)
    strain = jnp.asarray([0.02, -0.02, 0.0])
    hot, _ = scaled.update(state, strain, 1e-6)
    cold, _ = materials.AISI_1045.update(state, strain, 1e-6)
    np.testing.assert_array_equal(np.asarray(hot.temperature), np.asarray(cold.temperature))


def test_the_replaced_names_warn_naming_their_replacement_and_still_work():
    import jaxcontact.sim as sim
    from jaxcontact.sim import cutting, elastic, plasticity, ploughing, solid, tool

    cases = [
        (lambda: sim.Material(), "jaxcontact.sim.materials.Elastic"),
        (lambda: sim.Mesh, "jaxcontact.sim.elements.triangle.Mesh"),
        (lambda: sim.run, "jaxcontact.sim.ploughing.run"),
        (lambda: ploughing(300, travel=0.1), "jaxcontact.sim.ploughing.setup"),
        (lambda: plasticity.JohnsonCook(), "jaxcontact.sim.materials.AISI_1045"),
        (lambda: plasticity.PointState, "jaxcontact.sim.materials.PointState"),
        (lambda: solid.grid_mesh, "jaxcontact.sim.elements.q4.grid_mesh"),
        (lambda: elastic.Material, "jaxcontact.sim.materials.Elastic"),
        (lambda: elastic.triangle_mesh, "jaxcontact.sim.elements.triangle.triangle_mesh"),
        (lambda: tool.tool_outline, "jaxcontact.sim.ploughing.tool_outline"),
        (lambda: cutting.STEEL, "jaxcontact.sim.materials.AISI_1045"),
    ]
    for old, replacement in cases:
        with pytest.warns(DeprecationWarning, match=replacement):
            old()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        assert plasticity.JohnsonCook() == materials.AISI_1045
        assert plasticity.JohnsonCook(A=600.0).A == 600.0
        assert sim.Material(young=1.0) == materials.Elastic(young=1.0)
        assert solid.grid_mesh is q4.grid_mesh and elastic.stresses is triangle.stresses
        mesh, _, config = ploughing(300, travel=0.1)
        assert config.steps == ploughing.setup(300, travel=0.1)[2].steps
        state = materials.PointState.at_rest((), materials.AISI_1045)
        new, plastic = plasticity.update(
            materials.AISI_1045, state, jnp.asarray([0.01, -0.01, 0.0]), 1e-6
        )
        assert float(plastic) > 0
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        _ = solid.nothing


def test_more_replaced_names_warn_and_keep_their_meaning():
    from jaxcontact.sim import cutting, hertz, plasticity, ploughing, tool

    with pytest.warns(DeprecationWarning, match=r"ploughing\.SCENE_TOOL\.arc_segments"):
        assert tool.ARC_SEGMENTS == ploughing.SCENE_TOOL.arc_segments
    with pytest.warns(DeprecationWarning, match=r"ploughing\.SCENE_TOOL\.edge_radius"):
        assert tool.EDGE_RADIUS == ploughing.SCENE_TOOL.edge_radius
    with pytest.warns(DeprecationWarning, match=r"jaxcontact\.sim\.ploughing\.setup"):
        assert ploughing.ploughing is ploughing.setup
    with pytest.warns(DeprecationWarning, match=r"materials\.Elastic"):
        assert hertz.Material is materials.Elastic
    # 1.1's Cutting.material was the mass-scaled steel: it still is.
    cut = cutting.Cutting(mass_scaling=100.0)
    with pytest.warns(DeprecationWarning, match=r"Cutting\.scaled"):
        assert cut.material == cut.scaled == materials.AISI_1045._replace(mass_scale=100.0)
    assert isinstance(materials.AISI_1045, plasticity.JohnsonCook)
    with pytest.raises(ValueError, match="work_material must be a materials.JohnsonCook"):
        cutting.Cutting(work_material=materials.STEEL)


def test_a_module_called_as_its_old_function_warns_at_the_callers_line():
    from jaxcontact.sim import ploughing

    with pytest.warns(DeprecationWarning) as caught:
        ploughing(300, travel=0.1)
    assert caught[0].filename == __file__


@pytest.mark.x64
def test_the_old_explicit_keywords_warn_and_give_the_boundarys_step():
    material = materials.AISI_1045
    quads = q4.grid_mesh(1.0, 1.0, 1, 1, material.density, jnp.float64)
    body = explicit.at_rest(quads, material)
    push = jnp.zeros((4, 2)).at[2].set([1.0, 0.0])
    fixed = jnp.zeros((4, 2), bool).at[0].set(True)
    new, _ = explicit.step(material, quads, body, push, 1e-8, explicit.Boundary(fixed=fixed))
    with pytest.warns(DeprecationWarning, match=r"explicit\.Boundary"):
        old, _ = explicit.step(material, quads, body, push, 1e-8, fixed=fixed)
    np.testing.assert_allclose(np.asarray(old.x), np.asarray(new.x), atol=FLOAT64_EXACT_ATOL)
    # 1.1's positional order: fixed, velocity, partner, alive.
    alive = jnp.ones(1, bool)
    with pytest.warns(DeprecationWarning, match=r"explicit\.Boundary"):
        old, _ = explicit.step(material, quads, body, push, 1e-8, fixed, None, None, alive)
    np.testing.assert_allclose(np.asarray(old.x), np.asarray(new.x), atol=FLOAT64_EXACT_ATOL)
    with pytest.raises(ValueError, match="velocity with fixed=None"):
        explicit.step(material, quads, body, push, 1e-8, explicit.Boundary(velocity=push))
