"""The paper's detectors as one-call functions.

``all_to_all`` and ``swept`` (exhaustive) are one prologue (``_checked``,
``_padded``: check, pair rule, pad to a size class so that nearby shapes share
a program) and epilogue (``_finish``: normals, cut back) around the exhaustive
driver (``_pipeline.driver``), for one of the two queries (``_query``).

``bucket_sort`` and ``bucket_swept`` are the same prologue and epilogue around a
``Search`` allocated for the call and run once: they measure their sizes on the
host from the data, so they need concrete inputs, and keep nothing between calls.
A ``Search`` is the form that keeps its sizes (and candidates) from step to step,
in the caller's hands.
"""

from __future__ import annotations

import numpy as np

from jaxcontact._normals import Smooth, check_normals, smoothed_jit
from jaxcontact._pipeline import driver
from jaxcontact._pipeline import pairs as _pairs
from jaxcontact._pipeline.inputs import ONLY_2D, reach_of, require_2d, require_concrete
from jaxcontact._pipeline.padding import cut_entries, cut_rows, pad_scene
from jaxcontact._pipeline.pairs import Pairs
from jaxcontact._pipeline.sizes import check_sizes
from jaxcontact._query.closest import CLOSEST
from jaxcontact._query.swept import SWEPT
from jaxcontact._search import Search
from jaxcontact._types import (
    Array,
    Contact,
    ContactList,
    Crossing,
    CrossingList,
    Sizes,
    Surface,
)


def _checked(query, points: tuple, surface, radius, mask, pairs):
    """The prologue's first half: ``(points, surface, radius, mask, pairs)`` checked."""
    points, surface, radius, mask = query.check(points, surface, radius, mask)
    pairs = _pairs.check(pairs, points[-1], surface, mask)
    return points, surface, radius, mask, pairs


def _padded(points: tuple, surface, radius, mask, pairs):
    """The prologue's second half: ``(points, surface, radius, mask, pairs,
    num_rows)`` padded to a size class (``num_rows`` None where nothing was)."""
    per_row = radius if radius is not None and np.ndim(radius) else None
    points, mask, surface, (per_row, pairs), num_rows = pad_scene(
        points, mask, surface, (per_row, pairs), others=radius
    )
    return points, surface, radius if per_row is None else per_row, mask, pairs, num_rows


def _finish(result, points, surface, normals: Smooth | None, num_rows):
    """The epilogue: smooth normals where asked, the rows (or entries) cut back."""
    if normals is not None:
        result = smoothed_jit(result, points[-1], surface, normals.corner)
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
    normals: Smooth | None = None,
) -> Contact:
    """Closest master segment of every slave, by dense N x M projection.

    In 3D, the closest triangle: ``x`` f[N, 3] against a surface of nodes
    f[P, 3] and triangles i32[M, 3] (counter-clockwise seen from outside);
    ``xi`` is then f[N, 2] (the barycentric weights of the face's corners
    1 and 2), ``point`` and ``normal`` f[N, 3], ``vertex`` i32[N, 2] (the
    closest feature's nodes), and the gap on an edge or at a vertex is
    signed by its angle-weighted pseudo-normal (docs/contract.md, "Contact
    in 3D"). ``pairs`` and ``normals`` must then be None.

    Args:
      x: f[N, 2] (or f[N, 3]) slave coordinates (float32 or float64).
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: search radius, >= 0: a scalar, or f[N] one per slave; a slave
        is ``found`` when its closest real segment lies within its radius.
      mask: optional bool[N], False for padding slaves.
      pairs: the pair rule (``Pairs``): own nodes, bodies, self-contact.
        ``None`` lets every slave meet every real segment.
      normals: ``None`` (each segment's own normal) or ``Smooth(corner)``:
        a normal interpolated along each segment between nodal normals, the
        bisectors at nodes where the outline turns by less than ``corner``
        degrees, and the gap measured along it (the repository's
        docs/contract.md, "Smooth normals"). The segment, ``xi`` and point
        are the same either way.

    Returns:
      A ``Contact`` with one row per slave, in ``x``'s dtype. ``overflow`` is
      always False. Costs O(N M) time and O(N + M) memory.

    Raises:
      ValueError: on a wrong shape or dtype, and (outside ``jit``) on a real
        segment's index out of range (masked segments' indices may be
        anything) or a negative or non-finite radius; in 3D, on ``pairs``
        or ``normals`` given.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Surface, all_to_all
      >>> floor = Surface(jnp.array([[1.0, 0.0], [0.0, 0.0]]), jnp.array([[0, 1]]))
      >>> contact = all_to_all(jnp.array([[0.5, 0.25], [0.5, -0.125]]), floor, radius=0.5)
      >>> contact.gap.tolist(), contact.active.tolist(), contact.normal.tolist()
      ([0.25, -0.125], [False, True], [[0.0, 1.0], [0.0, 1.0]])
    """
    normals = check_normals(normals)
    if normals is not None and np.shape(x)[-1:] == (3,):
        raise ValueError(
            f"normals must be None with x of shape {np.shape(x)}; got {normals!r}: {ONLY_2D}"
        )
    checked = _checked(CLOSEST, (x,), surface, radius, mask, pairs)
    points, surface, radius, mask, pairs, num_rows = _padded(*checked)
    contact = driver.exhaustive(CLOSEST, points, surface, radius, mask, pairs)
    return _finish(contact, points, surface, normals, num_rows)


