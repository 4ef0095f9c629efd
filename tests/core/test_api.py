"""The public surface of 1.0: its layout, every mix of concrete and traced
arguments, and the names 1.0 replaced (they warn and keep working)."""

import ast
import pathlib

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import (
    Pairs,
    Search,
    Surface,
    all_to_all,
    bucket_sort,
    bucket_swept,
    swept,
)
from jaxcontact.forces import penalty
from tests.support.helpers import local_atol
from tests.support.tolerances import FLOAT64_ATOL

PACKAGE = pathlib.Path(jaxcontact.__file__).resolve().parent

# A small scene: a floor of three segments, four slaves above and below it.
NODES = np.array([[3.0, 0.0], [2.0, 0.0], [1.0, 0.0], [0.0, 0.0]])
SEGMENTS = np.array([[0, 1], [1, 2], [2, 3]])
X = np.array([[0.5, 0.1], [1.5, -0.05], [2.5, 0.2], [2.9, 0.6]])
X_PREV = X + np.array([0.0, 0.3])
MASK = np.array([True, True, True, False])
RADIUS = 0.25
# Slave 2 is node 1 of the surface: with the rule, it never meets segments 0 and 1.
SLAVE_NODE = np.array([-1, -1, 1, -1], np.int32)


# -- the layout ------------------------------------------------------------------


