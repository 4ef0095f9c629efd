"""The public surface of 2.0: its layout, every mix of concrete and traced
arguments, and the names 2.0 removed (they fail, naming their replacement)."""

import ast
import importlib
import pathlib
import subprocess
import sys

import jax
import numpy as np
import pytest

import jaxcontact
from jaxcontact import (
    Contact,
    Pairs,
    Search,
    Surface,
    _removed,
    all_to_all,
    bucket_sort,
    bucket_swept,
    swept,
)
from tests.support.helpers import local_atol

PACKAGE = pathlib.Path(jaxcontact.__file__).resolve().parent
# The public names that are submodules.
MODULES = ("forces", "scenes")

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
    above = {"jaxcontact", "jaxcontact._detect", "jaxcontact._search"}
    for name, targets in graph.items():
        if name.startswith("jaxcontact._pipeline"):
            assert not targets & above, (name, targets & above)
            assert not any(target.startswith("jaxcontact._query") for target in targets), name


def test_every_public_name_is_documented():
    public = [name for name in dir(jaxcontact) if not name.startswith("_")]
    # dir() lists __all__ (and __version__): the new names, none that 2.0 removed.
    assert sorted(public) == sorted(jaxcontact.__all__)
    assert {"Pairs", "Smooth", "check_overflow"} <= set(public)
    assert not {"clear_sizes", "sharded", "contact_forces"} & set(public)
    for name in public:
        # The submodules (forces, scenes) by import: test_import_gives_every_public_name
        # checks that the package itself gives them.
        value = importlib.import_module(f"jaxcontact.{name}") if name in MODULES else None
        value = getattr(jaxcontact, name) if value is None else value
        if callable(value):
            assert value.__doc__ and len(value.__doc__) > 40, name


