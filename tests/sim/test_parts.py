"""The simulation parts a user composes: tools, the contact coupling, materials behind one
protocol, and the 0.7.5 names that now forward to them with a warning."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import forces
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


@pytest.mark.x64
def test_zorev_at_its_limit_is_a_traction_whatever_the_node_spacing():
    # A line of slaves 4 to 21 µm apart (mm), pressed into a wide flat master
    # that then slides far past the stick spring's reach: every node at the cap.
    xs = jnp.asarray([0.0, 0.004, 0.015, 0.019, 0.04, 0.043, 0.064, 0.07])
    slaves = jnp.stack([xs, jnp.full_like(xs, -1e-3)], -1)
    count = xs.shape[0]
    own = jaxcontact.Surface(slaves, jnp.stack([jnp.arange(count - 1), jnp.arange(1, count)], -1))
    limit = 200.0  # MPa
    law = coupling.Zorev(mu=10.0, limit=limit, share=coupling.tributary(own))

    def master(shift):  # a face along y = 0, its outward normal +y
        return jaxcontact.Surface(
            jnp.asarray([[1.0 + shift, 0.0], [-1.0 + shift, 0.0]]), jnp.asarray([[0, 1]])
        )

    search = jaxcontact.Search(radius=0.01, method="exhaustive", track=True)
    state = search.allocate(slaves, master(0.0))
    friction = forces.Friction.zeros(count, slaves.dtype)
    stiffness = 1e5  # N/mm per mm: 100 N/mm of normal force on each node
    for shift in (0.0, 0.01):
        contact, state = search.closest(state, slaves, master(shift))
        assert np.asarray(contact.active).all()
        pushed, friction = coupling.friction_forces(
            contact, state.slip, friction, master(shift), stiffness, law
        )
    along = np.asarray(pushed.on_slaves)[:, 0]
    # Each node at its own cap, and the caps sum to the traction times the
    # contact's length, not to a fixed share times the node count.
    np.testing.assert_allclose(along, limit * np.asarray(law.share), rtol=FLOAT64_RTOL)
    np.testing.assert_allclose(along.sum(), limit * float(xs[-1] - xs[0]), rtol=FLOAT64_RTOL)


def test_a_nodes_tributary_length_is_half_its_real_segments():
    # A closed unit square and a padded segment: each corner has two halves of 1.
    square = jnp.asarray([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [5.0, 5.0]])
    segments = jnp.asarray([[0, 1], [1, 2], [2, 3], [3, 0], [-1, -1], [3, 4]])
    mask = jnp.asarray([True, True, True, True, False, False])
    share = coupling.tributary(jaxcontact.Surface(square, segments, mask=mask))
    np.testing.assert_allclose(np.asarray(share), [1.0, 1.0, 1.0, 1.0, 0.0], rtol=FLOAT32_RTOL)
    # Two nodes at one place (a segment of zero length): finite gradients.
    doubled = square.at[1].set(square[0])

    def total(nodes):
        return coupling.tributary(jaxcontact.Surface(nodes, segments, mask=mask)).sum()

    assert np.isfinite(np.asarray(jax.grad(total)(doubled))).all()


@pytest.mark.x64
@pytest.mark.parametrize("rake_deg", [0.0, 10.0, -7.0])
def test_pressure_on_a_split_flat_face_pushes_only_across_it(rake_deg):
    # Frictionless penalty only, smooth normals: slaves pressed, unevenly, into
    # the rake face past its first (one arc chord long) segment.
    rake = math.radians(rake_deg)
    tool = tools.Tool(**TOOL_FIELDS, split_faces=True)
    up = np.asarray([math.sin(rake), math.cos(rake)])  # along the rake face
    outward = np.asarray([-math.cos(rake), math.sin(rake)])
    start = np.asarray(tools.outline(tool, rake, tip=jnp.zeros(2)))[-1]  # the split node
    along_face = np.linspace(0.005, 0.4, 12)
    depth = np.linspace(1e-3, 4e-3, 12) ** 2 / 4e-3
    slaves = jnp.asarray(start + along_face[:, None] * up - depth[:, None] * outward)

    def force_on(tool):
        surface = tools.surface(tool, rake, tip=jnp.zeros(2))
        contact = jaxcontact.all_to_all(slaves, surface, radius=0.05, normals=jaxcontact.Smooth())
        assert np.asarray(contact.active).all()
        return np.asarray(forces.penalty(contact, surface, 1e3).on_master.sum(0))

    total = force_on(tool)
    assert abs(total @ up) <= FLOAT64_RTOL * abs(total @ outward)
    # The face drawn as one segment: the normal, interpolated from the arc's
    # end node, tilts, and so does the force (about 2°).
    tilted = force_on(dataclasses.replace(tool, split_faces=False))
    assert abs(tilted @ up) > 0.01 * abs(tilted @ outward)


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
