"""Compiled path extraction of the global planner: gradient descent and grid walk over the potentials
that expansion_kernels computed, on the same padded grid (see there for its layout and for why
numba). Compiled with ``cache=True``; the entry points release the GIL.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from simplebot_navigation.planning.expansion_kernels import POT_HIGH


@njit(cache=True)
def _append(buf, count, x, y):
    if count == buf.shape[0]:
        bigger = np.empty((2 * buf.shape[0], 2), np.float64)
        bigger[:count] = buf[:count]
        buf = bigger
    buf[count, 0] = x
    buf[count, 1] = y
    return buf, count + 1


@njit(cache=True, inline="always")
def _is_pad(n, width, height):
    x = n % width
    y = n // width
    return x == 0 or x == width - 1 or y == 0 or y == height - 1


@njit(cache=True)
def _grad_cell(pot, n, width, height):
    """GradientPath::gradCell: unit vector towards lower potential (0, 0 when undefined)."""
    if _is_pad(n, width, height):
        return 0.0, 0.0
    cv = pot[n]
    dx = 0.0
    dy = 0.0
    if cv >= POT_HIGH:
        # Inside an obstacle: head for any assigned neighbour.
        if pot[n - 1] < POT_HIGH:
            dx = -1.0
        elif pot[n + 1] < POT_HIGH:
            dx = 1.0
        if pot[n - width] < POT_HIGH:
            dy = -1.0
        elif pot[n + width] < POT_HIGH:
            dy = 1.0
    else:
        if pot[n - 1] < POT_HIGH:
            dx += pot[n - 1] - cv
        if pot[n + 1] < POT_HIGH:
            dx += cv - pot[n + 1]
        if pot[n - width] < POT_HIGH:
            dy += pot[n - width] - cv
        if pot[n + width] < POT_HIGH:
            dy += cv - pot[n + width]
    norm = math.hypot(dx, dy)
    if norm > 0.0:
        return dx / norm, dy / norm
    return 0.0, 0.0


@njit(cache=True, nogil=True)
def gradient_path(pot, width, start_x, start_y, goal_x, goal_y, max_steps):
    """GradientPath::getPath, from the goal down the potential to the start.

    Coordinates are lattice coordinates of the unpadded grid (integer = cell centre).
    Returns (points, n, status): status 0 = reached the start, 1 = left the map,
    2 = ran into unassigned potential, 3 = stuck in a local minimum, 4 = step limit.
    """
    height = pot.size // width
    buf = np.empty((64, 2), np.float64)
    count = 0
    stc = (int(goal_y) + 1) * width + int(goal_x) + 1
    dx = goal_x - int(goal_x)
    dy = goal_y - int(goal_y)
    step = 0
    while step < max_steps:
        step += 1
        px = stc % width - 1 + dx
        py = stc // width - 1 + dy
        if abs(px - start_x) < 0.5 and abs(py - start_y) < 0.5:
            buf, count = _append(buf, count, start_x, start_y)
            return buf, count, 0
        if _is_pad(stc, width, height):
            return buf, count, 1
        buf, count = _append(buf, count, px, py)
        oscillating = (count > 2 and buf[count - 1, 0] == buf[count - 3, 0]
                       and buf[count - 1, 1] == buf[count - 3, 1])
        up = stc - width
        down = stc + width
        grid_step = (oscillating or pot[stc] >= POT_HIGH or pot[stc - 1] >= POT_HIGH
                     or pot[stc + 1] >= POT_HIGH or pot[up] >= POT_HIGH
                     or pot[up - 1] >= POT_HIGH or pot[up + 1] >= POT_HIGH
                     or pot[down] >= POT_HIGH or pot[down - 1] >= POT_HIGH
                     or pot[down + 1] >= POT_HIGH)
        if not grid_step:
            g00x, g00y = _grad_cell(pot, stc, width, height)
            g10x, g10y = _grad_cell(pot, stc + 1, width, height)
            g01x, g01y = _grad_cell(pot, down, width, height)
            g11x, g11y = _grad_cell(pot, down + 1, width, height)
            x = (1.0 - dy) * ((1.0 - dx) * g00x + dx * g10x) + dy * ((1.0 - dx) * g01x + dx * g11x)
            y = (1.0 - dy) * ((1.0 - dx) * g00y + dx * g10y) + dy * ((1.0 - dx) * g01y + dx * g11y)
            # ROS 1 gives up on a zero gradient (a saddle of the potential); a grid step
            # gets past it.
            grid_step = x == 0.0 and y == 0.0
            if not grid_step:
                ss = 0.5 / math.hypot(x, y)
                dx += x * ss
                dy += y * ss
                if dx > 1.0:
                    stc += 1
                    dx -= 1.0
                if dx < -1.0:
                    stc -= 1
                    dx += 1.0
                if dy > 1.0:
                    stc += width
                    dy -= 1.0
                if dy < -1.0:
                    stc -= width
                    dy += 1.0
        if grid_step:
            # Near the edge of the assigned potential, oscillating or on a saddle: step to the
            # lowest of the 8 neighbours. ROS truncates the reference potential to an int.
            best = stc
            best_pot = math.floor(pot[stc]) if pot[stc] < POT_HIGH else POT_HIGH
            for m in (up - 1, up, up + 1, stc - 1, stc + 1, down - 1, down, down + 1):
                if pot[m] < best_pot:
                    best_pot = pot[m]
                    best = m
            if pot[best] >= POT_HIGH:
                return buf, count, 2
            if best == stc and dx == 0.0 and dy == 0.0:
                return buf, count, 3  # a local minimum: ROS 1 would spin to the step limit
            stc = best
            dx = 0.0
            dy = 0.0
    return buf, count, 4


@njit(cache=True, nogil=True)
def grid_path(pot, width, start_x, start_y, goal_x, goal_y, max_steps):
    """GridPath::getPath: steepest descent over the 8 neighbours, from the goal to the start.

    Ends on the first lattice node less than one cell from the start in x and y, i.e. on one
    of the nodes a precise start seeds (ROS 1 waits for one particular node, which the descent
    can miss and then oscillates until the step limit). Same return convention as
    gradient_path.
    """
    buf = np.empty((64, 2), np.float64)
    buf, count = _append(buf, 0, goal_x, goal_y)
    cx = int(goal_x)
    cy = int(goal_y)
    for _ in range(max_steps):
        if abs(cx - start_x) < 1.0 and abs(cy - start_y) < 1.0:
            return buf, count, 0
        best = np.float32(1e10)
        bx = -1
        by = -1
        for xd in (-1, 0, 1):
            for yd in (-1, 0, 1):
                if xd == 0 and yd == 0:
                    continue
                x = cx + xd
                y = cy + yd
                p = pot[(y + 1) * width + x + 1]
                if p < best:
                    best = p
                    bx = x
                    by = y
        if bx < 0:
            return buf, count, 2
        cx = bx
        cy = by
        buf, count = _append(buf, count, float(cx), float(cy))
    return buf, count, 4
