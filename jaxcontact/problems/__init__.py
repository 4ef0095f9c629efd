"""The problems, each set up from the parts of ``jaxcontact.sim``, one package each.

* ``cutting``: orthogonal cutting of AISI 1045 that forms a chip;
* ``ploughing``: a rigid tool ploughing an elastic workpiece;
* ``hertz``: a rigid cylinder pressed into an elastic block, against Hertz.

Each has one shape: its config class (frozen numbers), ``setup(config)``,
``step`` and ``run(config, ...)``, split by job into ``config``, ``model``,
``report`` (where it has one) and ``demo`` (``jaxcontact demo --scene ...``).
Nothing is imported here: ``import jaxcontact.problems.cutting`` loads one
problem, and no part of ``jaxcontact.sim`` imports any.
"""

__all__ = ["cutting", "hertz", "ploughing"]
