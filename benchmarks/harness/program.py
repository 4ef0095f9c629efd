"""The shape of a compiled XLA program, read from its optimised HLO and XLA's own accounts.

What the maintained suites report of a jitted step beside its time (``benchmarks/targets.py``
for each ``Search.closest`` form), as ``describe(compiled)``:

- **kernels**: the thunks XLA's CPU runtime runs for one call. Every instruction of the entry
  computation and of each computation it runs (a ``while``'s condition and body, a
  ``conditional``'s branches, a ``call``'s callee), less those that run nothing
  (``FREE``). A fusion is one kernel; a loop body is counted once, not once per trip; the
  ``while``, ``conditional`` and ``call`` instructions themselves only run what they hold.
  ``kernel_kinds`` sorts them by what they do (``KINDS``: an elementwise fusion, a gather, a
  reduction, a sort, ...), as the compile time of a program grows with its kernels of each kind.
- **loop trips**: each ``while`` loop's trip count (a sequential loop on a CPU or GPU: its body
  runs once per trip, one after the other), where XLA knows it (the ``known_trip_count`` of
  the loop's backend config: a ``lax.scan`` or a ``fori_loop`` of static bounds), else None
  (a loop that stops on a value, or of bounds only known at run time).
- **bytes accessed**: what XLA's cost analysis (``compiled.cost_analysis()``) says one call
  reads and writes, beside the least any program with the same inputs and outputs moves (the
  inputs' bytes plus the outputs'). XLA counts a loop's body once whatever its trip count, so
  the account of a program with loops is a floor of its traffic, read with its trip counts.

Example:
  >>> import jax, jax.numpy as jnp
  >>> def scan(x):
  ...     return jax.lax.scan(lambda c, _: (c * 1.5 + 1.0, None), x, None, length=37)[0]
  >>> shape = describe(jax.jit(scan).lower(jnp.ones(8, jnp.float32)).compile())
  >>> shape.loops, largest_trip(shape.loops), shape.minimum_bytes
  ((37,), 37, 64)
"""

from __future__ import annotations

import re
from collections import Counter
from typing import NamedTuple

import numpy as np

# Instructions that run no kernel of their own.
FREE = frozenset({"parameter", "constant", "get-tuple-element", "tuple", "bitcast", "opt-barrier"})
# Instructions that run other computations, no kernel of their own.
CONTROL = frozenset({"while", "conditional", "call"})
# The callees a control instruction runs: what ``while``, ``conditional`` and ``call`` name.
_CALLEES = re.compile(
    r"(?:condition|body|to_apply|true_computation|false_computation)=%([\w.\-]+)"
    r"|branch_computations=\{([^}]*)\}"
)
_TRIPS = re.compile(r'"known_trip_count":\{"n":"(\d+)"\}')

ELEMENTWISE = "elementwise"
GATHER = "gather + elementwise"
SCALAR = "reduction to a scalar"
ROWS = "row reduction (N/8 x 8 -> N/8)"
WINDOW = "reduce-window (a stage of a tree reduction, or cumsum)"
SORT = "sort"
SCATTER = "scatter-add"
KINDS = (ELEMENTWISE, GATHER, SCALAR, ROWS, WINDOW, SORT, SCATTER)


class Instruction(NamedTuple):
    """One instruction of an optimised HLO text."""

    line: str  # as the text has it, comments left out
    opcode: str  # "fusion", "while", "sort", ...
    computation: str  # the computation it belongs to


class Shape(NamedTuple):
    """``describe``'s account of one compiled program."""

    kernels: int  # thunks run per call (``kernel_lines``)
    kinds: dict  # kind (``KINDS``) -> how many of the kernels
    loops: tuple  # per ``while`` loop, its trip count, or None where XLA does not know it
    bytes_accessed: float | None  # XLA's cost analysis (loop bodies once); None: no account
    minimum_bytes: int  # the inputs' bytes plus the outputs'


def opcode(line: str) -> str:
    """The opcode of an instruction line: the word after its result type (a tuple type's
    parentheses skipped, however nested)."""
    rest = line.split("= ", 1)[1] if "= " in line else ""
    if rest.startswith("("):
        depth = 0
        for at, char in enumerate(rest):
            depth += {"(": 1, ")": -1}.get(char, 0)
            if depth == 0:
                rest = rest[at + 1 :]
                break
    else:
        rest = rest.split(" ", 1)[1] if " " in rest else ""
    found = re.match(r"\s*([a-z][a-z0-9\-]*)\(", rest)
    return found.group(1) if found else ""


