"""Hertz's line contact of a rigid cylinder on an elastic half-space (Johnson,
*Contact Mechanics*, 1985, ch. 4, §4.3, eq. 4.43-4.45): what the FE solution is set against.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from jaxcontact.problems.hertz.config import Indentation, _check

__all__ = ["Hertz", "hertz"]


class Hertz(NamedTuple):
    """Hertz's line contact of a rigid cylinder on an elastic half-space."""

    half_width: float  # a (mm)
    peak: float  # p0 (MPa)
    modulus: float  # E* = E / (1 - ν²) (MPa)

    def pressure(self, x):
        """f[...]: ``p0 sqrt(1 - x²/a²)`` at ``x`` (mm; array-like), 0 outside ``|x| < a`` (MPa)."""
        x = np.asarray(x, np.float64)
        return self.peak * np.sqrt(np.clip(1 - (x / self.half_width) ** 2, 0, None))


def hertz(problem: Indentation) -> Hertz:
    """Hertz's a, p0 and E* for ``problem`` (Johnson, 1985, eq. 4.43-4.45).

    Example:
      >>> exact = hertz(Indentation())
      >>> round(exact.half_width, 4), round(exact.peak), round(float(exact.pressure(0.0)))
      (0.2349, 2710, 2710)
    """
    _check(problem)
    modulus = problem.young / (1 - problem.poisson**2)
    half_width = math.sqrt(4 * problem.force * problem.radius / (math.pi * modulus))
    return Hertz(half_width, 2 * problem.force / (math.pi * half_width), modulus)
