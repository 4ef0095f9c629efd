"""Deprecated: J2 Johnson–Cook plasticity is ``jaxcontact.sim.materials.JohnsonCook``,
AISI 1045's constants ``jaxcontact.sim.materials.AISI_1045``."""

from __future__ import annotations

import warnings

from jaxcontact.sim import materials
from jaxcontact.sim._moved import deprecated, forward

# The 0.7.5 field order of ``JohnsonCook``, whose defaults were AISI 1045's.
_FIELDS = (
    "young poisson density specific_heat A B n C m reference_rate melting room taylor_quinney"
).split()


class _Either(type):
    """``isinstance(x, plasticity.JohnsonCook)`` holds for every ``materials.JohnsonCook``."""

    def __instancecheck__(cls, instance) -> bool:
        return isinstance(instance, materials.JohnsonCook)


class _JohnsonCook(materials.JohnsonCook, metaclass=_Either):
    """1.1's ``JohnsonCook``: its defaults were AISI 1045's. Builds a ``materials.JohnsonCook``."""

    def __new__(cls, *args, **fields):
        warnings.warn(
            "jaxcontact.sim.plasticity.JohnsonCook is deprecated: use "
            "jaxcontact.sim.materials.AISI_1045 (any materials.JohnsonCook)",
            DeprecationWarning,
            stacklevel=2,
        )
        return materials.AISI_1045._replace(**dict(zip(_FIELDS, args, strict=False)), **fields)


def _flow_stress(material, plastic_strain, rate, temperature):
    return material.flow_stress(plastic_strain, rate, temperature)


def _update(material, state, strain_increment, dt):
    return material.update(state, strain_increment, dt)


_HERE = "jaxcontact.sim.plasticity"
_OLD = {
    "JohnsonCook": _JohnsonCook,
    "flow_stress": deprecated(
        f"{_HERE}.flow_stress", "jaxcontact.sim.materials.JohnsonCook.flow_stress", _flow_stress
    ),
    "update": deprecated(f"{_HERE}.update", "jaxcontact.sim.materials.JohnsonCook.update", _update),
}
_forwarded = forward(
    __name__,
    {
        "PointState": "jaxcontact.sim.materials.PointState",
        "von_mises": "jaxcontact.sim.materials.von_mises",
        "BISECTIONS": "jaxcontact.sim.materials.BISECTIONS",
    },
)


def __getattr__(name: str):
    if name in _OLD:
        return _OLD[name]
    return _forwarded(name)
