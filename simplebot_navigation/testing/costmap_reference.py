"""Straightforward per-cell / per-ray costmap update in plain Python, written from the REFERENCE text.

It is the yardstick for the vectorised package code: the tests compare grids cell for cell and
bench/costmap_update.py times both in the same run. Layer stack: ObstacleLayer (max combination,
footprint clearing) then InflationLayer, on a LayeredCostmap with a FREE master.
"""

from __future__ import annotations

import heapq
import math

FREE, INSCRIBED, LETHAL, UNKNOWN = 0, 253, 254, 255


def bresenham(x0, y0, x1, y1, max_length=math.inf):
    """Cells of costmap_2d's raytrace: the steps, then once more the cell it stopped on."""
    dx, dy = x1 - x0, y1 - y0
    adx, ady = abs(dx), abs(dy)
    sx, sy = (1 if dx > 0 else -1), (1 if dy > 0 else -1)
    dist = math.hypot(dx, dy)
    scale = 1.0 if dist == 0 else min(1.0, max_length / dist)
    if adx >= ady:
        major, minor, step_major, step_minor = adx, ady, (sx, 0), (0, sy)
    else:
        major, minor, step_major, step_minor = ady, adx, (0, sy), (sx, 0)
    error = major // 2
    x, y = x0, y0
    cells = []
    for _ in range(min(int(scale * major), major)):
        cells.append((x, y))
        x, y = x + step_major[0], y + step_major[1]
        error += minor
        if error >= major:
            x, y = x + step_minor[0], y + step_minor[1]
            error -= major
    cells.append((x, y))
    return cells


def inflation_cost(d, res, r_ins, w):
    if d == 0:
        return LETHAL
    if d * res <= r_ins:
        return INSCRIBED
    return int(252 * math.exp(-w * (d * res - r_ins)))


def brushfire(grid, size_x, size_y, x0, y0, xn, yn, res, r_ins, w, r_inf, inflate_unknown=False):
    """Inflate grid[y][x] in place: distance bins visited in increasing order, FIFO within a bin,
    4-neighbours carry their source cell, first visit wins, bins already passed are never revisited."""
    cr = max(0, math.ceil(r_inf / res))
    if cr == 0:
        return
    x0, y0, xn, yn = max(0, x0 - cr), max(0, y0 - cr), min(size_x, xn + cr), min(size_y, yn + cr)
    seen = [[False] * size_x for _ in range(size_y)]
    bins = {0.0: [(i, j, i, j) for j in range(y0, yn) for i in range(x0, xn) if grid[j][i] == LETHAL]}
    keys = [0.0]
    current = -1.0
    while keys:
        key = heapq.heappop(keys)
        if key <= current:
            continue
        current = key
        cells = bins[key]
        k = 0
        while k < len(cells):
            mx, my, sx, sy = cells[k]
            k += 1
            if seen[my][mx]:
                continue
            seen[my][mx] = True
            cost = inflation_cost(math.hypot(mx - sx, my - sy), res, r_ins, w)
            old = grid[my][mx]
            if old == UNKNOWN and (cost > 0 if inflate_unknown else cost >= INSCRIBED):
                grid[my][mx] = cost
            else:
                grid[my][mx] = max(old, cost)
            for nx, ny in ((mx - 1, my), (mx, my - 1), (mx + 1, my), (mx, my + 1)):
                if 0 <= nx < size_x and 0 <= ny < size_y and not seen[ny][nx]:
                    d = math.hypot(nx - sx, ny - sy)
                    if d <= cr:
                        if d not in bins:
                            bins[d] = []
                            heapq.heappush(keys, d)
                        bins[d].append((nx, ny, sx, sy))


