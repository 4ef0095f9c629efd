"""Every private name of jaxcontact that the benchmarks use, imported here alone.

The benchmarks time the library's sized forms (fixed ``Sizes`` measured
outside the timer) and its stages one by one, which the public API does not
expose. Importing them in this one module keeps the benchmarks' dependence on
the library's internals in one place: when a private module is reorganised,
this file is the one to update. Where the public API does the same job
(``jaxcontact.Search``, ``all_to_all``, ``bucket_sort``), the benchmarks call
it instead. It holds only what a maintained suite or test imports, so a name
that nothing uses any more goes with its last caller.

The sized searches (``sized_bucket_sort``, ``sized_bucket_swept``) are thin
adapters onto the library's one pipeline (``jaxcontact._detect.at_sizes`` run
with the ``CLOSEST`` or ``SWEPT`` query).
"""

import jax.numpy as jnp

from jaxcontact import _normals, _track
from jaxcontact._detect import at_sizes
from jaxcontact._pipeline import driver
from jaxcontact._pipeline import outline as _outline
from jaxcontact._pipeline.broad import broad_phase, kept_rows
from jaxcontact._pipeline.cells import list_candidates
from jaxcontact._pipeline.inputs import check_surface
from jaxcontact._pipeline.narrow import search_listed, search_tiles
from jaxcontact._pipeline.pairs import EVERY_PAIR, ruled
from jaxcontact._pipeline.segments import resolve_segments
from jaxcontact._pipeline.sizes import largest, measure, with_entries
from jaxcontact._query.closest import CLOSEST
from jaxcontact._query.swept import SWEPT
from jaxcontact._timing import (
    Timing,
    _elapsed,
    compiled_call,
    pinned_note,
    time_call,
    time_interleaved,
)


def sized_bucket_sort(x, surface, *, radius, mask=None, sizes, candidates=None, pairs=None):
    """``bucket_sort`` at ``sizes``, inputs checked."""
    return at_sizes(CLOSEST, (x,), surface, radius, mask, sizes, candidates, pairs)


def sized_bucket_swept(x_prev, x, surface, *, mask=None, sizes, pairs=None):
    """``bucket_swept`` at ``sizes``, inputs checked."""
    return at_sizes(SWEPT, (x_prev, x), surface, None, mask, sizes, pairs=pairs)


def measure_contacts(x, surface, radius, mask, sizes, slack):
    """``sizes`` with the compact closest form's capacity measured."""
    radius = jnp.asarray(radius, x.dtype)
    needed = driver.entries_needed(CLOSEST, (x,), surface, radius, mask, sizes, EVERY_PAIR)
    return with_entries(sizes, needed, slack)


__all__ = [
    "CLOSEST",
    "Timing",
    "_elapsed",
    "_normals",
    "_outline",
    "_track",
    "broad_phase",
    "check_surface",
    "compiled_call",
    "kept_rows",
    "largest",
    "list_candidates",
    "measure",
    "measure_contacts",
    "pinned_note",
    "resolve_segments",
    "ruled",
    "search_listed",
    "search_tiles",
    "sized_bucket_sort",
    "sized_bucket_swept",
    "time_call",
    "time_interleaved",
]
