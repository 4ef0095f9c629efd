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
PAD = 1e-6
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
    def box_cells(low_x, low_y, high_x, high_y, origin_x, origin_y, cell, nx, ny):
        """``(i0, i1, j0, j1)``: the inclusive cell ranges a box covers."""
        i0 = cell_index(low_x, origin_x, cell, nx)
        i1 = cell_index(high_x, origin_x, cell, nx)
        j0 = cell_index(low_y, origin_y, cell, ny)
        j1 = cell_index(high_y, origin_y, cell, ny)
        return i0, i1, j0, j1

    @njit
    def bin_boxes(low, high, origin_x, origin_y, cell, nx, ny):
        """CSR lists of the boxes ``[low, high]`` (f64[M, 2]) in each cell.

        Returns ``(first, items)``: cell ``c = j * nx + i`` holds
        ``items[first[c] : first[c + 1]]``, in ascending box index.
        """
        count = np.zeros(nx * ny + 1, np.int64)
        for k in range(low.shape[0]):
            i0, i1, j0, j1 = box_cells(
                low[k, 0], low[k, 1], high[k, 0], high[k, 1], origin_x, origin_y, cell, nx, ny
            )
            for j in range(j0, j1 + 1):
                for i in range(i0, i1 + 1):
                    count[j * nx + i + 1] += 1
        first = np.cumsum(count)
        cursor = first[:-1].copy()
        items = np.empty(first[-1], np.int64)
        for k in range(low.shape[0]):
            i0, i1, j0, j1 = box_cells(
                low[k, 0], low[k, 1], high[k, 0], high[k, 1], origin_x, origin_y, cell, nx, ny
            )
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

    # Inlined into the loop over a list's segments: called, it cost 3.5x the plain query's
    # time on the chip's outline at 10^4 nodes (measured alternated in one process).
    @numba.njit(cache=False, inline="always")
    def allowed(node, k, indices, seg_chain, low, high, loop, node_chain, node_arc, selfc, window):
        """Whether slave node ``node`` may meet segment ``k`` (jaxcontact's pair rule,
        ``jaxcontact/_pipeline/pairs.py``): never a segment through its own node; with
        self-contact, not one within ``window`` of it along its own outline."""
        if indices[k, 0] == node or indices[k, 1] == node:
            return False
        if not selfc or node >= node_chain.shape[0] or node_chain[node] < 0:
            return True
        if node_chain[node] != seg_chain[k]:
            return True
        at = node_arc[node]
        direct = max(max(low[k] - at, at - high[k]), 0.0)
        around = at + (loop[k] - high[k]) if at < low[k] else (loop[k] - at) + low[k]
        return min(direct, around) >= window

    @njit
    def outline_arcs(indices, start, end, num_nodes):
        """The arc coordinates the self-contact window reads, as jaxcontact defines them
        (``jaxcontact/_pipeline/outline.py``: a segment is followed by the lowest other one
        starting at its end node; a loop is cut open before its lowest segment; ``u`` runs
        from a chain's end back to its start), by walking each chain once. For outlines whose
        nodes join at most two segments, every segment real.

        Returns ``(chain, low, high, loop)`` per segment and ``(node_chain, node_arc)`` per node.
        """
        m = indices.shape[0]
        lowest_start = np.full(num_nodes, -1, np.int64)
        next_start = np.full(num_nodes, -1, np.int64)
        for j in range(m):
            s = indices[j, 0]
            if lowest_start[s] < 0:
                lowest_start[s] = j
            elif next_start[s] < 0:
                next_start[s] = j
        after = np.empty(m, np.int64)
        length = np.empty(m)
        for k in range(m):
            j = lowest_start[indices[k, 1]]
            after[k] = next_start[indices[k, 1]] if j == k else j
            dx = np.float64(end[k, 0]) - np.float64(start[k, 0])
            dy = np.float64(end[k, 1]) - np.float64(start[k, 1])
            length[k] = np.sqrt(dx * dx + dy * dy)
        # Loops: walk from each segment not yet seen; meeting the walk's own stamp closes a
        # loop, which is cut before its lowest segment and measured.
        loop = np.full(m, np.inf)
        stamp = np.full(m, -1, np.int64)
        for k0 in range(m):
            k = k0
            while k >= 0 and stamp[k] < 0:
                stamp[k] = k0
                k = after[k]
            if k >= 0 and stamp[k] == k0:
                lowest, total, j = k, 0.0, k
                while True:
                    lowest = min(lowest, j)
                    total += length[j]
                    j = after[j]
                    if j == k:
                        break
                j = k
                while True:
                    loop[j] = total
                    if after[j] == lowest:
                        nxt = after[j]
                        after[j] = -1
                        j = nxt
                    else:
                        j = after[j]
                    if j == k:
                        break
        # Suffix sums along each chain, from its head (a segment no other one leads to).
        led = np.zeros(m, np.bool_)
        for k in range(m):
            if after[k] >= 0:
                led[after[k]] = True
        chain = np.empty(m, np.int64)
        arc = np.empty(m)
        path = np.empty(m, np.int64)
        for head in range(m):
            if led[head]:
                continue
            count, k = 0, head
            while k >= 0:
                path[count] = k
                count += 1
                k = after[k]
            last, total = path[count - 1], 0.0
            for i in range(count - 1, -1, -1):
                total += length[path[i]]
                arc[path[i]] = total
                chain[path[i]] = last
        node_chain = np.full(num_nodes, -1, np.int64)
        node_arc = np.zeros(num_nodes)
        for k in range(m):
            node_chain[indices[k, 1]] = chain[k]
            node_arc[indices[k, 1]] = arc[k] - length[k]
        for k in range(m):
            node_chain[indices[k, 0]] = chain[k]
            node_arc[indices[k, 0]] = arc[k]
        return chain, arc - length, arc, loop, node_chain, node_arc

    @njit
    def outline_rule(slave_node, indices, start, end, num_nodes, window):
        """The rule's arrays for ``closest_rows``: no rule where ``slave_node`` is empty."""
        if slave_node.shape[0] == 0 or window <= 0.0:
            empty_f, empty_i = np.zeros(0), np.zeros(0, np.int64)
            return (
                slave_node,
                indices,
                empty_i,
                empty_f,
                empty_f,
                empty_f,
                empty_i,
                empty_f,
                window,
            )
        chain, low, high, loop, node_chain, node_arc = outline_arcs(indices, start, end, num_nodes)
        return slave_node, indices, chain, low, high, loop, node_chain, node_arc, window

    @njit
    def closest_rows(
        part, parts, x, start, end, radius, grid, first, items, rule, segment, gap, found
    ):
        """Fills the rows of blocks ``part, part + parts, ...`` of ``(segment, gap, found)``.

        ``rule``: ``outline_rule``'s tuple; a pair it forbids is never scored."""
        slave_node, indices, seg_chain, low, high, loop, node_chain, node_arc, window = rule
        own = slave_node.shape[0] > 0
        self_contact = window > 0.0
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
                node = slave_node[row] if own else -1
                for entry in range(first[c], first[c + 1]):
                    k = items[entry]
                    ax, ay = np.float64(start[k, 0]), np.float64(start[k, 1])
                    bx, by = np.float64(end[k, 0]), np.float64(end[k, 1])
                    distance_squared, cross = project(px, py, ax, ay, bx, by)
                    # The rule is asked only of a pair that would be kept: most are not.
                    if distance_squared > best or (
                        node >= 0
                        and not allowed(
                            node,
                            k,
                            indices,
                            seg_chain,
                            low,
                            high,
                            loop,
                            node_chain,
                            node_arc,
                            self_contact,
                            window,
                        )
                    ):
                        continue
                    if distance_squared < best:
                        best, best_k, best_cross = distance_squared, k, cross
                    elif distance_squared == best and best_k >= 0:
                        # An exact tie (a shared vertex): the larger signed normal
                        # distance cross / |d|, as the float64 reference; then the lower
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
                i0, i1, j0, j1 = box_cells(
                    low_x, low_y, high_x, high_y, origin_x, origin_y, cell, nx, ny
                )
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

    @njit
    def grid_over(low, high, cell):
        """f64[7] grid over the boxes ``[low, high]`` (f64[M, 2]): origin x and y, cell edge,
        top x and y, cells in x and in y. ``cell`` is widened where the grid would
        hold more than ``MAX_CELLS_PER_SEGMENT`` cells per box."""
        origin_x, origin_y = low[:, 0].min(), low[:, 1].min()
        top_x, top_y = high[:, 0].max(), high[:, 1].max()
        width, height = max(top_x - origin_x, 1e-300), max(top_y - origin_y, 1e-300)
        cell = max(cell, np.sqrt(width * height / (MAX_CELLS_PER_SEGMENT * low.shape[0])))
        nx, ny = max(1.0, np.ceil(width / cell)), max(1.0, np.ceil(height / cell))
        return np.array([origin_x, origin_y, cell, top_x, top_y, nx, ny])

    @njit
    def boxes(start, end, inflation):
        """f64[M, 2] low and high corners of the segments' boxes, inflated."""
        low = np.empty((start.shape[0], 2))
        high = np.empty((start.shape[0], 2))
        for k in range(start.shape[0]):
            for axis in range(2):
                a, b = np.float64(start[k, axis]), np.float64(end[k, axis])
                low[k, axis] = min(a, b) - inflation
                high[k, axis] = max(a, b) + inflation
        return low, high

    @njit
    def median_length(start, end):
        length = np.empty(start.shape[0])
        for k in range(start.shape[0]):
            dx = np.float64(end[k, 0]) - np.float64(start[k, 0])
            dy = np.float64(end[k, 1]) - np.float64(start[k, 1])
            length[k] = np.sqrt(dx * dx + dy * dy)
        return np.median(length)

    @njit
    def closest_setup(start, end, radius, cell):
        """The closest-point grid: ``(grid, first, items)``.

        Cell edge (``cell <= 0``): half the radius-inflated median segment box,
        ``median length / 2 + radius``. Chosen by timing this query on one
        thread (median of 15 calls) on the reference scenes at small sizes,
        with edges ``f (median + 2 radius)`` (``median + 2 radius``: the
        inflated box of the median segment) and with other rules. On the
        cutting scene at 81,939 nodes every rule took 0.16-0.20 ms (20
        segments: the pass over the slaves is the cost) except the longest
        segment's box (0.35 ms). On the rough die at (10^4, 10^3), (10^5,
        10^4) and (2 10^4, 10^5): f = 0.25 took 0.16, 2.5 and 12.3 ms; 0.5
        0.14, 2.8 and 7.4 ms; 0.7 0.15, 3.1 and 6.9 ms; 1 0.16, 3.9 and 7.7
        ms; 2 0.23, 6.8 and 12.4 ms; the longest segment's box 0.18 and 4.0
        ms, ``sqrt(box area / M)`` 0.18 and 2.9 ms (first two only). So 0.5:
        within 11% of the best on every scene.
        """
        if cell <= 0:
            cell = median_length(start, end) / 2 + radius
        low, high = boxes(start, end, radius * (1 + PAD))
        grid = grid_over(low, high, cell)
        first, items = bin_boxes(low, high, grid[0], grid[1], grid[2], int(grid[5]), int(grid[6]))
        return grid, first, items

    @njit
    def swept_setup(start, end, cell):
        """The path grid: ``(grid, first, items)``.

        Cell edge (``cell <= 0``): the larger of the median segment length and
        ``sqrt(area / M)``, ``area`` the segments' box's (about as many cells
        as segments). Timed as ``closest_setup``: on the reference scenes with
        paths (the cutting scene at 81,939 nodes, tool in and clear, 0.2 of
        travel; the paper's Tests 1 and 2 at 82,369 and 63,001 nodes) every
        rule tried took 0.27-0.34 ms, the pass over the paths, as those tools
        have 2 or 20 segments (the longest segment: 0.43 ms with the tool
        in). So the rule was chosen on the rough die (10^4 and 10^5 segments)
        with its slaves given paths 0.03 and 0.3 long (not a reference scene:
        none has many segments and motion), three cases: ``sqrt(area / M)``
        took 2.5, 8.3 and 3.7 ms, the median segment length 9.6, 36 and 85
        ms, 4 times it 2.9, 12 and 69 ms, the median path length 2.9, 32 and
        4.2 ms; the larger of the median segment length and ``sqrt(area /
        M)`` 2.5, 7.8 and 3.8 ms.
        """
        low, high = boxes(start, end, 0.0)
        if cell <= 0:
            width = high[:, 0].max() - low[:, 0].min()
            height = high[:, 1].max() - low[:, 1].min()
            cell = max(median_length(start, end), np.sqrt(width * height / start.shape[0]))
        grid = grid_over(low, high, cell)
        first, items = bin_boxes(low, high, grid[0], grid[1], grid[2], int(grid[5]), int(grid[6]))
        return grid, first, items

    # One numba call per query, grid included: the set-up on the host in NumPy
    # cost 30 us a call more (10 small NumPy calls and three dispatches).
    @njit
    def closest_serial(x, start, end, radius, cell, slave_node, indices, num_nodes, window):
        grid, first, items = closest_setup(start, end, radius, cell)
        rule = outline_rule(slave_node, indices, start, end, num_nodes, window)
        n = x.shape[0]
        segment, gap, found = np.empty(n, np.int64), np.empty(n, x.dtype), np.empty(n, np.bool_)
        closest_rows(0, 1, x, start, end, radius, grid, first, items, rule, segment, gap, found)
        return segment, gap, found

    @numba.njit(cache=False, parallel=True)
    def closest_parallel(
        x, start, end, radius, cell, parts, slave_node, indices, num_nodes, window
    ):
        grid, first, items = closest_setup(start, end, radius, cell)
        rule = outline_rule(slave_node, indices, start, end, num_nodes, window)
        n = x.shape[0]
        segment, gap, found = np.empty(n, np.int64), np.empty(n, x.dtype), np.empty(n, np.bool_)
        for part in numba.prange(parts):
            closest_rows(
                part, parts, x, start, end, radius, grid, first, items, rule, segment, gap, found
            )
        return segment, gap, found

    @njit
    def swept_serial(x_prev, x, start, end, cell):
        grid, first, items = swept_setup(start, end, cell)
        n = x.shape[0]
        segment, t, crossed = np.empty(n, np.int64), np.empty(n, x.dtype), np.empty(n, np.bool_)
        swept_rows(0, 1, x_prev, x, start, end, grid, first, items, segment, t, crossed)
        return segment, t, crossed

    @numba.njit(cache=False, parallel=True)
    def swept_parallel(x_prev, x, start, end, cell, parts):
        grid, first, items = swept_setup(start, end, cell)
        n = x.shape[0]
        segment, t, crossed = np.empty(n, np.int64), np.empty(n, x.dtype), np.empty(n, np.bool_)
        for part in numba.prange(parts):
            swept_rows(part, parts, x_prev, x, start, end, grid, first, items, segment, t, crossed)
        return segment, t, crossed

    return {
        "closest": (closest_serial, closest_parallel),
        "swept": (swept_serial, swept_parallel),
        "numba": numba,
    }


