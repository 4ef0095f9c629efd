"""Every private name of jaxcontact that the benchmarks use, imported here alone.

The benchmarks time the library's sized forms (fixed ``Sizes`` measured
outside the timer) and its stages one by one, which the public API does not
expose. Importing them in this one module keeps the benchmarks' dependence on
the library's internals in one place: when a private module is reorganised,
this file is the one to update. Where the public API does the same job
(``jaxcontact.Search``, ``all_to_all``, ``bucket_sort``), the benchmarks call
it instead.

The names the suites call (``contact_jit``, ``sized_bucket_sort``, ...) are
thin adapters onto the library's one pipeline (``jaxcontact._pipeline.driver``
run with the ``CLOSEST`` or ``SWEPT`` query).
"""

from types import SimpleNamespace

import jax.numpy as jnp

from jaxcontact import _normals, _track
from jaxcontact._detect import at_sizes
from jaxcontact._pipeline import candidates, driver, inputs, segments, writeback
from jaxcontact._pipeline import outline as _outline
from jaxcontact._pipeline.broad import broad_phase, kept_rows, segment_boxes
from jaxcontact._pipeline.cells import Grid, cell_entries, list_candidates, num_lists
from jaxcontact._pipeline.geometry import squared_distance
from jaxcontact._pipeline.narrow import search_all, search_listed, search_tiles, vmapped
from jaxcontact._pipeline.pairs import EVERY_PAIR, ruled
from jaxcontact._pipeline.sizes import largest, measure, measure_batch, with_entries
from jaxcontact._pipeline.sort import packs, sorted_pairs, stable_order
from jaxcontact._query.closest import CLOSEST, contact_from_choice
from jaxcontact._query.swept import SWEPT
from jaxcontact._timing import (
    Timing,
    _elapsed,
    compiled_call,
    pinned_note,
    time_call,
    time_interleaved,
)
from jaxcontact._types import Contact

# The two drivers' jitted programs (one cache each, shared by both queries).
exhaustive = driver.exhaustive
sized_jit = driver.sized_jit


def contact_jit(x, surface, radius, mask, *, sizes, candidates=None, pairing=EVERY_PAIR):
    """The closest-point bucket sort at ``sizes`` (jitted, inputs unchecked)."""
    return driver.sized_jit(
        CLOSEST, (x,), surface, radius, mask, sizes=sizes, candidates=candidates, pairs=pairing
    )


def crossing_jit(x_prev, x, surface, mask, *, sizes, pairing=EVERY_PAIR):
    """The swept bucket sort at ``sizes`` (jitted, inputs unchecked)."""
    return driver.sized_jit(SWEPT, (x_prev, x), surface, None, mask, sizes=sizes, pairs=pairing)


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


def empty_contact(template, overflow):
    """A ``Contact`` of nothing found, with ``template``'s rows and dtype."""
    return writeback.empty(Contact, template.shape[0], template.dtype, overflow)


def write_blocks(result, blocks, empty, block_size):
    """The kept blocks' rows written into ``empty``'s N rows."""
    return writeback.write_blocks(result, blocks, empty, block_size)


_bucket = SimpleNamespace(
    contact_jit=contact_jit,
    find=candidates.find,
    find_jit=candidates.find_jit,
    sized_bucket_sort=sized_bucket_sort,
    sized_bucket_swept=sized_bucket_swept,
)
_dense = SimpleNamespace(
    ROW_MULTIPLE=SWEPT.row_multiple,
    _all_to_all=lambda x, surface, radius, mask, pairing=EVERY_PAIR: driver.exhaustive(
        CLOSEST, (x,), surface, radius, mask, pairing
    ),
    _swept=lambda x_prev, x, surface, mask, pairing=EVERY_PAIR: driver.exhaustive(
        SWEPT, (x_prev, x), surface, None, mask, pairing
    ),
)
_inputs = SimpleNamespace(
    check_surface=inputs.check_surface, resolve_segments=segments.resolve_segments
)

__all__ = [
    "Grid",
    "Timing",
    "_bucket",
    "_dense",
    "_elapsed",
    "_inputs",
    "_normals",
    "_outline",
    "_track",
    "broad_phase",
    "cell_entries",
    "compiled_call",
    "contact_from_choice",
    "contact_jit",
    "crossing_jit",
    "empty_contact",
    "exhaustive",
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
    "search_tiles",
    "segment_boxes",
    "sized_jit",
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