def _module_name(path: pathlib.Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _import_graph() -> dict[str, set[str]]:
    """Every module of the package and the package modules it imports,
    anywhere in its body (an import inside a function counts too)."""
    paths = {_module_name(path): path for path in PACKAGE.rglob("*.py")}
    graph = {name: set() for name in paths}
    for name, path in paths.items():
        is_package = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = name.split(".")[: len(name.split(".")) - node.level + is_package]
                    base = ".".join(anchor + ([base] if base else []))
                # ``from pkg import module`` names the module; anything else the package.
                targets = [
                    f"{base}.{alias.name}" if f"{base}.{alias.name}" in paths else base
                    for alias in node.names
                ]
            else:
                continue
            for target in targets:
                while target and target not in paths:
                    target = target.rpartition(".")[0]
                if target and target != name:
                    graph[name].add(target)
    return graph


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` as a path of names, or None."""
    state: dict[str, int] = {}
    trail: list[str] = []

    def visit(name):
        state[name] = 1
        trail.append(name)
        for target in sorted(graph[name]):
            if state.get(target) == 1:
                return trail[trail.index(target) :] + [target]
            if target not in state and (found := visit(target)):
                return found
        trail.pop()
        state[name] = 2
        return None

    for name in sorted(graph):
        if name not in state and (found := visit(name)):
            return found
    return None


def test_the_package_has_no_import_cycle():
    graph = _import_graph()
    assert len(graph) > 30 and "jaxcontact._pipeline.driver" in graph
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_cycle_check_finds_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycle(graph) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_the_stages_import_no_entry_point():
    # The pipeline's stages sit below the queries and the entry points.
    graph = _import_graph()
    above = {"jaxcontact", "jaxcontact._detect", "jaxcontact._search", "jaxcontact._shard"}
    for name, targets in graph.items():
        if name.startswith("jaxcontact._pipeline"):
            assert not targets & above, (name, targets & above)
            assert not any(target.startswith("jaxcontact._query") for target in targets), name


def test_every_public_name_is_documented():
    public = [name for name in dir(jaxcontact) if not name.startswith("_")]
    assert "Pairs" in public and "clear_sizes" in public
    for name in public:
        value = getattr(jaxcontact, name)
        if callable(value):
            assert value.__doc__ and len(value.__doc__) > 40, name


# -- concrete and traced arguments --------------------------------------------------


def _surface(nodes=NODES):
    return Surface(nodes, SEGMENTS)


def _closest(detect, compact=False):
    def run(x, nodes, radius, mask, slave_node):
        found = detect(x, _surface(nodes), radius=radius, mask=mask, pairs=Pairs(slave_node))
        return found.to_contact(len(X)) if compact else found

    return run


def _crossing(detect):
    def run(x, nodes, radius, mask, slave_node):
        return detect(X_PREV, x, _surface(nodes), mask=mask, pairs=Pairs(slave_node))

    return run


ARGUMENTS = ("x", "nodes", "radius", "mask", "slave_node")
CONCRETE = (X, NODES, RADIUS, MASK, SLAVE_NODE)
EXHAUSTIVE = {"all_to_all": _closest(all_to_all), "swept": _crossing(swept)}
ONE_CALL_BUCKET = {"bucket_sort": _closest(bucket_sort), "bucket_swept": _crossing(bucket_swept)}


def _traced_call(run, traced: tuple[str, ...]):
    """``run`` with the arguments named in ``traced`` traced by ``jit`` and
    the others concrete NumPy values closed over."""
    given = dict(zip(ARGUMENTS, CONCRETE, strict=True))

    def partial(*values):
        return run(**{**given, **dict(zip(traced, values, strict=True))})

    return jax.jit(partial)(*(given[name] for name in traced))


MIXES = [(name,) for name in ARGUMENTS] + [ARGUMENTS]


@pytest.mark.parametrize("traced", MIXES, ids=["+".join(mix) for mix in MIXES])
@pytest.mark.parametrize("detector", EXHAUSTIVE)
def test_exhaustive_detectors_take_any_mix_of_concrete_and_traced_arguments(detector, traced):
    run = EXHAUSTIVE[detector]
    plain = run(*CONCRETE)
    got = _traced_call(run, traced)
    for field, want in plain._asdict().items():
        got_field, want = np.asarray(getattr(got, field)), np.asarray(want)
        if np.issubdtype(want.dtype, np.floating):
            # Two programs (op by op, and jitted around the traced
            # arguments): XLA contracts a*b+c into fused multiply-adds per
            # fusion, so a coordinate may differ in its last bits.
            atol = local_atol(want.dtype, float(np.max(np.abs(NODES))))
            np.testing.assert_allclose(got_field, want, rtol=0, atol=atol, err_msg=field)
        else:
            np.testing.assert_array_equal(got_field, want, field)
    assert bool(plain.found.any() if detector == "all_to_all" else plain.crossed.any())


def test_the_reported_call_with_only_the_radius_traced_works():
    # A user's call: concrete NumPy slaves and tool, a traced radius.
    tool = _surface()
    traced = jax.jit(lambda r: all_to_all(X, tool, radius=r))(0.1)
    np.testing.assert_array_equal(traced.segment, all_to_all(X, tool, radius=0.1).segment)


# bucket_swept takes no radius: tracing only that traces nothing.
BUCKET_MIXES = [
    (detector, mix)
    for detector in ONE_CALL_BUCKET
    for mix in MIXES
    if not (detector == "bucket_swept" and mix == ("radius",))
]


@pytest.mark.parametrize(
    "detector, traced", BUCKET_MIXES, ids=[f"{d}-{'+'.join(m)}" for d, m in BUCKET_MIXES]
)
def test_one_call_bucket_forms_refuse_traced_arguments_and_say_what_to_do(detector, traced):
    with pytest.raises(ValueError, match="use jaxcontact.Search"):
        _traced_call(ONE_CALL_BUCKET[detector], traced)


def test_search_steps_take_traced_arguments_and_equal_the_exhaustive_form():
    search = Search(radius=RADIUS, compact=True)
    state = search.allocate(X, _surface(), x_prev=X_PREV, mask=MASK, pairs=Pairs(SLAVE_NODE))

    @jax.jit
    def step(state, x, nodes, radius, mask, slave_node):
        contact, state = search.closest(
            state, x, _surface(nodes), mask=mask, radius=radius, pairs=Pairs(slave_node)
        )
        crossing, state = search.swept(
            state, X_PREV, x, _surface(nodes), mask=mask, pairs=Pairs(slave_node)
        )
        return contact, crossing, state

    contact, crossing, state = step(state, *CONCRETE)
    want = all_to_all(X, _surface(), radius=RADIUS, mask=MASK, pairs=Pairs(SLAVE_NODE))
    np.testing.assert_array_equal(contact.to_contact(len(X)).segment, want.segment)
    paths = swept(X_PREV, X, _surface(), mask=MASK, pairs=Pairs(SLAVE_NODE))
    np.testing.assert_array_equal(crossing.to_crossing(len(X)).segment, paths.segment)
    assert not bool(state.overflow)


@pytest.mark.parametrize("state", [None, "state", 3])
def test_a_search_step_without_a_state_is_a_clear_error(state):
    search = Search(radius=RADIUS)
    with pytest.raises(ValueError, match="state must be the SearchState that search.allocate"):
        search.closest(state, X, _surface())
    with pytest.raises(ValueError, match="state must be the SearchState"):
        Search(radius=RADIUS).swept(state, X_PREV, X, _surface())


def test_pairs_must_be_a_pairs():
    with pytest.raises(ValueError, match="pairs must be a jaxcontact.Pairs; got dict"):
        all_to_all(X, _surface(), radius=RADIUS, pairs={"slave_node": SLAVE_NODE})


# -- the names 1.0 replaced ------------------------------------------------------------


def _same(got, want):
    for field, value in want._asdict().items():
        np.testing.assert_array_equal(np.asarray(getattr(got, field)), np.asarray(value), field)


@pytest.mark.parametrize("detector", ["all_to_all", "bucket_sort", "swept", "bucket_swept"])
def test_the_replaced_pair_keywords_warn_and_give_the_pairs_answer(detector):
    call = {**EXHAUSTIVE, **ONE_CALL_BUCKET}[detector]
    want = call(*CONCRETE)
    detect = getattr(jaxcontact, detector)
    args = (X, _surface()) if "swept" not in detector else (X_PREV, X, _surface())
    radius = {} if "swept" in detector else {"radius": RADIUS}
    with pytest.warns(
        DeprecationWarning, match=r"slave_node= .*replaced by pairs=jaxcontact\.Pairs"
    ):
        got = detect(*args, **radius, mask=MASK, slave_node=SLAVE_NODE)
    _same(got, want)


def test_the_replaced_search_names_warn_and_keep_working():
    with pytest.warns(DeprecationWarning, match='method="unbinned"'):
        old = Search(radius=RADIUS, method="dense")
    assert old == Search(radius=RADIUS, method="unbinned")
    with pytest.warns(DeprecationWarning, match=r"Pairs\(self_contact=True"):
        own = Search(radius=RADIUS, self_contact=True)
    node = np.arange(4, dtype=np.int32)
    with pytest.warns(DeprecationWarning, match="slave_node= are replaced by pairs="):
        state = own.allocate(NODES, _surface(), slave_node=node)
    with pytest.warns(DeprecationWarning, match="slave_node= are replaced by pairs="):
        contact, _ = own.closest(state, NODES, _surface(), slave_node=node)
    rule = Pairs(node, self_contact=True)
    _same(contact, all_to_all(NODES, _surface(), radius=RADIUS, pairs=rule))


def test_contact_forces_warns_and_equals_the_penalty():
    contact = all_to_all(X, _surface(), radius=RADIUS)
    assert bool(contact.active.any())
    with pytest.warns(DeprecationWarning, match=r"jaxcontact\.forces\.penalty"):
        on_slaves, on_master = jaxcontact.contact_forces(contact, 10.0)
    forces = penalty(contact, _surface(), 10.0)
    np.testing.assert_allclose(on_slaves, forces.on_slaves)
    np.testing.assert_allclose(on_master, jnp.sum(forces.on_master, axis=0), atol=FLOAT64_ATOL)


def test_the_wheel_lists_every_package_of_the_library_and_nothing_else():
    import re

    pyproject = (PACKAGE.parent / "pyproject.toml").read_text()
    (line,) = re.findall(r"^packages = \[(.*)\]$", pyproject, flags=re.M)
    listed = set(re.findall(r'"([\w.]+)"', line))
    found = {_module_name(path) for path in PACKAGE.rglob("__init__.py")}
    assert listed == found
    assert not any("bench" in name for name in listed)


def _not_segment_one_for_even_rows(slave, segment):
    return (segment != 1) | (slave % 2 == 1)


@pytest.mark.parametrize("form", ["all_to_all", "bucket_sort", "Search", "swept", "bucket_swept"])
def test_a_users_own_rule_composes_with_pairs(form):
    rule = Pairs(allow=_not_segment_one_for_even_rows)
    x = np.array([[1.5, -0.1], [1.5, -0.05], [1.4, -0.05], [1.6, -0.1]])
    x_prev = x + np.array([0.0, 0.3])
    without = Surface(NODES, SEGMENTS, np.array([True, False, True]))
    if form in ("swept", "bucket_swept"):
        detect = getattr(jaxcontact, form)
        got, plain, masked = (
            detect(x_prev, x, surface, pairs=pairs)
            for surface, pairs in ((_surface(), rule), (_surface(), None), (without, None))
        )
    elif form == "Search":
        search = Search(radius=RADIUS, compact=True)
        state = search.allocate(x, _surface(), pairs=rule)
        got = search.closest(state, x, _surface(), pairs=rule)[0].to_contact(len(x))
        plain = all_to_all(x, _surface(), radius=RADIUS)
        masked = all_to_all(x, without, radius=RADIUS)
    else:
        detect = getattr(jaxcontact, form)
        got, plain, masked = (
            detect(x, surface, radius=RADIUS, pairs=pairs)
            for surface, pairs in ((_surface(), rule), (_surface(), None), (without, None))
        )
    odd = np.arange(len(x)) % 2 == 1
    segment, plain_segment = np.asarray(got.segment), np.asarray(plain.segment)
    np.testing.assert_array_equal(segment[odd], plain_segment[odd])
    np.testing.assert_array_equal(segment[~odd], np.asarray(masked.segment)[~odd])
    assert (plain_segment == 1).all() and not (segment[~odd] == 1).any()


def test_a_users_rule_must_be_a_function():
    with pytest.raises(ValueError, match="Pairs.allow must be a function or None"):
        all_to_all(X, _surface(), radius=RADIUS, pairs=Pairs(allow=3))


def test_pairs_and_a_replaced_keyword_together_are_refused():
    with pytest.raises(TypeError, match="pass the pair rule as pairs= alone"):
        all_to_all(X, _surface(), radius=RADIUS, pairs=Pairs(SLAVE_NODE), slave_node=SLAVE_NODE)
    with pytest.raises(TypeError, match="pass the pair rule as pairs= alone"):
        Search(radius=RADIUS).allocate(X, _surface(), pairs=Pairs(), slave_body=SLAVE_NODE)


def test_a_replaced_keyword_warns_whatever_its_value():
    with pytest.warns(DeprecationWarning, match="self_contact="):
        all_to_all(X, _surface(), radius=RADIUS, self_contact=False)
    with pytest.warns(DeprecationWarning, match="slave_node="):
        swept(X_PREV, X, _surface(), slave_node=None)


def test_search_steps_take_plain_lists_as_the_one_call_forms_do():
    search = Search(radius=RADIUS)
    state = search.allocate(X, _surface(), x_prev=X_PREV)
    crossing, _ = search.swept(state, X_PREV.tolist(), X.tolist(), _surface())
    np.testing.assert_array_equal(crossing.segment, swept(X_PREV, X, _surface()).segment)


def test_sharded_takes_the_default_pair_rule():
    mesh = jax.make_mesh((1,), ("slaves",))
    got = jaxcontact.sharded(all_to_all, mesh)(X, _surface(), radius=RADIUS, pairs=Pairs())
    np.testing.assert_array_equal(got.segment, all_to_all(X, _surface(), radius=RADIUS).segment)
