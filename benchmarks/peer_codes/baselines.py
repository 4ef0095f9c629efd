"""The peers: the same closest-segment query answered by the tools a user would reach for.

Each peer takes NumPy arrays ``x`` f[N, 2], segment ``start`` and ``end``
f[M, 2] and the ``radius``, and returns ``(segment, gap, found)`` as NumPy
arrays (``segment`` -1 where not found), so one checker reads them all
(``benchmarks.harness.answers.compare``). Optional packages are imported inside the functions:
``unavailable`` says which peers cannot run here, and why.

- NumPy dense: every slave-segment pair at once, ``argmin`` over segments.
- NumPy box-then-dense: the paper's preliminary phase (slaves inside the
  tool's box inflated by the radius), then dense on those, on separate x and
  y planes; and the first version, with (K, M, 2) tensors.
- cKDTree: scipy's KD-tree on segment midpoints; candidates are the
  midpoints within ``radius + half the longest segment`` of a slave, then a
  NumPy projection of those pairs. Two routes: ``query_ball_point`` (Python
  lists, the first thing one writes) and ``sparse_distance_matrix`` (arrays).
- shapely 2 STRtree: ``query_nearest`` with ``max_distance=radius``.
- jax-md cell list: ``partition.cell_list`` bins the segment midpoints in
  cells of edge ``radius + half the longest segment``; each slave reads the
  3 x 3 cells around its own; jitted.
- libigl: ``point_mesh_squared_distance`` with the segments as 2D edges
  (an AABB tree, built on every call), then ``found`` where within radius.
- numba grid: a uniform grid written by hand in numba (``numba_grid``), one
  thread, and the same over ``prange`` on 2 threads; compiled ahead.
- IPC Toolkit: its LBVH broad phase for the slave-segment pairs within the
  radius (``ipc.lbvh_pairs``), then a NumPy projection of those pairs.
"""

from __future__ import annotations

import functools
import importlib

import numpy as np

from benchmarks.harness import _run
from benchmarks.peer_codes import ipc


