"""The indentation to solve: ``Indentation`` (R, P, E, ν: traced, differentiable),
with the mesh's constants (the solver's settings are ``model.Solver``). Units mm,
N, MPa; forces per mm of thickness.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["FINE", "Indentation", "MESHES", "MOST_WIDTH", "NOMINAL", "SEGMENTS_PER_ELEMENT", "SPAN"]

# The uniform zone of the mesh, about the contact: |x| <= FINE a, y >= -FINE a.
FINE = 1.5
# The cylinder's arc, the master, covers |x| <= SPAN a: the gap grows as x²/2R
# outside the contact, so nodes farther out cannot touch it.
SPAN = 3.0
# Segments of the arc per element at the contact (half an element each).
SEGMENTS_PER_ELEMENT = 2
# The largest a / R taken: a << R is Hertz's premise (and small strain's, p0/E* = a/2R).
MOST_WIDTH = 0.1
# The elements across the contact width 2a of the benchmark's meshes.
MESHES = (12, 24, 48)


class Indentation(NamedTuple):
    """The problem: a rigid cylinder pressed into an elastic block (plane strain).

    Defaults: a 10 mm cylinder pressed with 1,000 N per mm into steel, which
    gives Hertz's a = 0.235 mm and p0 = 2.71 GPa (``theory.hertz``). A pytree: pass
    it to ``peak_pressure`` and differentiate with respect to its fields.
    ``setup`` and ``run`` take a / R up to ``MOST_WIDTH``.
    """

    radius: float = 10.0  # R (mm)
    force: float = 1_000.0  # P (N per mm of thickness)
    young: float = 210_000.0  # E of the block (MPa)
    poisson: float = 0.3  # ν of the block


# The default problem (the class's defaults).
NOMINAL = Indentation()


def _check(problem: Indentation) -> None:
    if not isinstance(problem, Indentation):
        raise ValueError(f"problem must be an Indentation; got {type(problem).__name__}")
    for name in ("radius", "force", "young"):
        value = getattr(problem, name)
        if not (np.ndim(value) == 0 and np.isfinite(value) and value > 0):
            raise ValueError(f"problem.{name} must be a finite number > 0; got {value!r}")
    nu = problem.poisson
    if not (np.ndim(nu) == 0 and np.isfinite(nu) and 0 <= nu < 0.5):
        raise ValueError(f"problem.poisson must be in [0, 0.5); got {nu!r}")