class ReferenceCostmap:
    """One obstacle layer + one inflation layer, cell by cell."""

    def __init__(self, size_x, size_y, res, origin_x, origin_y, rolling, track_unknown_layer,
                 footprint, r_inf, w):
        self.size_x, self.size_y, self.res = size_x, size_y, res
        self.ox, self.oy = origin_x, origin_y
        self.rolling = rolling
        self.layer_default = UNKNOWN if track_unknown_layer else FREE
        self.layer = [[self.layer_default] * size_x for _ in range(size_y)]
        self.master = [[FREE] * size_x for _ in range(size_y)]
        self.footprint = footprint
        edges = []
        for (ax, ay), (bx, by) in zip(footprint, footprint[1:] + footprint[:1]):
            t = ((-ax) * (bx - ax) + (-ay) * (by - ay)) / ((bx - ax) ** 2 + (by - ay) ** 2)
            t = min(1.0, max(0.0, t))
            edges.append(math.hypot(ax + t * (bx - ax), ay + t * (by - ay)))
        self.r_ins = min(edges)
        self.r_inf, self.w = r_inf, w
        self.last = None    # inflation's previous bounds; None = first cycle covers everything

    def world_to_map(self, wx, wy):
        if wx < self.ox or wy < self.oy:
            return None
        mx, my = int((wx - self.ox) / self.res), int((wy - self.oy) / self.res)
        return (mx, my) if mx < self.size_x and my < self.size_y else None

    def _shift(self, grid, default, new_ox, new_oy):
        cx, cy = int((new_ox - self.ox) / self.res), int((new_oy - self.oy) / self.res)
        if cx == 0 and cy == 0:
            return grid, False
        out = [[default] * self.size_x for _ in range(self.size_y)]
        for j in range(self.size_y):
            for i in range(self.size_x):
                si, sj = i + cx, j + cy
                if 0 <= si < self.size_x and 0 <= sj < self.size_y:
                    out[j][i] = grid[sj][si]
        return out, (cx, cy)

    def update(self, rx, ry, ryaw, observations):
        if self.rolling:
            self._roll(rx, ry)
        b = [1e30, 1e30, -1e30, -1e30]

        def touch(x, y):
            b[0], b[1], b[2], b[3] = min(b[0], x), min(b[1], y), max(b[2], x), max(b[3], y)

        self._clear_rays(observations, touch)
        self._mark(observations, touch)
        c, s = math.cos(ryaw), math.sin(ryaw)
        poly = [(rx + x * c - y * s, ry + x * s + y * c) for x, y in self.footprint]
        for x, y in poly:
            touch(x, y)
        x0, y0, xn, yn = self._update_window(b)
        for j in range(y0, yn):
            for i in range(x0, xn):
                self.master[j][i] = FREE
        self._clear_footprint(poly)
        for j in range(y0, yn):                                       # maximum combination
            for i in range(x0, xn):
                v, m = self.layer[j][i], self.master[j][i]
                if v != UNKNOWN and (m == UNKNOWN or m < v):
                    self.master[j][i] = v
        brushfire(self.master, self.size_x, self.size_y, x0, y0, xn, yn, self.res, self.r_ins, self.w, self.r_inf)
        return x0, y0, xn, yn

    def _roll(self, rx, ry):
        new_ox = rx - (self.size_x - 0.5) * self.res / 2
        new_oy = ry - (self.size_y - 0.5) * self.res / 2
        self.master, shift = self._shift(self.master, FREE, new_ox, new_oy)
        self.layer, _ = self._shift(self.layer, self.layer_default, new_ox, new_oy)
        if shift:
            self.ox += shift[0] * self.res
            self.oy += shift[1] * self.res

    def _clear_rays(self, observations, touch):
        end_x, end_y = self.ox + self.size_x * self.res, self.oy + self.size_y * self.res
        for obs in observations:
            ox, oy = float(obs.origin[0]), float(obs.origin[1])
            start = self.world_to_map(ox, oy)
            if start is None:
                continue
            touch(ox, oy)
            for p in list(obs.points) + list(obs.clear_points):
                wx, wy = float(p[0]), float(p[1])
                a, bb = wx - ox, wy - oy
                if wx < self.ox:
                    t = (self.ox - ox) / a
                    wx, wy = self.ox, oy + bb * t
                if wy < self.oy:
                    t = (self.oy - oy) / bb
                    wx, wy = ox + a * t, self.oy
                if wx > end_x:
                    t = (end_x - ox) / a
                    wx, wy = end_x - 0.001, oy + bb * t
                if wy > end_y:
                    t = (end_y - oy) / bb
                    wx, wy = ox + a * t, end_y - 0.001
                end = self.world_to_map(wx, wy)
                if end is None:
                    continue
                for cx, cy in bresenham(*start, *end, max(0, math.ceil(obs.raytrace_range / self.res))):
                    self.layer[cy][cx] = FREE
                full = math.hypot(wx - ox, wy - oy)
                scale = min(1.0, obs.raytrace_range / full) if full > 0 else 1.0
                touch(ox + (wx - ox) * scale, oy + (wy - oy) * scale)

    def _mark(self, observations, touch):
        for obs in observations:
            for p in obs.points:
                px, py, pz = float(p[0]), float(p[1]), float(p[2])
                if pz > 2.0:
                    continue
                d2 = sum((float(p[k]) - float(obs.origin[k])) ** 2 for k in range(3))
                if d2 >= obs.obstacle_range ** 2:
                    continue
                cell = self.world_to_map(px, py)
                if cell is not None:
                    self.layer[cell[1]][cell[0]] = LETHAL
                    touch(px, py)

    def _update_window(self, b):
        """Cells of the update: the layer's bounds grown by the inflation radius and last update's bounds."""
        if self.last is None:
            big = 3.4028234663852886e38
            self.last = list(b)
            b = [-big, -big, big, big]
        else:
            prev, self.last = self.last, list(b)
            r = self.r_inf
            b = [min(prev[0], b[0]) - r, min(prev[1], b[1]) - r, max(prev[2], b[2]) + r, max(prev[3], b[3]) + r]

        def clamp(w, o, n):
            if w < o:
                return 0
            if w >= self.res * n + o:
                return n - 1
            return int((w - o) / self.res)

        x0, y0 = clamp(b[0], self.ox, self.size_x), clamp(b[1], self.oy, self.size_y)
        return x0, y0, clamp(b[2], self.ox, self.size_x) + 1, clamp(b[3], self.oy, self.size_y) + 1

    def _clear_footprint(self, poly):
        """Footprint clearing on the layer, only if every vertex is on the map."""
        cells = [self.world_to_map(x, y) for x, y in poly]
        if not all(cell is not None for cell in cells):
            return
        outline = []
        for k in range(len(cells)):
            outline += bresenham(*cells[k], *cells[(k + 1) % len(cells)])
        columns = {}
        for x, y in outline:
            lo, hi = columns.get(x, (y, y))
            columns[x] = (min(lo, y), max(hi, y))
        for x, (lo, hi) in columns.items():
            for y in range(lo, hi + 1):
                self.layer[y][x] = FREE
