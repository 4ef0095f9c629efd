"""Hand-written numba grids for the closest-segment and the path-crossing queries.

What an engineer fluent in numba writes by hand for a CPU, as a peer for the
benchmarks: a uniform grid of cells, rebuilt at every call, in compressed
sparse rows (per cell a count, then their prefix sum, then the segment
indices filled in ascending order), and one loop over the slaves.

- Closest point (``closest``): cells over the segments' box inflated by the
  radius; each segment is listed in every cell its radius-inflated box
  touches, so a slave within the radius of a segment lies in that box and
  its own cell lists the segment. Each slave projects onto its own cell's
  segments only and keeps the closest within the radius.
- Path crossing (``swept``): cells over the segments' box; each segment is
  listed in the cells its box touches. Each path ``x_prev -> x`` visits the
  cells its own box covers, tests each segment once (a stamp per segment
  records the last path that tested it), and keeps the smallest ``t``.

Both run in float64 inside (scalar code: no slower than float32 on a CPU),
on float32 or float64 inputs. One thread by default (``numba.njit``, no
``parallel``); ``threads > 1`` splits the slaves into blocks over numba's
``prange``, on numba's ``workqueue`` threads unless ``NUMBA_THREADING_LAYER``
says otherwise. The kernels are compiled on first use, for the input dtype:
``compile_for`` does it ahead of the timed runs and says how long it took.
numba is optional: it is imported inside ``_kernels``.

The code is written for this package from the contract (docs/contract.md);
the cell index ``floor((p - origin) / cell)`` is computed by one function for
box corners and points alike, so a point in a box lies in one of the box's
cells whatever the rounding.
"""

from __future__ import annotations

import functools
import os
import time

import numpy as np

# Cells per segment at most, so that a few long segments over a wide box
# cannot ask for a grid larger than the data (the grid is rebuilt every call).
MAX_CELLS_PER_SEGMENT = 64
# A segment's box is inflated by the radius and this fraction of it more, so
# that float64 rounding of ``min(a, b) - radius`` cannot drop a slave at the radius.
_PAD = 1e-6
# Rows per block dealt to a thread (``threads > 1``).
BLOCK = 1024