def computations(text: str) -> tuple[str, dict[str, list[str]]]:
    """``(entry, name -> instruction lines)`` of an optimised HLO ``text`` (every
    computation's, fusion bodies among them)."""
    text = re.sub(r"/\*.*?\*/", "", text)
    bodies, name, entry = {}, None, None
    for line in text.splitlines():
        head = re.match(r"^(ENTRY )?%(\S+) .*\{$", line)
        if head:
            name = head.group(2)
            bodies[name] = []
            entry = name if head.group(1) else entry
        elif line.startswith("}"):
            name = None
        elif name and re.match(r"^\s+(ROOT )?%", line):
            bodies[name].append(line.strip())
    if entry is None:
        raise ValueError("no ENTRY computation in the text: pass compiled.as_text()")
    return entry, bodies


def callees(line: str) -> list[str]:
    """The computations a control instruction line (``CONTROL``) runs, in order."""
    return [
        callee
        for single, listed in _CALLEES.findall(line)
        for callee in ([single] if single else re.findall(r"%([\w.\-]+)", listed))
    ]


def is_kernel(code: str) -> bool:
    """Whether an instruction of opcode ``code`` is a kernel (one thunk) of its own."""
    return bool(code) and code not in FREE | CONTROL


def executed(text: str) -> list[Instruction]:
    """Every instruction a call runs: the entry computation's and those of every computation
    a control instruction (``CONTROL``) reaches, each computation once (a loop body is not
    repeated per trip); a fusion's body is not entered (it is the fusion's one kernel)."""
    entry, bodies = computations(text)
    found, todo, seen = [], [entry], set()
    while todo:
        name = todo.pop(0)
        if name in seen or name not in bodies:
            continue
        seen.add(name)
        for line in bodies[name]:
            code = opcode(line)
            found.append(Instruction(line, code, name))
            if code in CONTROL:
                todo += callees(line)
    return found


def kernel_lines(text: str) -> list[str]:
    """The lines of an optimised HLO ``text`` that are its kernels (one thunk each)."""
    return [each.line for each in executed(text) if is_kernel(each.opcode)]


def kind_of(line: str, bodies: dict[str, list[str]]) -> str:
    """What one kernel line does, one of ``KINDS``: by the operations in its fusion's body
    (``bodies``: ``computations``' second item), or its own opcode for an unfused one."""
    called = re.search(r"calls=%([\w.\-]+)", line)
    lines = bodies.get(called.group(1), []) if called else [line]
    ops = {opcode(each) for each in lines}
    # A scalar result: the type right after "= " has no dimensions (or is a tuple of such).
    scalar = re.search(r"= (?:\w+\[\]|\([^)]*\w+\[\][^)]*\))", line) is not None
    if "sort" in ops:
        return SORT
    if "scatter" in ops:
        return SCATTER
    if "reduce-window" in ops:
        return WINDOW
    if "reduce" in ops:
        return SCALAR if scalar else ROWS
    if "gather" in ops or "dynamic-slice" in ops:
        return GATHER
    return ELEMENTWISE


def kernel_kinds(text: str) -> dict[str, int]:
    """kind (``KINDS``, in that order) -> how many of the program's kernels are of it."""
    _, bodies = computations(text)
    counts = Counter(kind_of(line, bodies) for line in kernel_lines(text))
    return {kind: counts[kind] for kind in KINDS}


def trip_counts(text: str) -> tuple[int | None, ...]:
    """Each ``while`` loop's trip count as XLA knows it (``known_trip_count``), None where
    it does not; in the order the loops are reached."""
    trips = []
    for each in executed(text):
        if each.opcode == "while":
            known = _TRIPS.search(each.line)
            trips.append(int(known.group(1)) if known else None)
    return tuple(trips)


def largest_trip(trips) -> int | str | None:
    """A table cell for ``trip_counts``: None with no loop, ``"unknown"`` where any loop's
    count is unknown (the largest cannot be known), else the largest count."""
    if not trips:
        return None
    if any(trip is None for trip in trips):
        return "unknown"
    return max(trips)


def _bytes(avals) -> int:
    import jax

    return int(
        sum(np.prod(a.shape, dtype=np.int64) * a.dtype.itemsize for a in jax.tree.leaves(avals))
    )


def minimum_bytes(compiled) -> int:
    """The inputs' bytes plus the outputs': what any program with this signature moves."""
    return _bytes(compiled.in_avals) + _bytes(compiled.out_info)


def bytes_accessed(compiled) -> float | None:
    """XLA's cost analysis of one call's bytes read and written (a loop's body once), or
    None where the backend gives none."""
    analysis = compiled.cost_analysis()
    if isinstance(analysis, (list, tuple)):  # older jax: one dict per device program
        analysis = analysis[0] if analysis else None
    if not analysis or "bytes accessed" not in analysis:
        return None
    return float(analysis["bytes accessed"])


def describe(compiled) -> Shape:
    """The ``Shape`` of a compiled program (``jax.jit(f).lower(*args).compile()``)."""
    text = compiled.as_text()
    kernels = kernel_lines(text)
    return Shape(
        kernels=len(kernels),
        kinds=kernel_kinds(text),
        loops=trip_counts(text),
        bytes_accessed=bytes_accessed(compiled),
        minimum_bytes=minimum_bytes(compiled),
    )