def test_import_gives_every_public_name():
    # A fresh process: in this one another test may already have imported the
    # submodules. docs/contract.md calls jaxcontact.forces.coulomb after a
    # plain ``import jaxcontact``.
    code = (
        "import jaxcontact\n"
        "for name in jaxcontact.__all__:\n"
        "    getattr(jaxcontact, name)\n"
        "print(jaxcontact.forces.penalty.__name__, jaxcontact.scenes.grid.__name__)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=PACKAGE.parent
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["penalty", "grid"]


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


# -- the names 2.0 removed ---------------------------------------------------------------


def _same(got, want):
    for field, value in want._asdict().items():
        np.testing.assert_array_equal(np.asarray(getattr(got, field)), np.asarray(value), field)


# The removed attributes of the package and its forces (tests/sim/test_parts.py checks
# the parts' and the problems'); Search(method=...) is a value, not an attribute (below).
REMOVED_ATTRIBUTES = [
    name
    for name in _removed.REMOVED
    if "(" not in name and name.rpartition(".")[0] in ("jaxcontact", "jaxcontact.forces")
]


@pytest.mark.parametrize("name", REMOVED_ATTRIBUTES)
def test_a_removed_attribute_fails_naming_its_replacement(name):
    module, _, attribute = name.rpartition(".")
    replacement, _, removed_in = _removed.REMOVED[name]
    with pytest.raises(AttributeError) as raised:
        getattr(importlib.import_module(module), attribute)
    assert str(raised.value) == f"{name} was removed in {removed_in}: {replacement}"
    assert not hasattr(importlib.import_module(module), attribute)


def test_the_removed_attributes_are_the_four_of_2_0():
    # The parametrisation above is over the table: an emptied table would pass it.
    assert set(REMOVED_ATTRIBUTES) == {
        "jaxcontact.clear_sizes",
        "jaxcontact.sharded",
        "jaxcontact.contact_forces",
        "jaxcontact.forces.contact_forces",
    }
    assert "penalty" in _removed.REMOVED["jaxcontact.forces.contact_forces"][0]


def test_an_unknown_attribute_is_a_plain_attribute_error():
    with pytest.raises(AttributeError, match="module 'jaxcontact' has no attribute 'nothing'"):
        jaxcontact.nothing  # noqa: B018


def test_the_removed_search_method_fails_naming_its_replacement():
    with pytest.raises(
        ValueError, match=r'method="dense"\) was removed in 2\.0: use method="unbinned"'
    ):
        Search(radius=RADIUS, method="dense")


@pytest.mark.parametrize("detector", ["all_to_all", "bucket_sort", "swept", "bucket_swept"])
@pytest.mark.parametrize("keyword", ["slave_node", "slave_body", "self_contact"])
def test_a_removed_pair_keyword_fails_as_python_fails_it(detector, keyword):
    # Whatever its value, None and False too: pairs=Pairs(...) is the one form.
    detect = getattr(jaxcontact, detector)
    args = (X, _surface()) if "swept" not in detector else (X_PREV, X, _surface())
    radius = {} if "swept" in detector else {"radius": RADIUS}
    with pytest.raises(TypeError, match=f"unexpected keyword argument '{keyword}'"):
        detect(*args, **radius, mask=MASK, **{keyword: None})


def test_the_search_takes_no_pair_keywords_and_no_self_contact():
    node = np.arange(4, dtype=np.int32)
    with pytest.raises(TypeError, match="unexpected keyword argument 'self_contact'"):
        Search(radius=RADIUS, self_contact=True)
    search = Search(radius=RADIUS)
    with pytest.raises(TypeError, match="unexpected keyword argument 'slave_node'"):
        search.allocate(NODES, _surface(), slave_node=node)
    rule = Pairs(node, self_contact=True)
    state = search.allocate(NODES, _surface(), pairs=rule)
    with pytest.raises(TypeError, match="unexpected keyword argument 'slave_node'"):
        search.closest(state, NODES, _surface(), slave_node=node)
    with pytest.raises(TypeError, match="unexpected keyword argument 'slave_body'"):
        search.swept(state, NODES, NODES, _surface(), slave_body=node)
    # The rule passed to each call, as Search(self_contact=True) applied it.
    contact, _ = search.closest(state, NODES, _surface(), pairs=rule)
    _same(contact, all_to_all(NODES, _surface(), radius=RADIUS, pairs=rule))


def test_the_wheel_lists_every_package_of_the_library_and_nothing_else():
    import re

    pyproject = (PACKAGE.parent / "pyproject.toml").read_text()
    (line,) = re.findall(r"^packages = \[(.*?)\]$", pyproject, flags=re.M | re.S)
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


def test_search_steps_take_plain_lists_as_the_one_call_forms_do():
    search = Search(radius=RADIUS)
    state = search.allocate(X, _surface(), x_prev=X_PREV)
    crossing, _ = search.swept(state, X_PREV.tolist(), X.tolist(), _surface())
    np.testing.assert_array_equal(crossing.segment, swept(X_PREV, X, _surface()).segment)


def test_shard_map_over_a_detector_takes_the_pair_rule_split_with_the_slaves():
    # The route to many devices (jaxcontact.sharded is gone): the user's own
    # shard_map, the rule's per-slave array split as the slaves are. Slave 2
    # is node 1: without the rule it meets segment 0, with it nothing.
    mesh = jax.make_mesh((1,), ("slaves",))

    def detect(x, slave_node):
        return all_to_all(x, _surface(), radius=RADIUS, pairs=Pairs(slave_node))

    spec = jax.sharding.PartitionSpec("slaves")
    # Per-slave fields split as x's rows; the bool[] overflow one per program.
    fields = Contact(*[spec] * len(Contact._fields))._replace(overflow=jax.sharding.PartitionSpec())
    # check_vma=False: the detectors' conds return constants where they skip
    # work, which shard_map's check of varying axes refuses (docs/guides/devices.md).
    mapped = jax.shard_map(
        detect, mesh=mesh, in_specs=(spec, spec), out_specs=fields, check_vma=False
    )
    # Placed split as in_specs say (newer JAX refuses a sharding that differs).
    placed = jax.sharding.NamedSharding(mesh, spec)
    got = jax.jit(mapped)(jax.device_put(X, placed), jax.device_put(SLAVE_NODE, placed))
    want = all_to_all(X, _surface(), radius=RADIUS, pairs=Pairs(SLAVE_NODE))
    _same(got, want)
    assert int(want.segment[2]) == -1
    assert int(all_to_all(X, _surface(), radius=RADIUS).segment[2]) == 0
