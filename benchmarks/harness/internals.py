"""Every private name of jaxcontact that the benchmarks use, imported here alone.

The benchmarks time the library's sized forms (fixed ``Sizes`` measured
outside the timer) and its stages one by one, which the public API does not
expose. Importing them in this one module keeps the benchmarks' dependence on
the library's internals in one place: when a private module is reorganised,
this file is the one to update. Where the public API does the same job
(``jaxcontact.Search``, ``all_to_all``, ``bucket_sort``), the benchmarks call
it instead.
"""

from jaxcontact import _bucket, _dense, _inputs, _normals, _outline, _track
from jaxcontact._assemble import contact_from_choice
from jaxcontact._broad import broad_phase, kept_rows, segment_boxes
from jaxcontact._bucket import (
    contact_jit,
    crossing_jit,
    measure_contacts,
    sized_bucket_sort,
    sized_bucket_swept,
)
from jaxcontact._cells import Grid, cell_entries, list_candidates, num_lists
from jaxcontact._dense import _all_to_all, _swept
from jaxcontact._geometry import squared_distance
from jaxcontact._narrow import search_all, search_listed, vmapped
from jaxcontact._pairs import ruled
from jaxcontact._shard import _device_sizes, _pad_rows, shard_rows
from jaxcontact._sizes import largest, measure, measure_batch
from jaxcontact._sort import packs, sorted_pairs, stable_order
from jaxcontact._timing import (
    Timing,
    _elapsed,
    compiled_call,
    pinned_note,
    time_call,
    time_interleaved,
)
from jaxcontact._writeback import empty_contact, write_blocks

__all__ = [
    "Grid",
    "Timing",
    "_all_to_all",
    "_bucket",
    "_dense",
    "_device_sizes",
    "_elapsed",
    "_inputs",
    "_normals",
    "_outline",
    "_pad_rows",
    "_swept",
    "_track",
    "broad_phase",
    "cell_entries",
    "compiled_call",
    "contact_from_choice",
    "contact_jit",
    "crossing_jit",
    "empty_contact",
    "kept_rows",
    "largest",
    "list_candidates",
    "measure",
    "measure_batch",
    "measure_contacts",
    "num_lists",
    "packs",
    "pinned_note",
    "ruled",
    "search_all",
    "search_listed",
    "segment_boxes",
    "shard_rows",
    "sized_bucket_sort",
    "sized_bucket_swept",
    "sorted_pairs",
    "squared_distance",
    "stable_order",
    "time_call",
    "time_interleaved",
    "vmapped",
    "write_blocks",
]
