"""jaxcontact: 2D node-to-segment contact detection as differentiable JAX array programs."""

from jaxcontact._detect import all_to_all as all_to_all
from jaxcontact._detect import bucket_sort as bucket_sort
from jaxcontact._detect import bucket_swept as bucket_swept
from jaxcontact._detect import clear_sizes as clear_sizes
from jaxcontact._detect import swept as swept
from jaxcontact._pipeline.pairs import Pairs as Pairs
from jaxcontact._resume import resumable_scan as resumable_scan
from jaxcontact._search import Search as Search
from jaxcontact._search import SearchState as SearchState
from jaxcontact._shard import sharded as sharded
from jaxcontact._track import Slip as Slip
from jaxcontact._track import track as track
from jaxcontact._types import Contact as Contact
from jaxcontact._types import ContactList as ContactList
from jaxcontact._types import Crossing as Crossing
from jaxcontact._types import CrossingList as CrossingList
from jaxcontact._types import Sizes as Sizes
from jaxcontact._types import Surface as Surface
from jaxcontact._validate import validate as validate
from jaxcontact.forces import contact_forces as contact_forces

__version__ = "1.2.0"
