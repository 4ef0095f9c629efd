"""Plane-strain elements, one module each: ``q4`` (large deformation, B-bar, for
explicit runs) and ``triangle`` (small strain, linear elastic)."""

from jaxcontact.sim.elements import q4 as q4
from jaxcontact.sim.elements import triangle as triangle

__all__ = ["q4", "triangle"]