@functools.cache
def _kernels():
    """The compiled kernels (numba imported here, so the package does not need it)."""
    import numba

    if "NUMBA_THREADING_LAYER" not in os.environ:
        # numba's own thread pool, whose idle threads sleep. Measured on 2 busy
        # cores at 81,939 nodes: 0.28 ms a call; libgomp (numba's first choice
        # here) 7.8 ms, its threads spinning after each region against the
        # other load (0.25 ms with OMP_WAIT_POLICY=passive), and they would spin
        # into the next method of a round-robin too. Chosen before any prange
        # runs, which is when numba starts its threads.
        numba.config.THREADING_LAYER = "workqueue"
    njit = numba.njit(cache=False)

    @njit
    def cell_index(value, origin, cell, count):
        """The cell of one coordinate, clamped into ``[0, count)``."""
        index = int(np.floor((value - origin) / cell))
        return min(max(index, 0), count - 1)

    @njit
    def bin_boxes(low, high, origin_x, origin_y, cell, nx, ny):
        """CSR lists of the boxes ``[low, high]`` (f64[M, 2]) in each cell.

        Returns ``(first, items)``: cell ``c = j * nx + i`` holds
        ``items[first[c] : first[c + 1]]``, in ascending box index.
        """
        count = np.zeros(nx * ny + 1, np.int64)
        for k in range(low.shape[0]):
            i0 = cell_index(low[k, 0], origin_x, cell, nx)
            i1 = cell_index(high[k, 0], origin_x, cell, nx)
            j0 = cell_index(low[k, 1], origin_y, cell, ny)
            j1 = cell_index(high[k, 1], origin_y, cell, ny)
            for j in range(j0, j1 + 1):
                for i in range(i0, i1 + 1):
                    count[j * nx + i + 1] += 1
        first = np.cumsum(count)
        cursor = first[:-1].copy()
        items = np.empty(first[-1], np.int64)
        for k in range(low.shape[0]):
            i0 = cell_index(low[k, 0], origin_x, cell, nx)
            i1 = cell_index(high[k, 0], origin_x, cell, nx)
            j0 = cell_index(low[k, 1], origin_y, cell, ny)
            j1 = cell_index(high[k, 1], origin_y, cell, ny)
            for j in range(j0, j1 + 1):
                for i in range(i0, i1 + 1):
                    items[cursor[j * nx + i]] = k
                    cursor[j * nx + i] += 1
        return first, items

    @njit
    def project(px, py, ax, ay, bx, by):
        """``(distance_squared, cross)`` of point ``p`` on segment ``a -> b``.

        The clamp is decided by the signs of ``(p - a) . d`` and ``(p - b) . d``
        and an end point is used as it is, so a vertex shared by two segments
        is the same point from both (docs/contract.md, "Closest point").
        ``cross = (p - q) x d`` has the sign of the signed gap.
        """
        dx, dy = bx - ax, by - ay
        along = (px - ax) * dx + (py - ay) * dy
        if along <= 0.0:
            qx, qy = ax, ay
        elif (px - bx) * dx + (py - by) * dy >= 0.0:
            qx, qy = bx, by
        else:
            xi = along / (dx * dx + dy * dy)
            qx, qy = ax + xi * dx, ay + xi * dy
        ox, oy = px - qx, py - qy
        return ox * ox + oy * oy, ox * dy - oy * dx

    @njit
    def closest_rows(part, parts, x, start, end, radius, grid, first, items, segment, gap, found):
        """Fills the rows of blocks ``part, part + parts, ...`` of ``(segment, gap, found)``."""
        origin_x, origin_y, cell, top_x, top_y = grid[0], grid[1], grid[2], grid[3], grid[4]
        nx, ny = int(grid[5]), int(grid[6])
        limit = radius * radius
        n = x.shape[0]
        # Blocks dealt round-robin to the parts: two threads stay equally busy
        # when the slaves near the tool are all in a few consecutive rows.
        for block in range(part, (n + BLOCK - 1) // BLOCK, parts):
            for row in range(block * BLOCK, min(n, (block + 1) * BLOCK)):
                px, py = np.float64(x[row, 0]), np.float64(x[row, 1])
                segment[row], gap[row], found[row] = -1, 0.0, False
                if not (origin_x <= px <= top_x and origin_y <= py <= top_y):
                    continue
                c = cell_index(py, origin_y, cell, ny) * nx + cell_index(px, origin_x, cell, nx)
                best, best_k, best_cross = np.inf, -1, 0.0
                for entry in range(first[c], first[c + 1]):
                    k = items[entry]
                    ax, ay = np.float64(start[k, 0]), np.float64(start[k, 1])
                    bx, by = np.float64(end[k, 0]), np.float64(end[k, 1])
                    distance_squared, cross = project(px, py, ax, ay, bx, by)
                    if distance_squared < best:
                        best, best_k, best_cross = distance_squared, k, cross
                    elif distance_squared == best and best_k >= 0:
                        # An exact tie (a shared vertex): the larger signed normal
                        # distance cross / |d|, as the float64 oracle; then the lower
                        # index, which the ascending lists give by keeping the first.
                        dx, dy = bx - ax, by - ay
                        bdx = np.float64(end[best_k, 0]) - np.float64(start[best_k, 0])
                        bdy = np.float64(end[best_k, 1]) - np.float64(start[best_k, 1])
                        mine = cross / np.sqrt(dx * dx + dy * dy)
                        if mine > best_cross / np.sqrt(bdx * bdx + bdy * bdy):
                            best_k, best_cross = k, cross
                if best <= limit:
                    distance = np.sqrt(best)
                    segment[row] = best_k
                    gap[row] = -distance if best_cross < 0.0 else distance
                    found[row] = True

    @njit
    def path_hit(px, py, qx, qy, ax, ay, bx, by):
        """First ``t`` in ``[0, 1]`` where the path ``p -> q`` meets ``a -> b``, or 2 (none).

        Orientation tests, from the contract: touching an end counts, a path
        along the segment's line meets it at its first ``t`` inside it, a
        parallel path off the line never does.
        """
        ux, uy, dx, dy = qx - px, qy - py, bx - ax, by - ay
        side_p = dx * (py - ay) - dy * (px - ax)  # which side of the segment's line p is
        side_q = dx * (qy - ay) - dy * (qx - ax)
        if side_p == 0.0 and side_q == 0.0:  # the path runs along the segment's line
            length_d = dx * dx + dy * dy
            along_p = (px - ax) * dx + (py - ay) * dy
            if 0.0 <= along_p <= length_d:
                return 0.0 if length_d > 0.0 else 2.0
            along_q = (qx - ax) * dx + (qy - ay) * dy
            entry = 0.0 if along_p < 0.0 else length_d
            if along_q == along_p:
                return 2.0
            t = (entry - along_p) / (along_q - along_p)
            return t if 0.0 <= t <= 1.0 else 2.0
        if (side_p > 0.0 and side_q > 0.0) or (side_p < 0.0 and side_q < 0.0):
            return 2.0
        side_a = ux * (ay - py) - uy * (ax - px)  # which side of the path's line a is
        side_b = ux * (by - py) - uy * (bx - px)
        if (side_a > 0.0 and side_b > 0.0) or (side_a < 0.0 and side_b < 0.0):
            return 2.0
        if side_p == 0.0:
            return 0.0
        if side_q == 0.0:
            return 1.0
        return min(max(side_p / (side_p - side_q), 0.0), 1.0)

    @njit
    def swept_rows(part, parts, x_prev, x, start, end, grid, first, items, segment, t, crossed):
        """Fills the rows of blocks ``part, part + parts, ...`` of ``(segment, t, crossed)``."""
        origin_x, origin_y, cell, top_x, top_y = grid[0], grid[1], grid[2], grid[3], grid[4]
        nx, ny = int(grid[5]), int(grid[6])
        stamp = np.full(start.shape[0], -1, np.int64)  # the last path that tested a segment
        n = x.shape[0]
        # Blocks dealt round-robin to the parts: two threads stay equally busy
        # when the slaves near the tool are all in a few consecutive rows.
        for block in range(part, (n + BLOCK - 1) // BLOCK, parts):
            for row in range(block * BLOCK, min(n, (block + 1) * BLOCK)):
                px, py = np.float64(x_prev[row, 0]), np.float64(x_prev[row, 1])
                qx, qy = np.float64(x[row, 0]), np.float64(x[row, 1])
                segment[row], t[row], crossed[row] = -1, 0.0, False
                low_x, high_x = min(px, qx), max(px, qx)
                low_y, high_y = min(py, qy), max(py, qy)
                if high_x < origin_x or low_x > top_x or high_y < origin_y or low_y > top_y:
                    continue
                i0 = cell_index(low_x, origin_x, cell, nx)
                i1 = cell_index(high_x, origin_x, cell, nx)
                j0 = cell_index(low_y, origin_y, cell, ny)
                j1 = cell_index(high_y, origin_y, cell, ny)
                best, best_k = 2.0, -1
                for j in range(j0, j1 + 1):
                    for i in range(i0, i1 + 1):
                        c = j * nx + i
                        for entry in range(first[c], first[c + 1]):
                            k = items[entry]
                            if stamp[k] == row:
                                continue
                            stamp[k] = row
                            ax, ay = np.float64(start[k, 0]), np.float64(start[k, 1])
                            bx, by = np.float64(end[k, 0]), np.float64(end[k, 1])
                            if (
                                max(ax, bx) < low_x
                                or min(ax, bx) > high_x
                                or max(ay, by) < low_y
                                or min(ay, by) > high_y
                            ):
                                continue
                            hit = path_hit(px, py, qx, qy, ax, ay, bx, by)
                            if hit < best or (hit == best and hit <= 1.0 and k < best_k):
                                best, best_k = hit, k
                if best_k >= 0:
                    segment[row], t[row], crossed[row] = best_k, best, True

    def chunked(rows):
        """``rows(part, parts, ...)`` over all rows: in one call, or one part per thread."""

        @njit
        def serial(*args):
            rows(0, 1, *args)

        @numba.njit(cache=False, parallel=True)
        def parallel(parts, *args):
            for part in numba.prange(parts):
                rows(part, parts, *args)

        return serial, parallel

    return {
        "bin_boxes": bin_boxes,
        "closest": chunked(closest_rows),
        "swept": chunked(swept_rows),
        "numba": numba,
    }


def _grid(low, high, cell, count):
    """f64[7]: origin x and y, cell edge, top x and y, cells in x and in y.

    The cells cover ``[low, high]``; ``cell`` is widened where the grid
    would hold more than ``MAX_CELLS_PER_SEGMENT * count`` cells.
    """
    extent = np.maximum(high - low, 1e-300)
    cell = max(float(cell), float(np.sqrt(extent[0] * extent[1] / (MAX_CELLS_PER_SEGMENT * count))))
    shape = np.maximum(1, np.ceil(extent / cell))
    return np.array([low[0], low[1], cell, high[0], high[1], shape[0], shape[1]], np.float64)


def closest_cell(start, end, radius):
    """The closest-point grid's cell edge: half the radius-inflated median segment box.

    That is ``median length / 2 + radius``. Chosen by timing the one-thread
    kernel (median of 15 calls, one core) on the reference scenes at small
    sizes with cell edges that are multiples of ``median + 2 radius`` (the
    inflated box of the median segment) and with other rules: on the cutting
    scene at 81,939 nodes every rule took 0.19-0.21 ms (20 segments: the
    pass over the slaves is the cost) except the longest segment's box
    (0.37 ms); on the rough die at (10^4, 10^3), (10^5, 10^4) and
    (2 10^4, 10^5) the best factors were 0.35-0.7 (0.20, 3.1 and 10.9 ms),
    against 0.23, 4.4 and 11.5 ms at 1 (``median + 2 radius``), 0.30, 7.2
    and 16.0 ms at 2, 0.22, 4.2 ms for the longest segment's box and 0.22,
    3.3 ms for ``sqrt(box area / M)``. So 0.5.
    """
    length = np.hypot(*(end - start).T)
    return float(np.median(length)) / 2 + radius


def closest(x, start, end, radius, *, threads=1, cell=None):
    """``(segment, gap, found)`` of every slave: the closest segment within ``radius``.

    Args:
      x: f[N, 2] slaves, float32 or float64.
      start: f[M, 2] segment starts (M >= 1).
      end: f[M, 2] segment ends.
      radius: search radius.
      threads: 1 (one loop) or more (numba's ``prange``, one part per thread).
      cell: cell edge; ``closest_cell`` when None.

    Returns:
      ``segment`` i64[N] (-1 where not found), ``gap`` f[N] in ``x``'s dtype
      (0 where not found), ``found`` bool[N]. Of segments at exactly equal
      distance, the larger signed normal distance, then the lower index.
    """
    kernels = _kernels()
    start64, end64 = np.asarray(start, np.float64), np.asarray(end, np.float64)
    reach = radius * (1 + _PAD)
    low = np.minimum(start64, end64) - reach  # f64[M, 2] inflated boxes
    high = np.maximum(start64, end64) + reach
    cell = closest_cell(start64, end64, radius) if cell is None else cell
    grid = _grid(low.min(axis=0), high.max(axis=0), cell, len(start))
    first, items = kernels["bin_boxes"](low, high, *grid[:3], int(grid[5]), int(grid[6]))
    segment = np.empty(len(x), np.int64)
    gap = np.empty(len(x), x.dtype)
    found = np.empty(len(x), bool)
    args = (x, start, end, float(radius), grid, first, items, segment, gap, found)
    serial, parallel = kernels["closest"]
    if threads == 1:
        serial(*args)
    else:
        kernels["numba"].set_num_threads(threads)
        parallel(threads, *args)
    return segment, gap, found


def swept_cell(start, end):
    """The path grid's cell edge: the larger of the median segment length and ``sqrt(area / M)``.

    ``area`` is the segments' box's, so the cells are about as many as the
    segments. Timed as ``closest_cell``: on the reference scenes with paths
    (the cutting scene at 81,939 nodes, tool in and clear, 0.2 of travel;
    the paper's Tests 1 and 2 at 82,369 and 63,001 nodes) every rule tried
    took 0.27-0.35 ms, the pass over the paths, as those tools have 2 or 20
    segments. So the rule was chosen on the rough die (10^4 and 10^5
    segments), its slaves given paths 0.03 and 0.3 long (not a reference
    scene: none has many segments and motion): there ``sqrt(area / M)``
    took 2.8, 8.9 and 7.1 ms, the median segment length 9.3, 36 and 89 ms,
    4 times it 3.2, 12 and 74 ms, and the median path length 3.2, 32 and
    7.8 ms.
    """
    low, high = np.minimum(start, end).min(axis=0), np.maximum(start, end).max(axis=0)
    area = float(np.prod(high - low))
    return max(float(np.median(np.hypot(*(end - start).T))), np.sqrt(area / len(start)))


def swept(x_prev, x, start, end, *, threads=1, cell=None):
    """``(segment, t, crossed)`` of every path ``x_prev -> x``: its first crossing.

    Args:
      x_prev: f[N, 2] path starts, float32 or float64.
      x: f[N, 2] path ends, the same dtype.
      start: f[M, 2] segment starts (M >= 1).
      end: f[M, 2] segment ends.
      threads: 1 (one loop) or more (numba's ``prange``, one part per thread).
      cell: cell edge; ``swept_cell`` when None.

    Returns:
      ``segment`` i64[N] (-1 where none), ``t`` f[N] in ``x``'s dtype (0
      where none), ``crossed`` bool[N]. Exact ties in ``t`` go to the lower index.
    """
    kernels = _kernels()
    start64, end64 = np.asarray(start, np.float64), np.asarray(end, np.float64)
    low = np.minimum(start64, end64)
    high = np.maximum(start64, end64)
    cell = swept_cell(start64, end64) if cell is None else cell
    grid = _grid(low.min(axis=0), high.max(axis=0), cell, len(start))
    first, items = kernels["bin_boxes"](low, high, *grid[:3], int(grid[5]), int(grid[6]))
    segment = np.empty(len(x), np.int64)
    t = np.empty(len(x), x.dtype)
    crossed = np.empty(len(x), bool)
    args = (x_prev, x, start, end, grid, first, items, segment, t, crossed)
    serial, parallel = kernels["swept"]
    if threads == 1:
        serial(*args)
    else:
        kernels["numba"].set_num_threads(threads)
        parallel(threads, *args)
    return segment, t, crossed


def compile_for(query, dtype, threads=1) -> float:
    """Compiles ``closest`` or ``swept`` (``query``) for ``dtype`` ahead of timed runs.

    numba compiles on the first call, once per argument types (not per
    shape), so this calls the query on one slave and one segment and returns
    how long that took: the compile time in the first call of the process,
    about 0 afterwards.
    """
    one = np.zeros((1, 2), dtype)
    began = time.perf_counter()
    if query == "closest":
        closest(one, one, one + 1, 0.1, threads=threads)
    else:
        swept(one, one + 1, one, one + 1, threads=threads)
    return time.perf_counter() - began
