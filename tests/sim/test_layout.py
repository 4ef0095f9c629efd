"""The parts load no problem, and only a problem's own package and the command line import one."""

from __future__ import annotations

import ast
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "jaxcontact"


def test_importing_a_part_loads_no_problem():
    code = (
        "import jaxcontact.sim.materials, sys; "
        "print([m for m in sys.modules if m.startswith('jaxcontact.problems')])"
    )
    found = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert found.stdout.strip() == "[]"


def _imported(path: pathlib.Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names |= {f"{node.module}.{alias.name}" for alias in node.names}
    return names


def test_only_a_problems_own_package_and_the_cli_import_a_problem():
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE).parts
        for name in _imported(path):
            if not name.startswith("jaxcontact.problems."):
                continue
            problem = name.split(".")[2]
            if problem.startswith("_"):  # the demos' shared helpers, no problem
                continue
            own = relative[:2] == ("problems", problem)
            if not own and relative != ("_cli.py",):
                wrong.append(f"{'/'.join(relative)} imports {name}")
    assert wrong == []