def swept(
    x_prev: Array,
    x: Array,
    surface: Surface,
    *,
    mask: Array | None = None,
    pairs: Pairs | None = None,
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
    require_2d("swept", x_prev=x_prev, x=x)
    checked = _checked(SWEPT, (x_prev, x), surface, None, mask, pairs)
    points, surface, _, mask, pairs, num_rows = _padded(*checked)
    crossing = driver.exhaustive(SWEPT, points, surface, None, mask, pairs)
    return _finish(crossing, points, surface, None, num_rows)


def bucket_sort(
    x: Array,
    surface: Surface,
    *,
    radius,
    mask: Array | None = None,
    compact: bool = False,
    pairs: Pairs | None = None,
    normals: Smooth | None = None,
) -> Contact | ContactList:
    """Closest master segment of every slave near the master, by bucket sort.

    The one-call form: a ``Search`` allocated for this call (its sizes
    measured from the data, on the host) and run once, so it needs concrete
    inputs and keeps nothing between calls. Inside ``jit``, ``lax.scan``,
    ``vmap`` or ``grad``, and to reuse sizes and candidates over the steps of
    a simulation, use ``Search``.

    Args:
      x: f[N, 2] slave coordinates. Rows close in the input should be close in
        space (a mesh numbering is): slaves are culled in blocks of rows.
      surface: the master ``Surface``; its nodes share ``x``'s dtype.
      radius: search radius, >= 0: a scalar, or f[N] one per slave.
      mask: optional bool[N], False for padding slaves.
      compact: return the found contacts only, as a ``ContactList``.
      pairs: the pair rule, as for ``all_to_all``.
      normals: flat (``None``) or ``Smooth`` normals, as for ``all_to_all``.

    Returns:
      A ``Contact`` equal to ``all_to_all``'s, ``overflow`` False, or its
      ``ContactList``.

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
    require_2d("bucket_sort", x=x)
    require_concrete("bucket_sort", (x, surface, radius, mask, pairs))
    checked = _checked(CLOSEST, (x,), surface, radius, mask, pairs)
    (x,), surface, radius, mask, pairs, num_rows = _padded(*checked)
    search = Search(radius=float(reach_of(radius, mask)), compact=compact, normals=normals)
    # A scene out of contact is an answer here, not a trap: no warning.
    state = search._allocate(x, surface, mask=mask, pairs=pairs, warn=False)
    contact, _ = search.closest(state, x, surface, mask=mask, radius=radius, pairs=pairs)
    return _finish(contact, (x,), surface, None, num_rows)


def bucket_swept(
    x_prev: Array,
    x: Array,
    surface: Surface,
    *,
    mask: Array | None = None,
    compact: bool = False,
    pairs: Pairs | None = None,
) -> Crossing | CrossingList:
    """First crossing of every slave's path with the master, by bucket sort.

    The cull works on the boxes of the paths ``x_prev -> x``; the cells hold
    the segments inflated by the longest path (the paper's ``d_max``). The
    one-call form, as ``bucket_sort``: for concrete inputs, nothing kept;
    under ``jit`` use ``Search``.

    Args:
      x_prev: f[N, 2] previous slave positions.
      x: f[N, 2] current slave positions.
      surface: the master ``Surface``.
      mask: optional bool[N], False for padding slaves.
      compact: return the crossed paths only, as a ``CrossingList``.
      pairs: the pair rule, as for ``swept``.

    Returns:
      A ``Crossing`` equal to ``swept``'s, ``overflow`` False, or its
      ``CrossingList``.
    """
    require_2d("bucket_swept", x_prev=x_prev, x=x)
    require_concrete("bucket_swept", (x_prev, x, surface, mask, pairs))
    checked = _checked(SWEPT, (x_prev, x), surface, None, mask, pairs)
    (x_prev, x), surface, _, mask, pairs, num_rows = _padded(*checked)
    search = Search(compact=compact)
    # A scene out of contact is an answer here, not a trap: no warning.
    state = search._allocate(x, surface, x_prev=x_prev, mask=mask, pairs=pairs, warn=False)
    crossing, _ = search.swept(state, x_prev, x, surface, mask=mask, pairs=pairs)
    return _finish(crossing, (x_prev, x), surface, None, num_rows)


def at_sizes(
    query, points: tuple, surface, radius, mask, sizes: Sizes, candidates=None, pairs=None
):
    """``query``'s bucket sort at given ``Sizes`` (and reused ``candidates``),
    its inputs checked as the one-call forms check them, nothing padded:
    what a ``Search`` step runs, for the tests and the benchmarks. Runs
    under ``jit`` and ``vmap`` (``sizes`` is static)."""
    require_2d("a bucket sort at sizes", x=points[-1])
    points, surface, radius, mask = query.check(points, surface, radius, mask)
    pairs = _pairs.check(pairs, points[-1], surface, mask)
    check_sizes(sizes, points[-1].shape[0], for_paths=query.num_points > 1)
    return driver.sized_jit(
        query, points, surface, radius, mask, sizes=sizes, candidates=candidates, pairs=pairs
    )