def closest(x, start, end, radius, *, threads=1, cell=0.0, pairs=None):
    """``(segment, gap, found)`` of every slave: the closest segment within ``radius``.

    Args:
      x: f[N, 2] slaves, float32 or float64.
      start: f[M, 2] segment starts (M >= 1), the same dtype.
      end: f[M, 2] segment ends.
      radius: search radius.
      threads: 1 (one loop) or more (numba's ``prange``, one part per thread).
      cell: cell edge; 0 for the rule of ``closest_setup`` (see ``_kernels``).
      pairs: None, or jaxcontact's pair rule for slaves that are nodes of the outline,
        ``(slave_node i64[N], indices i64[M, 2], num_nodes, self_contact)``: a slave never
        meets a segment through its own node and, with ``self_contact``, not one within
        ``4 radius`` of it along its own outline (``jaxcontact.Pairs``; the arc lengths
        computed at every call, as the grid is).

    Returns:
      ``segment`` i64[N] (-1 where not found), ``gap`` f[N] in ``x``'s dtype
      (0 where not found), ``found`` bool[N]. Of segments at exactly equal
      distance, the larger signed normal distance, then the lower index.
    """
    serial, parallel = _kernels()["closest"]
    rule = _rule(pairs, float(radius))
    if threads == 1:
        return serial(x, start, end, float(radius), float(cell), *rule)
    _kernels()["numba"].set_num_threads(threads)
    return parallel(x, start, end, float(radius), float(cell), threads, *rule)


