"""The paper's detectors as one-call functions, over one prologue and one driver.

Each is the same prologue (``_checked``, ``_padded``: check, pair rule, pad to a size
class) and epilogue (``_finish``: normals, cut back) around one of the two
drivers (``_pipeline.driver``), for one of the two queries (``_query``).

The bucket-sort forms measure their sizes on the host, so they need concrete
inputs. To save a measure per call they keep the sizes they last used, per
query, result form and padded input shapes and dtypes (the ``KEPT_SIZES``
most recently used signatures, in this process): a call runs with them and
measures again only when they overflow, then runs again at the new sizes.
That never changes an answer: without overflow a result is the exhaustive
one whatever the sizes. ``clear_sizes()`` empties the table; ``Search`` is
the form that keeps its sizes in the caller's hands.
"""

from __future__ import annotations

import collections
import dataclasses
import threading
from collections.abc import Callable

import jax
import numpy as np

from jaxcontact._normals import CORNER_DEGREES, check_normals, smoothed_jit
from jaxcontact._pipeline import driver
from jaxcontact._pipeline import pairs as _pairs
from jaxcontact._pipeline.inputs import reach_of, require_concrete
from jaxcontact._pipeline.padding import cut_entries, cut_rows, pad_scene
from jaxcontact._pipeline.pairs import Pairs
from jaxcontact._pipeline.sizes import check_sizes, measure, room_for_every_slot
from jaxcontact._query.closest import CLOSEST
from jaxcontact._query.swept import SWEPT
from jaxcontact._types import (
    CELLS_ABOVE,
    Array,
    Contact,
    ContactList,
    Crossing,
    CrossingList,
    Sizes,
    Surface,
)


def _checked(query, points: tuple, surface, radius, mask, pairs, keywords: dict):
    """The prologue's first half: ``(points, surface, radius, mask, pairs)``
    checked, the replaced pair keywords folded in."""
    points, surface, radius, mask = query.check(points, surface, radius, mask)
    pairs = _pairs.check(pairs, points[-1], surface, mask, stacklevel=4, **keywords)
    return points, surface, radius, mask, pairs


def _padded(points: tuple, surface, radius, mask, pairs):
    """The prologue's second half: ``(points, surface, radius, mask, pairs,
    num_rows)`` padded to a size class (``num_rows`` None where nothing was)."""
    per_row = radius if radius is not None and np.ndim(radius) else None
    points, mask, surface, (per_row, pairs), num_rows = pad_scene(
        points, mask, surface, (per_row, pairs), others=radius
    )
    return points, surface, radius if per_row is None else per_row, mask, pairs, num_rows


def _finish(result, points, surface, normals: str, corner: float, num_rows):
    """The epilogue: smooth normals where asked, the rows (or entries) cut back."""
    if normals == "smooth":
        result = smoothed_jit(result, points[-1], surface, corner)
    if isinstance(result, ContactList | CrossingList):
        return cut_entries(result, num_rows)
    return cut_rows(result, num_rows)


def all_to_all(
    x: Array,
    surface: Surface,
    *,
    radius,
    mask: Array | None = None,
    pairs: Pairs | None = None,
    normals: str = "flat",
    corner: float = CORNER_DEGREES,
    **replaced,
) -> Contact:
    """Closest master segment of every slave, by dense N x M projection.

    Args:
      x: f[N, 2] slave coordinates (float32 or float64).
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: search radius, >= 0: a scalar, or f[N] one per slave; a slave
        is ``found`` when its closest real segment lies within its radius.
      mask: optional bool[N], False for padding slaves.
      pairs: the pair rule (``Pairs``): own nodes, bodies, self-contact.
        ``None`` lets every slave meet every real segment.
      normals: ``"flat"`` (each segment's own normal) or ``"smooth"``: a
        normal interpolated along each segment between nodal normals, the
        bisectors at nodes where the outline turns by less than ``corner``
        degrees, and the gap measured along it (the repository's
        docs/contract.md, "Smooth normals"). The segment, ``xi`` and point
        are the same either way.
      corner: the corner angle of smooth normals, in degrees.
      **replaced: ``slave_node``, ``slave_body``, ``self_contact``: replaced
        by ``pairs``; they still work, with a ``DeprecationWarning``.

    Returns:
      A ``Contact`` with one row per slave, in ``x``'s dtype. ``overflow`` is
      always False. Costs O(N M) time and O(N + M) memory.

    Raises:
      ValueError: on a wrong shape or dtype, and (outside ``jit``) on a real
        segment's index out of range (masked segments' indices may be
        anything) or a negative or non-finite radius.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, all_to_all
      >>> floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]]), jnp.array([[0, 1]]))
      >>> contact = all_to_all(jnp.array([[0.5, 0.25], [0.5, -0.125]]), floor, radius=0.5)
      >>> contact.gap.tolist(), contact.active.tolist(), contact.normal.tolist()
      ([0.25, -0.125], [False, True], [[0.0, 1.0], [0.0, 1.0]])
    """
    corner = check_normals(normals, corner)
    checked = _checked(CLOSEST, (x,), surface, radius, mask, pairs, replaced)
    points, surface, radius, mask, pairs, num_rows = _padded(*checked)
    contact = driver.exhaustive(CLOSEST, points, surface, radius, mask, pairs)
    return _finish(contact, points, surface, normals, corner, num_rows)


