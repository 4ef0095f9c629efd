"""Every ```python block of README.md and docs/ runs, page by page.

A page's blocks run in order in one namespace, so later blocks use what
earlier ones built. A block that starts with ``>>>`` runs as a doctest. Sizes
written for reading are cut down by ``SMALLER`` so that CI runs every line in
seconds: the same programs at another size. Blocks not meant to run are
```bash or ```text; an unlabelled fence fails ``test_every_block_is_labelled``.
"""

import doctest
import pathlib
import re
import textwrap

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^( *)```(\S*)\n(.*?)^\1```", re.S | re.M)
LANGUAGES = {"python", "bash", "text"}

# page -> (as written, as run): sizes cut down, and the one gradient of the
# cutting run taken as a value (tests/problems/test_cutting.py checks that gradient
# against finite differences in float64; compiling it again here would double
# CI's longest compile).
SMALLER = {
    "docs/guides/search.md": [
        ("cutting_scene(81_939,", "cutting_scene(2_000,"),
        ("curling_chip(10_000)", "curling_chip(2_000)"),
    ],
    "docs/simulation.md": [
        ("Ploughing(10_000, travel=0.5)", "Ploughing(300, travel=0.1)"),
        (
            "print(jax.grad(force, argnums=(0, 1))(math.radians(5.0), 0.3))",
            "value = force(math.radians(5.0), 0.3)",
        ),
        # tests/problems/test_hertz.py checks this gradient; here the value, whose program the
        # solve above compiled.
        (
            "print(jax.grad(hertz.peak_pressure, argnums=1)(block, problem))",
            "peak = hertz.peak_pressure(block, problem)",
        ),
    ],
}

# page -> what its blocks must have left in their namespace.
CHECKS = {
    "README.md": lambda ns: int(ns["contact"].active.sum()) > 0,
    "docs/getting-started.md": lambda ns: (
        int(ns["contact"].active.sum()) > 0
        and ns["gaps"].shape == (10, ns["x"].shape[0])
        and bool((ns["gaps"] < 0).any())  # the loop reached the tool
    ),
    "docs/guides/search.md": lambda ns: (
        int(ns["own"].active.sum()) > 0
        and ns["grad"].shape == ns["scene"].x.shape
        and int(ns["crossing"].crossed.sum()) > 0
        and bool(abs(ns["nodal"]).sum() > 0)
    ),
    "docs/guides/bodies.md": lambda ns: int(ns["entries"].active.sum()) > 0,
    # The parts' worked example: the wedge pressed in, its mean pressure near Prandtl's
    # limit (above it by the hardening, below the hardened limit at eps_p = 1).
    "docs/parts.md": lambda ns: (
        not bool(ns["state"].overflow) and 1.0 < ns["pressure"] / ns["prandtl"] < 1.5
    ),
    "docs/guides/friction.md": lambda ns: (
        ns["on_slaves"].shape == ns["xs"].shape
        and bool(abs(ns["on_slaves"]).sum() > 0)
        and bool(abs(ns["friction"].traction).sum() > 0)  # it slid under friction
    ),
    "docs/guides/devices.md": lambda ns: (
        ns["contacts"].gap.shape == ns["xs"].shape[:2]
        and ns["gap"].shape == ns["x_split"].shape[:1]
        and ns["on_tool"].shape == (2,)
        and bool(abs(ns["on_tool"]).sum() > 0)  # the tool presses on the split slaves
    ),
    "docs/simulation.md": lambda ns: (
        0 < float(ns["value"]) < 1000  # N per mm: the tool pushes into the layer
        and float(ns["history"].force[:, 0].mean()) > 0  # the tool pushes the workpiece in -x
        and all(bool(abs(g) > 0) for g in (ns["grads"].rake, ns["grads"].stiffness))
        and ns["result"].l2_error < 0.05  # the Hertz indentation: the target
        and float(ns["peak"]) == ns["result"].peak
    ),
}

SLOW = {"docs/simulation.md"}


def name(page: pathlib.Path) -> str:
    return page.relative_to(ROOT).as_posix()


def blocks(page: pathlib.Path):
    """``(language, code, line)`` of each fenced block, ``line`` its first code line (0-based)."""
    text = page.read_text()
    for match in FENCE.finditer(text):
        line = text.count("\n", 0, match.start(3))
        yield match.group(2), textwrap.dedent(match.group(3)), line


def run_page(page: pathlib.Path) -> dict:
    namespace: dict = {"__name__": f"docs:{name(page)}"}
    substitutions = SMALLER.get(name(page), [])
    for language, code, line in blocks(page):
        if language != "python":
            continue
        if code.lstrip().startswith(">>>"):
            test = doctest.DocTestParser().get_doctest(code, namespace, name(page), str(page), line)
            runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
            runner.run(test)
            assert runner.failures == 0, f"{name(page)}:{line + 1}: doctest failed"
            continue
        for written, smaller in substitutions:
            code = code.replace(written, smaller)
        # Leading newlines: a traceback names the page's own line numbers.
        exec(compile("\n" * line + code, str(page), "exec"), namespace)
    return namespace


def page_params():
    for page in PAGES:
        if not any(language == "python" for language, _, _ in blocks(page)):
            continue
        marks = [pytest.mark.slow, pytest.mark.simulation] if name(page) in SLOW else []
        yield pytest.param(page, id=name(page), marks=marks)


@pytest.mark.parametrize("page", list(page_params()))
def test_page_runs(page):
    namespace = run_page(page)
    check = CHECKS.get(name(page))
    assert check is None or check(namespace)


def test_every_block_is_labelled():
    unlabelled = [
        f"{name(page)}:{line}: ```{language}"
        for page in PAGES
        for language, _, line in blocks(page)
        if language not in LANGUAGES
    ]
    assert not unlabelled


def test_every_substitution_applies():
    for page, substitutions in SMALLER.items():
        code = "".join(code for language, code, _ in blocks(ROOT / page) if language == "python")
        for written, _ in substitutions:
            assert written in code, (page, written)
    assert set(CHECKS) | set(SLOW) <= {name(page) for page in PAGES}
