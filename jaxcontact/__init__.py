"""jaxcontact: 2D node-to-segment contact detection as differentiable JAX array programs."""

from jaxcontact import forces as forces
from jaxcontact import scenes as scenes
from jaxcontact._detect import all_to_all as all_to_all
from jaxcontact._detect import bucket_sort as bucket_sort
from jaxcontact._detect import bucket_swept as bucket_swept
from jaxcontact._detect import swept as swept
from jaxcontact._normals import Smooth as Smooth
from jaxcontact._pairs import Pairs as Pairs
from jaxcontact._removed import missing as _missing
from jaxcontact._resume import check_overflow as check_overflow
from jaxcontact._resume import resumable_scan as resumable_scan
from jaxcontact._search import Search as Search
from jaxcontact._search import SearchState as SearchState
from jaxcontact._track import Slip as Slip
from jaxcontact._track import track as track
from jaxcontact._types import Contact as Contact
from jaxcontact._types import ContactList as ContactList
from jaxcontact._types import Crossing as Crossing
from jaxcontact._types import CrossingList as CrossingList
from jaxcontact._types import QuerySizes as QuerySizes
from jaxcontact._types import Sizes as Sizes
from jaxcontact._types import Surface as Surface
from jaxcontact._validate import validate as validate

__version__ = "2.2.0"

__all__ = [
    "Contact",
    "ContactList",
    "Crossing",
    "CrossingList",
    "Pairs",
    "QuerySizes",
    "Search",
    "SearchState",
    "Sizes",
    "Slip",
    "Smooth",
    "Surface",
    "all_to_all",
    "bucket_sort",
    "bucket_swept",
    "check_overflow",
    "forces",
    "resumable_scan",
    "scenes",
    "swept",
    "track",
    "validate",
]

# Old names fail naming their replacements (_removed); dir() lists the public ones.
__getattr__ = _missing(__name__)


def __dir__() -> list[str]:
    return sorted(__all__ + ["__version__"])