def swept(
    x_prev: Array,
    x: Array,
    surface: Surface,
    *,
    mask: Array | None = None,
    pairs: Pairs | None = None,
    **replaced,
) -> Crossing:
    """First crossing of every slave's path ``x_prev -> x`` with the master, densely.

    The earliest crossing along the path wins; exact ties go to the lower
    segment index.

    Args:
      x_prev: f[N, 2] previous slave positions.
      x: f[N, 2] current slave positions, same shape and dtype.
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      mask: optional bool[N], False for padding slaves.
      pairs: the pair rule, as for ``all_to_all``; a path's self-contact
        neighbourhood is measured in multiples of its length.
      **replaced: the replaced pair keywords, as for ``all_to_all``.

    Returns:
      A ``Crossing`` with one row per slave, in ``x``'s dtype; ``overflow`` is
      always False. Costs O(N M) time and O(N + M) memory.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, swept
      >>> wall = Surface(jnp.array([[1.0, 0.0], [1.0, 2.0]]), jnp.array([[0, 1]]))
      >>> crossing = swept(jnp.array([[0.0, 1.0]]), jnp.array([[4.0, 1.0]]), wall)
      >>> crossing.crossed.tolist(), crossing.t.tolist(), crossing.point.tolist()
      ([True], [0.25], [[1.0, 1.0]])
    """
    checked = _checked(SWEPT, (x_prev, x), surface, None, mask, pairs, replaced)
    points, surface, _, mask, pairs, num_rows = _padded(*checked)
    crossing = driver.exhaustive(SWEPT, points, surface, None, mask, pairs)
    return _finish(crossing, points, surface, "flat", 0.0, num_rows)


def bucket_sort(
    x: Array,
    surface: Surface,
    *,
    radius,
    mask: Array | None = None,
    compact: bool = False,
    pairs: Pairs | None = None,
    normals: str = "flat",
    corner: float = CORNER_DEGREES,
    **replaced,
) -> Contact | ContactList:
    """Closest master segment of every slave near the master, by bucket sort.

    The one-call form: it measures the sizes of the bucket sort from the data
    (on the host) and runs it, so it needs concrete inputs. Inside ``jit``,
    ``lax.scan``, ``vmap`` or ``grad``, and to reuse sizes and candidates
    over the steps of a simulation, use ``Search``.

    Args:
      x: f[N, 2] slave coordinates. Rows close in the input should be close in
        space (a mesh numbering is): slaves are culled in blocks of rows.
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: search radius, >= 0: a scalar, or f[N] one per slave.
      mask: optional bool[N], False for padding slaves.
      compact: return the found contacts only, as a ``ContactList`` with an
        entry for every slave the cull kept (``Search(compact=True)``
        measures a tighter capacity once and reuses it).
      pairs: the pair rule, as for ``all_to_all``.
      normals: flat or smooth normals, as for ``all_to_all``.
      corner: the corner angle of smooth normals, as for ``all_to_all``.
      **replaced: the replaced pair keywords, as for ``all_to_all``.

    Returns:
      A ``Contact`` equal to ``all_to_all``'s, ``overflow`` False, or its
      ``ContactList``. The sizes last used at the same padded shapes are
      reused while they hold, and measured again for this data when a
      search at them overflows (the module's notes; ``clear_sizes``).

    Example:
      >>> from jaxcontact import all_to_all, bucket_sort
      >>> from jaxcontact.scenes import cutting_scene
      >>> scene = cutting_scene(2_000, 18.0)
      >>> contact = bucket_sort(scene.x, scene.surface, radius=scene.radius)
      >>> bool(contact.overflow), int(contact.found.sum())
      (False, 13)
      >>> bool((contact.segment == all_to_all(scene.x, scene.surface, radius=0.1).segment).all())
      True
    """
    corner = check_normals(normals, corner)
    checked = _checked(CLOSEST, (x,), surface, radius, mask, pairs, replaced)
    use_cells = _use_cells(checked[1])
    points, surface, radius, mask, pairs, num_rows = _padded(*checked)
    require_concrete("bucket_sort", (points, surface, radius, mask, pairs))

    def sizes_now(use_cells):
        reach = reach_of(radius, mask)
        return measure(points[0], surface, radius=reach, mask=mask, use_cells=use_cells)

    found = _bucket(CLOSEST, points, surface, radius, mask, pairs, compact, use_cells, sizes_now)
    return _finish(found, points, surface, normals, corner, num_rows)


