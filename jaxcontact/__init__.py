"""jaxcontact: 2D node-to-segment contact detection as differentiable JAX array programs."""

from jaxcontact._dense import all_to_all as all_to_all
from jaxcontact._dense import swept as swept
from jaxcontact._types import Contact as Contact
from jaxcontact._types import Crossing as Crossing
from jaxcontact._types import Surface as Surface

__version__ = "0.1.0"