def cross(u, v):
    """z-component of the cross product of 2D vectors along the last axis."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def dense_closest(xp, x, start, end, radius):
    """Textbook brute force: ``(segment, gap, found)`` of every slave.

    Args:
      xp: the array module, ``numpy`` or ``jax.numpy``.
      x: f[N, 2] slaves.
      start: f[M, 2] segment starts.
      end: f[M, 2] segment ends (no segment of zero length).
      radius: search radius.

    Example:
      >>> import numpy as np
      >>> segment, gap, found = dense_closest(np, np.array([[0.5, 0.2]]),
      ...                                     np.zeros((1, 2)), np.array([[1.0, 0.0]]), 0.5)
      >>> segment.tolist(), found.tolist()
      ([0], [True])
    """
    direction = end - start  # f[M, 2]
    relative = x[:, None, :] - start  # f[N, M, 2]
    length_squared = xp.sum(direction * direction, axis=-1)
    xi = xp.clip(xp.sum(relative * direction, axis=-1) / length_squared, 0, 1)
    offset = relative - xi[..., None] * direction
    distance_squared = xp.sum(offset * offset, axis=-1)  # f[N, M]
    segment = xp.argmin(distance_squared, axis=1)
    rows = xp.arange(x.shape[0])
    normal = xp.stack([direction[:, 1], -direction[:, 0]], axis=-1)[segment]
    distance = xp.sqrt(distance_squared[rows, segment])
    gap = xp.where(xp.sum(offset[rows, segment] * normal, axis=-1) < 0, -distance, distance)
    found = distance <= radius
    return xp.where(found, segment, -1), gap, found


def brute_crossing(xp, x_prev, x, start, end):
    """Textbook brute force: ``(segment, t, crossed)`` of every path ``x_prev -> x``.

    Solves ``x_prev + t u = a + s d`` for every pair; parallel pairs never hit.
    """
    motion = (x - x_prev)[:, None, :]  # f[N, 1, 2]
    direction = end - start  # f[M, 2]
    to_start = start - x_prev[:, None, :]  # f[N, M, 2]
    denominator = cross(motion, direction)  # f[N, M]
    parallel = denominator == 0
    denominator = xp.where(parallel, 1, denominator)
    t = cross(to_start, direction) / denominator
    s = cross(to_start, motion) / denominator
    hit = ~parallel & (t >= 0) & (t <= 1) & (s >= 0) & (s <= 1)
    times = xp.where(hit, t, xp.inf)
    segment = xp.argmin(times, axis=1)
    first = xp.min(times, axis=1)
    crossed = xp.isfinite(first)
    return xp.where(crossed, segment, -1), xp.where(crossed, first, 0), crossed


def numpy_dense(x, start, end, radius):
    """NumPy dense brute force (``dense_closest`` on NumPy)."""
    return dense_closest(np, x, start, end, radius)


def _in_box(x, start, end, radius):
    """i[K]: the slaves in the segments' box inflated by ``radius`` (the paper's first phase)."""
    low = np.minimum(start, end).min(axis=0) - radius
    high = np.maximum(start, end).max(axis=0) + radius
    column_x, column_y = x[:, 0], x[:, 1]
    return np.flatnonzero(
        (column_x >= low[0]) & (column_x <= high[0]) & (column_y >= low[1]) & (column_y <= high[1])
    )


# Slave-segment pairs per block of box-then-dense: four float32 (K, M) planes of
# 1 MB stay in cache. On the rough die at (10^4, 10^3) and (10^4, 10^4) the
# whole box at once took 45 and 412 ms, blocks of 2^16 pairs 21 and 461 ms
# (Python's loop shows at 6 rows a block), 2^18 23 and 232 ms, 2^20 25 and
# 214 ms; the cutting scene (2,000 slaves in the box, 20 segments) is one block.
BLOCK_PAIRS = 2**18


def numpy_box_then_dense(x, start, end, radius):
    """The paper's preliminary phase in NumPy, then dense on separate coordinate planes.

    The slaves inside the tool's box inflated by the radius are projected on
    every segment, ``BLOCK_PAIRS // M`` slaves at a time, with x and y as
    separate (K, M) planes (no (K, M, 2) tensor, no reductions over a
    trailing axis of 2), updated in place where that saves a temporary;
    ``argmin`` over the segments, then the gap of the chosen pair alone.
    """
    inside = _in_box(x, start, end, radius)
    segment = np.full(len(x), -1)
    gap = np.zeros(len(x), x.dtype)
    found = np.zeros(len(x), bool)
    rows = max(1, BLOCK_PAIRS // len(start))
    for first in range(0, inside.size, rows):
        block = inside[first : first + rows]
        nearest, signed, within = _closest_on_planes(x[block], start, end, radius)
        segment[block[within]] = nearest[within]
        gap[block[within]] = signed[within]
        found[block[within]] = True
    return segment, gap, found


def _closest_on_planes(x, start, end, radius):
    """``(segment, gap, within)`` f[K] of slaves ``x`` f[K, 2] on every segment, by planes."""
    slave_x, slave_y = x[:, 0][:, None], x[:, 1][:, None]  # f[K, 1]
    start_x, start_y = start[:, 0], start[:, 1]  # f[M]
    step_x, step_y = end[:, 0] - start_x, end[:, 1] - start_y
    inverse_length_squared = 1 / (step_x * step_x + step_y * step_y)
    from_x = slave_x - start_x  # f[K, M]
    from_y = slave_y - start_y
    xi = from_x * step_x
    scratch = from_y * step_y
    xi += scratch
    xi *= inverse_length_squared
    np.clip(xi, 0, 1, out=xi)
    # from_x, from_y become the offset x - p, then its squared length.
    np.multiply(xi, step_x, out=scratch)
    from_x -= scratch
    np.multiply(xi, step_y, out=scratch)
    from_y -= scratch
    from_x *= from_x
    from_y *= from_y
    from_x += from_y
    nearest = np.argmin(from_x, axis=1)  # i[K]
    rows = np.arange(len(x))
    distance_squared = from_x[rows, nearest]
    # The chosen pair's offset again (K pairs, not K x M) for the sign of the gap.
    t = xi[rows, nearest]
    offset_x = slave_x[:, 0] - start_x[nearest] - t * step_x[nearest]
    offset_y = slave_y[:, 0] - start_y[nearest] - t * step_y[nearest]
    outward = offset_x * step_y[nearest] - offset_y * step_x[nearest]
    distance = np.sqrt(distance_squared)
    signed = np.where(outward < 0, -distance, distance)
    return nearest, signed, distance_squared <= radius * radius


def numpy_box_then_dense_tensor(x, start, end, radius):
    """The same first phase, then ``numpy_dense`` with its (K, M, 2) tensors: the first version."""
    inside = _in_box(x, start, end, radius)
    segment = np.full(len(x), -1)
    gap = np.zeros(len(x), x.dtype)
    found = np.zeros(len(x), bool)
    if inside.size:
        segment[inside], gap[inside], found[inside] = numpy_dense(x[inside], start, end, radius)
    return segment, gap, found


def closest_of_pairs(x, start, end, radius, slave, pair_segment):
    """``(segment, gap, found)`` per slave from candidate pairs, by NumPy projection."""
    a, d = start[pair_segment], end[pair_segment] - start[pair_segment]
    from_a = x[slave] - a
    xi = np.clip(np.einsum("pk,pk->p", from_a, d) / np.einsum("pk,pk->p", d, d), 0, 1)
    offset = from_a - xi[:, None] * d
    distance_squared = np.einsum("pk,pk->p", offset, offset)
    # Per slave, the closest pair: sort by (slave, distance, segment) and take the first.
    order = np.lexsort((pair_segment, distance_squared, slave))
    first = order[np.r_[True, slave[order][1:] != slave[order][:-1]]] if order.size else order
    first = first[distance_squared[first] <= radius * radius]
    segment = np.full(len(x), -1)
    gap = np.zeros(len(x), x.dtype)
    found = np.zeros(len(x), bool)
    outward = offset[first, 0] * d[first, 1] - offset[first, 1] * d[first, 0]
    distance = np.sqrt(distance_squared[first])
    segment[slave[first]] = pair_segment[first]
    gap[slave[first]] = np.where(outward < 0, -distance, distance)
    found[slave[first]] = True
    return segment, gap, found


def _midpoint_reach(start, end, radius):
    """Segment midpoints, and the ball around them that holds every slave within radius."""
    middle = (start + end) / 2
    return middle, radius + np.max(np.linalg.norm(end - start, axis=1)) / 2


def kdtree_project(x, start, end, radius):
    """scipy's cKDTree on segment midpoints, a ball query per slave, then NumPy projection.

    The first thing a user writes: ``query_ball_point`` returns Python lists.
    """
    from scipy.spatial import cKDTree

    middle, reach = _midpoint_reach(start, end, radius)
    lists = cKDTree(middle).query_ball_point(x, reach, return_sorted=False)
    counts = np.fromiter((len(v) for v in lists), int, len(lists))
    slave = np.repeat(np.arange(len(x)), counts)
    pair_segment = np.fromiter((s for v in lists for s in v), int, counts.sum())
    return closest_of_pairs(x, start, end, radius, slave, pair_segment)


def kdtree_pairs_project(x, start, end, radius):
    """The same with both point sets in trees and every pair found at once.

    ``sparse_distance_matrix(..., output_type="ndarray")`` returns the pairs as
    arrays, with no Python loop: the fastest cKDTree route we found.
    """
    from scipy.spatial import cKDTree

    middle, reach = _midpoint_reach(start, end, radius)
    pairs = cKDTree(x).sparse_distance_matrix(cKDTree(middle), reach, output_type="ndarray")
    return closest_of_pairs(x, start, end, radius, pairs["i"], pairs["j"])


def shapely_strtree(x, start, end, radius):
    """shapely 2's STRtree of the segments, ``query_nearest`` within the radius.

    Of equally near segments shapely returns one (``all_matches=False``); the
    gap is the NumPy projection on it.
    """
    import shapely

    lines = shapely.linestrings(np.stack([start, end], axis=1))
    tree = shapely.STRtree(lines)
    slave, pair_segment = tree.query_nearest(
        shapely.points(x), max_distance=radius, all_matches=False
    )
    return closest_of_pairs(x, start, end, radius, slave, pair_segment)


def libigl_distance(x, start, end, radius):
    """libigl's ``point_mesh_squared_distance`` with the segments as 2D edges.

    It answers the nearest edge of every slave whatever the distance (an AABB
    tree built on each call); ``found`` is that distance within the radius.
    """
    import igl

    vertices = np.concatenate([start, end]).astype(np.float64)
    edges = np.stack([np.arange(len(start)), len(start) + np.arange(len(start))], axis=1)
    _, nearest, _ = igl.point_mesh_squared_distance(x.astype(np.float64), vertices, edges)
    slave = np.arange(len(x))
    return closest_of_pairs(x, start, end, radius, slave, nearest.astype(np.int64))


def jaxmd_cell_list(x, start, end, radius):
    """jax-md's cell list of the segment midpoints: ``(detect, args)`` to time.

    The cell list is allocated here, on the host (jax-md's ``allocate``), and
    refilled inside the jitted ``detect`` (its ``update``), as a jax-md user
    would split them. Cells have edge ``reach = radius + half the longest
    segment``, so every segment within the radius of a slave has its midpoint
    in the 3 x 3 cells around the slave's. ``detect`` returns
    ``(segment, gap, found, overflow)``.
    """
    import jax
    import jax.numpy as jnp
    from jax_md import partition

    middle, reach = _midpoint_reach(start, end, radius)
    both = np.concatenate([x, middle])
    origin = both.min(axis=0) - reach
    box = both.max(axis=0) + reach - origin
    # jax-md broadcasts (N, 2) against (2,) inside: allowed here whatever the caller's setting.
    with jax.numpy_rank_promotion("allow"):
        cells = partition.cell_list(jnp.asarray(box, x.dtype), float(reach)).allocate(
            jnp.asarray(middle - origin)
        )
    shape = np.array(cells.id_buffer.shape[1::-1])  # cells in x, in y (ids are [y, x, slot])
    cell_edge = jnp.asarray(box / shape, x.dtype)[None]  # f[1, 2]
    origin = jnp.asarray(origin, x.dtype)[None]

    steps = jnp.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)])  # i[9, 2]
    last_cell = jnp.asarray(shape - 1)[None]  # i[1, 2]

    def closest(slave, ids, start, end):
        """``(segment, gap, found)`` of one slave f[2] from the 3 x 3 cells around it."""
        own = jnp.floor((slave[None] - origin) / cell_edge).astype(jnp.int32)  # i[1, 2]
        around = jnp.clip(own + steps, 0, last_cell)  # i[9, 2]
        candidates = ids[around[:, 1], around[:, 0]].reshape(-1)  # i[9 * slots]
        real = candidates < len(start)
        k = jnp.where(real, candidates, 0)
        a, d = start[k], end[k] - start[k]
        from_a = slave[None] - a
        xi = jnp.clip(jnp.sum(from_a * d, -1) / jnp.sum(d * d, -1), 0, 1)
        offset = from_a - xi[:, None] * d
        distance_squared = jnp.where(real, jnp.sum(offset * offset, -1), jnp.inf)
        best = jnp.argmin(distance_squared)
        distance = jnp.sqrt(distance_squared[best])
        found = distance <= radius
        gap = jnp.where(cross(offset[best], d[best]) < 0, -distance, distance)
        return jnp.where(found, k[best], -1), jnp.where(found, gap, 0), found

    @jax.jit
    def detect(x, start, end):
        with jax.numpy_rank_promotion("allow"):
            refilled = cells.update((start + end) / 2 - origin)
        ids = refilled.id_buffer[..., 0]  # i[gy, gx, slots]
        # Slaves in batches: an (N, 9 * slots) candidate table would not fit at 10^6.
        answer = jax.lax.map(lambda one: closest(one, ids, start, end), x, batch_size=8192)
        return (*answer, refilled.did_buffer_overflow)

    return detect, tuple(jnp.asarray(a) for a in (x, start, end))


def ipctk_lbvh_project(x, start, end, radius):
    """IPC Toolkit's LBVH pairs (``ipc.lbvh_pairs``), then the NumPy projection of those pairs."""
    return closest_of_pairs(x, start, end, radius, *ipc.lbvh_pairs(x, start, end, radius))


def _numba_grid(threads):
    """prepare for ``numba_grid.closest`` on ``threads``: compiled ahead (``fn.compile_s``)."""

    def prepare(x, start, end, radius):
        return _run.numba_peer("closest", threads, x.dtype, (x, start, end), radius=radius)

    return prepare


def _plain(peer):
    return lambda x, start, end, radius: (functools.partial(peer, radius=radius), (x, start, end))


# name -> (module it needs, or None; prepare(x, start, end, radius) -> (fn, args), or a
# string: why it cannot run here). A plain fn with a ``compile_s`` attribute was
# compiled by prepare, outside the timer.
PEERS = {
    "NumPy dense": (None, _plain(numpy_dense)),
    "NumPy box-then-dense": (None, _plain(numpy_box_then_dense)),
    "NumPy box-then-dense, (N, M, 2)": (None, _plain(numpy_box_then_dense_tensor)),
    "cKDTree ball + NumPy projection": ("scipy", _plain(kdtree_project)),
    "cKDTree pairs + NumPy projection": ("scipy", _plain(kdtree_pairs_project)),
    "shapely STRtree": ("shapely", _plain(shapely_strtree)),
    "jax-md cell list": ("jax_md", jaxmd_cell_list),
    "libigl point_mesh_squared_distance": ("igl", _plain(libigl_distance)),
    "numba grid (1 thread)": ("numba", _numba_grid(1)),
    "numba grid (prange, 2 threads)": ("numba", _numba_grid(2)),
    "IPC Toolkit LBVH + NumPy projection": ("ipctk", _plain(ipctk_lbvh_project)),
}


def unavailable(name: str) -> str | None:
    """Why the peer ``name`` cannot run here (its module does not import), or None.

    Example:
      >>> unavailable("NumPy dense") is None
      True
    """
    return unavailable_module(PEERS[name][0])


def unavailable_module(module: str | None) -> str | None:
    """Why ``module`` (None: no module needed) does not import here, or None."""
    if module is None:
        return None
    try:
        importlib.import_module(module)
    except Exception as error:  # an import can fail in many ways (missing, ABI, jax version)
        return f"not installed: {type(error).__name__}: {error}".splitlines()[0][:120]
    return None
