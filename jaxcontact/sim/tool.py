"""The cutting scene's tool in ``jax.numpy``, parametrised by its rake angle.

``scenes.cutting_tool_outline`` builds the outline in NumPy for one fixed
rake angle; a simulation differentiated with respect to the rake angle needs
the same geometry as a traced function. The two are kept equal by a test
(the repository's tests/sim/test_simulate.py) at the scene's 10°.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact import Surface

# The cutting scene's tool (docs/scenes.md): clearance angle, face length, edge
# radius, tip height (depth of cut 1 in a workpiece 5 high), arc segments.
CLEARANCE = math.radians(7)
FACE = 3.0
EDGE_RADIUS = 0.05
TIP_HEIGHT = 4.0
ARC_SEGMENTS = 16


@jax.jit
def tool_outline(x_tip, rake) -> Array:
    """f[20, 2]: the cutting scene's tool outline for a rake angle, in jnp.

    The geometry of ``scenes.cutting_tool_outline`` (which it equals at
    ``rake = 10°``) written in ``jax.numpy``, so that it is differentiable in
    ``x_tip`` and ``rake`` (radians). Counter-clockwise: the arc of radius
    0.05 from the rake face's tangent point past the tip to the flank's, then
    the flank end, the back corner and the rake end.

    Example:
      >>> import math
      >>> from jaxcontact.scenes import cutting_tool_outline
      >>> outline = tool_outline(18.0, math.radians(10))
      >>> bool(abs(outline - cutting_tool_outline(18.0)).max() < 1e-5)
      True
    """
    rake = jnp.asarray(rake)
    dtype = jnp.result_type(rake, float)
    rake = rake.astype(dtype)
    tip = jnp.stack([jnp.asarray(x_tip, dtype), jnp.asarray(TIP_HEIGHT, dtype)])
    rake_dir = jnp.stack([jnp.sin(rake), jnp.cos(rake)])
    flank_dir = jnp.asarray([math.cos(CLEARANCE), math.sin(CLEARANCE)], dtype)
    rake_end, flank_end = tip + FACE * rake_dir, tip + FACE * flank_dir
    back = jnp.stack([flank_end[0], rake_end[1]])
    # The arc touches both faces: its centre lies on the wedge's bisector at
    # r / sin(wedge / 2) from the tip. The wedge between the faces is
    # 90° - rake - clearance; the arc runs from the rake face's outward normal
    # (angle 180° - rake) to the flank's (270° + clearance).
    wedge = math.pi / 2 - rake - CLEARANCE
    bisector = (rake_dir + flank_dir) / jnp.linalg.norm(rake_dir + flank_dir)
    centre = tip + bisector * EDGE_RADIUS / jnp.sin(wedge / 2)
    unit = jnp.linspace(0.0, 1.0, ARC_SEGMENTS + 1, dtype=dtype)
    angles = (math.pi - rake) + unit * (1.5 * math.pi + CLEARANCE - (math.pi - rake))
    arc = centre[None, :] + EDGE_RADIUS * jnp.stack([jnp.cos(angles), jnp.sin(angles)], axis=-1)
    return jnp.concatenate([arc, jnp.stack([flank_end, back, rake_end])])


def tool_surface(x_tip, rake) -> Surface:
    """The closed ``Surface`` of ``tool_outline(x_tip, rake)``."""
    nodes = tool_outline(x_tip, rake)
    starts = np.arange(nodes.shape[0])
    segments = np.stack([starts, (starts + 1) % nodes.shape[0]], axis=-1).astype(np.int32)
    return Surface(nodes, jnp.asarray(segments))
