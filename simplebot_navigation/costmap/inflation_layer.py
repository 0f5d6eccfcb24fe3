"""InflationLayer: graded cost around lethal cells (docs/reference.md §2.6).

The propagation is costmap_2d's brushfire, not an exact distance transform: cells are visited in
increasing distance bins, each carrying the lethal cell it was reached from, and a cell keeps the
cost of the first visit. Some cells therefore end up with a slightly larger distance than the true
nearest obstacle; reproducing the brushfire exactly (compiled with numba) keeps every cost identical
to ROS 1, which a distance transform would not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from simplebot_navigation.parameters import ParameterError, param
from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.layer import Bounds, Layer
from simplebot_navigation.costmap.plugins import LayerContext, LayerSpec


def inflation_cost(distance_cells: float, resolution: float, inscribed_radius: float, weight: float) -> int:
    """Cost of a cell `distance_cells` cells from the nearest lethal cell (truncated, as costmap_2d)."""
    if distance_cells == 0:
        return LETHAL_OBSTACLE
    if distance_cells * resolution <= inscribed_radius:
        return INSCRIBED_INFLATED_OBSTACLE
    factor = math.exp(-1.0 * weight * (distance_cells * resolution - inscribed_radius))
    return int((INSCRIBED_INFLATED_OBSTACLE - 1) * factor)


@numba.njit(cache=True, nogil=True)
def _brushfire(master, x0, y0, xn, yn, cell_radius, bin_of, cost_of, n_bins, inflate_unknown, capacity):
    """Inflate `master` in place from the lethal cells of [x0, xn) x [y0, yn).

    bin_of[|dx|, |dy|] is the rank of hypot(dx, dy) among the distinct distances (-1 beyond the
    inflation radius); each bin is a FIFO linked list, processed in rank order. Entries appended to
    an already processed bin are never visited, which mirrors iterating a std::map while inserting.
    Returns the number of queue entries used, or -1 if `capacity` entries were not enough; the
    caller then runs it again with more room, which is safe because a partial run only wrote the
    costs a full run writes first.
    """
    size_y, size_x = master.shape
    seen = np.zeros(size_y * size_x, dtype=np.bool_)
    cell = np.empty(capacity, dtype=np.int64)
    src = np.empty(capacity, dtype=np.int64)
    nxt = np.full(capacity, -1, dtype=np.int64)
    head = np.full(n_bins, -1, dtype=np.int64)
    tail = np.full(n_bins, -1, dtype=np.int64)
    flat = master.reshape(-1)
    count = 0
    for j in range(y0, yn):
        for i in range(x0, xn):
            index = j * size_x + i
            if flat[index] == LETHAL_OBSTACLE:
                cell[count] = index
                src[count] = index
                if tail[0] < 0:
                    head[0] = count
                else:
                    nxt[tail[0]] = count
                tail[0] = count
                count += 1
    for b in range(n_bins):
        e = head[b]
        while e >= 0:
            index = cell[e]
            if not seen[index]:
                seen[index] = True
                mx = index % size_x
                my = index // size_x
                s = src[e]
                sx = s % size_x
                sy = s // size_x
                cost = cost_of[abs(mx - sx), abs(my - sy)]
                old = flat[index]
                if old == NO_INFORMATION and ((inflate_unknown and cost > 0) or
                                              (not inflate_unknown and cost >= INSCRIBED_INFLATED_OBSTACLE)):
                    flat[index] = cost
                elif cost > old:
                    flat[index] = cost
                for k in range(4):
                    if k == 0:
                        if mx == 0:
                            continue
                        nx, ny = mx - 1, my
                    elif k == 1:
                        if my == 0:
                            continue
                        nx, ny = mx, my - 1
                    elif k == 2:
                        if mx == size_x - 1:
                            continue
                        nx, ny = mx + 1, my
                    else:
                        if my == size_y - 1:
                            continue
                        nx, ny = mx, my + 1
                    n_index = ny * size_x + nx
                    if seen[n_index]:
                        continue
                    nb = bin_of[abs(nx - sx), abs(ny - sy)]
                    if nb < 0:
                        continue
                    if count == capacity:
                        return -1
                    cell[count] = n_index
                    src[count] = s
                    if tail[nb] < 0:
                        head[nb] = count
                    else:
                        nxt[tail[nb]] = count
                    tail[nb] = count
                    count += 1
            e = nxt[e]
    return count


@dataclass
class InflationLayerParams:
    inflation_radius: float = param(0.55, "m", "distance up to which obstacle cost is inflated", ge=0)
    cost_scaling_factor: float = param(10.0, "1/m", "how fast the inflated cost decays", ge=0)
    inflate_unknown: bool = param(False, "", "inflate around unknown cells too")
    enabled: bool = param(True, "", "the layer takes part in updates")


class InflationLayer(Layer):
    """Writes inflated costs into the master grid around every lethal cell of the update window."""

    def __init__(self, name: str, inflation_radius: float = 0.55, cost_scaling_factor: float = 10.0,
                 inflate_unknown: bool = False, enabled: bool = True):
        super().__init__(name)
        self.inflation_radius = float(inflation_radius)
        self.cost_scaling_factor = float(cost_scaling_factor)
        self.inflate_unknown = bool(inflate_unknown)
        self.enabled = bool(enabled)
        self.inscribed_radius = 0.0
        self.resolution = 0.0
        self.cell_inflation_radius = 0
        self.need_reinflation = False
        big = float(np.finfo(np.float32).max)
        self._last = Bounds(-big, -big, big, big)
        self._tables = None

    def on_initialize(self) -> None:
        self.match_size()

    def match_size(self) -> None:
        self.resolution = self.layered_costmap.costmap.resolution
        self._compute_caches()

    def on_footprint_changed(self) -> None:
        self.inscribed_radius = self.layered_costmap.inscribed_radius
        self._compute_caches()
        self.need_reinflation = True

    def set_inflation_parameters(self, inflation_radius: float, cost_scaling_factor: float) -> None:
        if inflation_radius != self.inflation_radius or cost_scaling_factor != self.cost_scaling_factor:
            self.inflation_radius = float(inflation_radius)
            self.cost_scaling_factor = float(cost_scaling_factor)
            self.need_reinflation = True
            self._compute_caches()

    def reconfigure(self, inflation_radius: float, cost_scaling_factor: float, inflate_unknown: bool,
                    enabled: bool) -> None:
        """A run-time change, as the layer's dynamic_reconfigure: the next update reinflates the whole map."""
        self.set_inflation_parameters(inflation_radius, cost_scaling_factor)
        self.set_enabled(enabled, inflate_unknown)

    def set_enabled(self, enabled: bool, inflate_unknown: bool | None = None) -> None:
        """Toggling either flag reinflates the whole map on the next cycle."""
        inflate_unknown = self.inflate_unknown if inflate_unknown is None else bool(inflate_unknown)
        if enabled != self.enabled or inflate_unknown != self.inflate_unknown:
            self.enabled, self.inflate_unknown = bool(enabled), inflate_unknown
            self.need_reinflation = True

    def _compute_caches(self) -> None:
        if self.resolution <= 0:
            return
        cr = max(0, int(math.ceil(self.inflation_radius / self.resolution)))
        self.cell_inflation_radius = cr
        if cr == 0:
            self._tables = None
            return
        idx = np.arange(cr + 2)
        dist = np.hypot(idx[:, None], idx[None, :])
        cost = np.array([[inflation_cost(d, self.resolution, self.inscribed_radius, self.cost_scaling_factor)
                          for d in row] for row in dist], dtype=np.uint8)
        within = dist <= cr
        distinct, rank = np.unique(dist[within], return_inverse=True)
        bin_of = np.full(dist.shape, -1, dtype=np.int64)
        bin_of[within] = rank
        self._tables = (bin_of, cost, len(distinct))

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float, bounds: Bounds) -> None:
        """Grow by the inflation radius over this and the previous cycle's bounds, so that the
        halo of an obstacle that vanished is recomputed; after a change, cover the whole map."""
        if self.need_reinflation:
            self._last = Bounds(*bounds.as_tuple())
            big = float(np.finfo(np.float32).max)
            bounds.min_x = bounds.min_y = -big
            bounds.max_x = bounds.max_y = big
            self.need_reinflation = False
            return
        previous, self._last = self._last, Bounds(*bounds.as_tuple())
        r = self.inflation_radius
        bounds.min_x = min(previous.min_x, bounds.min_x) - r
        bounds.min_y = min(previous.min_y, bounds.min_y) - r
        bounds.max_x = max(previous.max_x, bounds.max_x) + r
        bounds.max_y = max(previous.max_y, bounds.max_y) + r

    def update_costs(self, master, x0: int, y0: int, xn: int, yn: int) -> None:
        if self._tables is None:
            return
        cr = self.cell_inflation_radius
        x0, y0 = max(0, x0 - cr), max(0, y0 - cr)
        xn, yn = min(master.size_x, xn + cr), min(master.size_y, yn + cr)
        bin_of, cost, n_bins = self._tables
        # Queued cells lie within the radius of a seed: start with two entries per such cell.
        reach = (min(xn + cr, master.size_x) - max(x0 - cr, 0)) * (min(yn + cr, master.size_y) - max(y0 - cr, 0))
        capacity = (xn - x0) * (yn - y0) + 2 * reach + 1024
        while _brushfire(master.costmap, x0, y0, xn, yn, cr, bin_of, cost, n_bins, self.inflate_unknown,
                         capacity) < 0:
            capacity *= 2

    def reset(self) -> None:
        """costmap_2d re-initialises the layer, which drops a pending full reinflation."""
        self.need_reinflation = False
        self.match_size()


@dataclass(frozen=True)
class InflationLayerSpec(LayerSpec):
    def resolve(self, tree: dict, path: str, context: LayerContext) -> tuple[dict, list[str]]:
        """Inflation reaches at most across the whole map: a larger radius only costs memory and time (its kernel
        grows with the square of it), which can stall the costmap's thread for seconds."""
        params, warnings = super().resolve(tree, path, context)
        radius, cfg = params["inflation_radius"], context.costmap
        diagonal = math.hypot(cfg.width, cfg.height)
        if radius > diagonal:
            raise ParameterError(f"{path}/inflation_radius: {radius:g} m is more than the costmap's diagonal "
                                 f"({diagonal:.3g} m for {cfg.width:g} x {cfg.height:g} m)")
        return params, warnings


SPEC = InflationLayerSpec.builtin(InflationLayer, InflationLayerParams, ("cost_scaling_factor", "inflation_radius"))