def bucket_swept(
    x_prev: Array,
    x: Array,
    surface: Surface,
    *,
    mask: Array | None = None,
    compact: bool = False,
    pairs: Pairs | None = None,
    **replaced,
) -> Crossing | CrossingList:
    """First crossing of every slave's path with the master, by bucket sort.

    The cull works on the boxes of the paths ``x_prev -> x``; the cells hold
    the segments inflated by the longest path (the paper's ``d_max``). The
    one-call form, for concrete inputs: under ``jit`` use ``Search``.

    Args:
      x_prev: f[N, 2] previous slave positions.
      x: f[N, 2] current slave positions.
      surface: the master ``Surface``.
      mask: optional bool[N], False for padding slaves.
      compact: return the crossed paths only, as a ``CrossingList`` with an
        entry for every path the cull kept (``Search(compact=True)``
        measures a tighter capacity once and reuses it).
      pairs: the pair rule, as for ``swept``.
      **replaced: the replaced pair keywords, as for ``all_to_all``.

    Returns:
      A ``Crossing`` equal to ``swept``'s, ``overflow`` False, or its
      ``CrossingList``; sizes kept and measured again as ``bucket_sort``'s.
    """
    checked = _checked(SWEPT, (x_prev, x), surface, None, mask, pairs, replaced)
    use_cells = _use_cells(checked[1])
    points, surface, _, mask, pairs, num_rows = _padded(*checked)
    require_concrete("bucket_swept", (points, surface, mask, pairs))

    def sizes_now(use_cells):
        x_prev, x = points
        return measure(x, surface, x_prev=x_prev, mask=mask, use_cells=use_cells)

    found = _bucket(SWEPT, points, surface, None, mask, pairs, compact, use_cells, sizes_now)
    return _finish(found, points, surface, "flat", 0.0, num_rows)


def at_sizes(
    query, points: tuple, surface, radius, mask, sizes: Sizes, candidates=None, pairs=None
):
    """``query``'s bucket sort at given ``Sizes`` (and reused ``candidates``),
    its inputs checked as the one-call forms check them, nothing padded:
    what a ``Search`` step runs, for the tests and the benchmarks. Runs
    under ``jit`` and ``vmap`` (``sizes`` is static)."""
    points, surface, radius, mask = query.check(points, surface, radius, mask)
    pairs = _pairs.check(pairs, points[-1], surface, mask)
    check_sizes(sizes, points[-1].shape[0], for_paths=query.num_points > 1)
    return driver.sized_jit(
        query, points, surface, radius, mask, sizes=sizes, candidates=candidates, pairs=pairs
    )


def _use_cells(surface: Surface) -> bool:
    """Whether the one-call bucket forms bin in cells: on the caller's segment
    count, before padding adds masked ones."""
    return surface.segments.shape[0] > CELLS_ABOVE


def _bucket(query, points, surface, radius, mask, pairs, compact: bool, use_cells, sizes_now):
    """``query``'s sized search at the kept sizes, or at new ones."""

    def search(sizes):
        sizes = room_for_every_slot(sizes) if compact else sizes
        return driver.sized_jit(query, points, surface, radius, mask, sizes=sizes, pairs=pairs)

    # Sizes do not depend on the user's own rule: the key holds no reference to it.
    signature = _signature(points, mask, surface, radius, dataclasses.replace(pairs, allow=None))
    key = (query.name, compact, use_cells, signature)
    return _with_kept_sizes(key, lambda: sizes_now(use_cells), search)


# -- the one-call forms' kept sizes (the module's notes) -------------------------

KEPT_SIZES = 64
_kept_sizes: collections.OrderedDict = collections.OrderedDict()
_kept_lock = threading.Lock()  # plain calls from several threads share the table


def clear_sizes() -> None:
    """Forgets the sizes ``bucket_sort`` and ``bucket_swept`` kept: their next
    calls measure again.

    The one-call bucket forms keep the sizes they last used for the
    ``KEPT_SIZES`` most recent input shapes, so that a call on a scene that
    changes little costs one search, not a measure and a search. Answers
    never depend on it. Clear it to free the memory, or to time a first call.

    Example:
      >>> import jaxcontact
      >>> jaxcontact.clear_sizes()
    """
    with _kept_lock:
        _kept_sizes.clear()


def _signature(*values) -> tuple:
    """Hashable: the tree structure, shapes and dtypes of ``values`` (and the
    static fields of a ``Pairs``)."""
    leaves, structure = jax.tree.flatten(values)
    dtypes = (leaf.dtype if hasattr(leaf, "dtype") else np.asarray(leaf).dtype for leaf in leaves)
    return structure, tuple(zip(map(np.shape, leaves), dtypes, strict=True))


def _with_kept_sizes(key, sizes_now: Callable[[], Sizes], search: Callable[[Sizes], object]):
    """``search(sizes)`` at the sizes kept under ``key`` when they do not
    overflow; else at ``sizes_now()``, which are kept instead."""
    with _kept_lock:
        kept = _kept_sizes.get(key)
    if kept is not None:
        found = search(kept)
        if not bool(found.overflow):
            _keep(key, kept)
            return found
    sizes = sizes_now()
    _keep(key, sizes)
    return search(sizes)


def _keep(key, sizes: Sizes) -> None:
    """``sizes`` kept under ``key``, as the last used; the oldest dropped past KEPT_SIZES."""
    with _kept_lock:
        _kept_sizes[key] = sizes
        _kept_sizes.move_to_end(key)
        while len(_kept_sizes) > KEPT_SIZES:
            _kept_sizes.popitem(last=False)
