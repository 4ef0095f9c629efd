"""Every tolerance of the suite comes from tests/support/tolerances.py.

A numeric literal given as a comparison's tolerance (``atol=``, ``rtol=``,
``rel=``, ``abs=``, or in their positions of ``assert_allclose``,
``allclose``, ``isclose`` and ``pytest.approx``) fails here: a tolerance
written where it is used carries no reason for its size and drifts from the
table's. Zero is allowed, as it turns a tolerance off rather than sizing one
(``rtol=0`` beside a named ``atol``).

tests/sim/ and tests/problems/ are left out until their literals move too
(the simulations' tests are edited apart from the rest of the suite).
"""

import ast
import pathlib

TESTS = pathlib.Path(__file__).resolve().parent
TABLE = TESTS / "support" / "tolerances.py"
NOT_YET: tuple[str, ...] = ()
KEYWORDS = {"atol", "rtol", "rel", "abs"}
# Function name -> the positions (after the compared values) of its tolerances.
POSITIONS = {"assert_allclose": (2, 3), "allclose": (2, 3), "isclose": (2, 3), "approx": (1, 2)}


def _number(node) -> float | None:
    """The value of a numeric literal (signed), else None."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        value = _number(node.operand)
        return None if value is None else -value if isinstance(node.op, ast.USub) else value
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return node.value
    return None


def literal_tolerances(source: str, name: str = "<source>") -> list[str]:
    """``name:line: what`` for each tolerance in ``source`` given as a nonzero literal."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        given = [(kw.arg, kw.value) for kw in node.keywords if kw.arg in KEYWORDS]
        function = node.func.attr if isinstance(node.func, ast.Attribute) else None
        function = node.func.id if isinstance(node.func, ast.Name) else function
        for position in POSITIONS.get(function, ()):
            if position < len(node.args):
                given.append((f"argument {position}", node.args[position]))
        for what, value in given:
            number = _number(value)
            if number is not None and number != 0:
                found.append((value.lineno, value.col_offset, f"{what}={number!r}"))
    return [f"{name}:{line}: {what}" for line, _, what in sorted(found)]


def test_no_tolerance_is_a_literal_outside_the_table():
    found = []
    for path in sorted(TESTS.rglob("*.py")):
        relative = path.relative_to(TESTS)
        if path == TABLE or relative.parts[0] in NOT_YET:
            continue
        found += literal_tolerances(path.read_text(), f"tests/{relative.as_posix()}")
    assert found == [], "name these in tests/support/tolerances.py:\n" + "\n".join(found)


def test_the_scan_finds_every_form_of_a_literal_tolerance():
    planted = """
np.testing.assert_allclose(a, b, atol=1e-6)
np.testing.assert_allclose(a, b, 1e-6)
np.testing.assert_allclose(a, b, 0, -2)
assert a == pytest.approx(b, rel=0.1)
assert a == pytest.approx(b, abs=1)
assert a == approx(b, 1e-3)
np.isclose(a, b, rtol=1e-9)
jnp.allclose(a, b, atol=+1e-3)
"""
    assert [line.split(": ", 1)[1] for line in literal_tolerances(planted)] == [
        "atol=1e-06",
        "argument 2=1e-06",
        "argument 3=-2",
        "rel=0.1",
        "abs=1",
        "argument 1=0.001",
        "rtol=1e-09",
        "atol=0.001",
    ]


def test_the_scan_passes_named_and_zero_tolerances():
    named = """
np.testing.assert_allclose(a, b, rtol=0, atol=FLOAT32_ATOL)
np.testing.assert_allclose(a, b, FLOAT64_RTOL, 0.0)
assert a == pytest.approx(b, rel=tol.HERTZ_RTOL, abs=2 * FD_ATOL)
np.testing.assert_allclose(a, b)
"""
    assert literal_tolerances(named) == []
