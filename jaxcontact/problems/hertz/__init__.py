"""A rigid cylinder pressed into an elastic block, against Hertz's line contact.

The shape every problem has: ``Indentation`` (R, P, E, ν, ``config``),
``setup(problem, across) -> Block`` (the mesh), ``equilibrium`` (the one
static step, by ``jaxcontact.sim.static``) and ``run(problem, across) ->
Result`` (``model``); ``theory`` is Hertz's solution it is set against;
``demo`` is ``jaxcontact demo --scene hertz``. ``model``'s docstring
describes the model.
"""

from jaxcontact.problems.hertz.config import (
    FINE,
    MESHES,
    MOST_WIDTH,
    NOMINAL,
    SEGMENTS_PER_ELEMENT,
    SPAN,
    Indentation,
)
from jaxcontact.problems.hertz.model import (
    Block,
    Equilibrium,
    Result,
    Solver,
    equilibrium,
    fit_half_width,
    peak_pressure,
    run,
    setup,
)
from jaxcontact.problems.hertz.theory import (
    Hertz,
    hertz,
)

__all__ = [
    "FINE",
    "MESHES",
    "MOST_WIDTH",
    "NOMINAL",
    "SEGMENTS_PER_ELEMENT",
    "SPAN",
    "Indentation",
    "Hertz",
    "hertz",
    "Block",
    "Equilibrium",
    "Result",
    "Solver",
    "equilibrium",
    "fit_half_width",
    "peak_pressure",
    "run",
    "setup",
]