# jaxcontact's self-contact window in multiples of the radius (``pairs.SELF_CONTACT_REACH``).
SELF_CONTACT_REACH = 4.0


def _rule(pairs, radius: float) -> tuple:
    """``closest``'s ``pairs`` as the kernels take them: no rule is empty arrays."""
    if pairs is None:
        return np.zeros(0, np.int64), np.zeros((0, 2), np.int64), 0, 0.0
    slave_node, indices, num_nodes, self_contact = pairs
    window = SELF_CONTACT_REACH * radius if self_contact else 0.0
    indices = np.ascontiguousarray(indices, np.int64)
    return np.ascontiguousarray(slave_node, np.int64), indices, int(num_nodes), window


def swept(x_prev, x, start, end, *, threads=1, cell=0.0):
    """``(segment, t, crossed)`` of every path ``x_prev -> x``: its first crossing.

    Args:
      x_prev: f[N, 2] path starts, float32 or float64.
      x: f[N, 2] path ends, the same dtype.
      start: f[M, 2] segment starts (M >= 1), the same dtype.
      end: f[M, 2] segment ends.
      threads: 1 (one loop) or more (numba's ``prange``, one part per thread).
      cell: cell edge; 0 for the rule of ``swept_setup`` (see ``_kernels``).

    Returns:
      ``segment`` i64[N] (-1 where none), ``t`` f[N] in ``x``'s dtype (0
      where none), ``crossed`` bool[N]. Exact ties in ``t`` go to the lower index.
    """
    serial, parallel = _kernels()["swept"]
    if threads == 1:
        return serial(x_prev, x, start, end, float(cell))
    _kernels()["numba"].set_num_threads(threads)
    return parallel(x_prev, x, start, end, float(cell), threads)


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
