"""The documentation site's API reference (docs/api/) names every public name.

A new public name without a ``::: name`` entry fails here, before anyone builds the
site. The site itself is built by ``mkdocs build --strict`` in .ci/run (it needs the
docs extra, which the test extra leaves out); a missing page or link fails there.
"""

import importlib
import importlib.util
import pathlib
import re
import types

ROOT = pathlib.Path(__file__).resolve().parent.parent
# The documented namespaces: the package, its two public modules, and the simulation's
# parts and problems.
MODULES = (
    ["jaxcontact", "jaxcontact.forces", "jaxcontact.scenes", "jaxcontact.sim"]
    + [
        f"jaxcontact.sim.{name}"
        for name in "materials elements.q4 elements.triangle explicit coupling tools static".split()
    ]
    + [
        f"jaxcontact.problems.{name}"
        for name in (
            "cutting cutting.config cutting.model cutting.report cutting.machining "
            "ploughing ploughing.config ploughing.model hertz hertz.config hertz.model hertz.theory"
        ).split()
    ]
)
DIRECTIVE = re.compile(r"^::: *(\S+)", re.M)


def public_names(module_name: str) -> dict:
    """name -> object: a package's re-exports, or the names a module defines."""
    module = importlib.import_module(module_name)
    package = hasattr(module, "__path__")
    return {
        name: value
        for name, value in vars(module).items()
        if not name.startswith("_")
        and not isinstance(value, types.ModuleType)
        and (package or getattr(value, "__module__", module_name) == module_name)
    }


def resolve(path: str):
    """What ``path`` names as mkdocstrings (griffe) reads it: a package's submodule before
    an attribute of the same name (``jaxcontact.sim.ploughing`` is the module, not the
    function)."""
    first, *rest = path.split(".")
    value, dotted = importlib.import_module(first), first
    for part in rest:
        dotted = f"{dotted}.{part}"
        if hasattr(value, "__path__") and importlib.util.find_spec(dotted) is not None:
            value = importlib.import_module(dotted)
        else:
            value = getattr(value, part)
    return value


def directives() -> list[str]:
    return [
        path
        for page in sorted((ROOT / "docs" / "api").glob("*.md"))
        for path in DIRECTIVE.findall(page.read_text())
    ]


def documented_ids() -> set[int]:
    """By identity: jaxcontact.Search is jaxcontact._search.Search, one entry.
    A module's entry renders its members (the default), so it documents their names."""
    documented = set()
    for path in directives():
        value = resolve(path)
        documented.add(id(value))
        if isinstance(value, types.ModuleType) and not hasattr(value, "__path__"):
            documented |= {id(member) for member in public_names(value.__name__).values()}
    return documented


def test_every_public_name_has_a_reference_entry():
    documented = documented_ids()
    missing = [
        f"{module}.{name}"
        for module in MODULES
        for name, value in public_names(module).items()
        if id(value) not in documented
    ]
    assert not missing, f"no ::: entry in docs/api/ for {missing}"


def test_the_public_names_are_found():
    # The test above means something only if it sees the names the issue lists.
    import jaxcontact

    names = public_names("jaxcontact")
    assert {"Surface", "Search", "all_to_all", "validate", "Smooth", "check_overflow"} <= set(names)
    assert {"penalty", "coulomb", "Friction", "Forces"} <= set(public_names("jaxcontact.forces"))
    # 2.0 removed these (they fail naming their replacement: jaxcontact._removed).
    assert not {"clear_sizes", "sharded", "contact_forces"} & set(names)
    assert not {"contact_forces"} & set(public_names("jaxcontact.forces"))
    # Every name of __all__ but the two public modules, documented by their own pages.
    assert set(names) == set(jaxcontact.__all__) - {"forces", "scenes"}
    assert len(names) == 20


# -- __all__ on every public module -------------------------------------------------------


def public_modules() -> list[str]:
    """The package and every module under it with no underscored part in its name."""
    import pkgutil

    import jaxcontact

    return ["jaxcontact"] + [
        found.name
        for found in pkgutil.walk_packages(jaxcontact.__path__, "jaxcontact.")
        if not any(part.startswith("_") for part in found.name.split("."))
    ]


def all_problems(module: types.ModuleType) -> list[str]:
    """What is wrong with ``module.__all__``: missing, a name that does not resolve, a
    public function or class the module defines (or a package re-exports) left out, a
    name ``dir`` does not show."""
    name = module.__name__
    listed = getattr(module, "__all__", None)
    if not isinstance(listed, list | tuple) or not all(isinstance(n, str) for n in listed):
        return [f"{name} has no __all__ of names"]
    problems = [f"{name}.__all__ lists {n!r} twice" for n in set(listed) if listed.count(n) > 1]
    package = hasattr(module, "__path__")
    for entry in listed:
        # A package's submodule resolves whether or not it was imported yet.
        submodule = package and importlib.util.find_spec(f"{name}.{entry}") is not None
        if not (hasattr(module, entry) or submodule):
            problems.append(f"{name}.__all__ lists {entry!r}, which does not resolve")
    for entry, value in vars(module).items():
        if entry.startswith("_") or isinstance(value, types.ModuleType) or entry in listed:
            continue
        own = callable(value) and getattr(value, "__module__", None) == name
        if own or (package and getattr(value, "__module__", "").startswith("jaxcontact")):
            problems.append(f"{name}.{entry} is public but not in __all__")
    unseen = set(listed) - set(dir(module))
    if unseen:
        problems.append(f"dir({name}) does not show {sorted(unseen)}")
    return problems


def test_every_public_module_has_an_all_of_its_public_names():
    modules = public_modules()
    # The walk finds the modules the issue names (an empty walk would pass the loop).
    assert {"jaxcontact.forces", "jaxcontact.scenes", "jaxcontact.sim.coupling"} <= set(modules)
    assert {"jaxcontact.problems.cutting.model", "jaxcontact.problems.hertz.theory"} <= set(modules)
    assert not any("._" in module for module in modules)
    problems = [p for module in modules for p in all_problems(importlib.import_module(module))]
    assert not problems, problems


def test_dir_of_forces_and_scenes_shows_their_public_names_only():
    import jaxcontact.forces
    import jaxcontact.scenes

    for module in (jaxcontact.forces, jaxcontact.scenes):
        assert dir(module) == sorted(module.__all__)
    assert {"coulomb", "penalty", "Friction", "Forces"} == set(dir(jaxcontact.forces))


def test_the_all_check_finds_what_is_wrong():
    # all_problems on modules made wrong on purpose: each fault is named.
    bare = types.ModuleType("jaxcontact_fake")
    assert all_problems(bare) == ["jaxcontact_fake has no __all__ of names"]

    def helper():
        pass

    helper.__module__ = "jaxcontact_fake"
    fake = types.ModuleType("jaxcontact_fake")
    fake.__all__ = ["gone", "kept", "kept"]
    fake.kept = 1.0
    fake.helper = helper
    fake._private = helper
    found = all_problems(fake)
    assert "jaxcontact_fake.__all__ lists 'kept' twice" in found
    assert "jaxcontact_fake.__all__ lists 'gone', which does not resolve" in found
    assert "jaxcontact_fake.helper is public but not in __all__" in found
    assert "dir(jaxcontact_fake) does not show ['gone']" in found
    assert len(found) == 4
