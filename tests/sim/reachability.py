"""Which goals a disc-shaped robot can reach in a world, on a 5 cm grid."""

import numpy as np
from scipy import ndimage

RESOLUTION = 0.05


def reachable_goals(world, robot_radius):
    """Names (or indices) of the goals connected to the start for a disc of robot_radius."""
    x0, y0, x1, y1 = world.bounds()
    xs = np.arange(x0, x1, RESOLUTION) + RESOLUTION / 2
    ys = np.arange(y0, y1, RESOLUTION) + RESOLUTION / 2
    gx, gy = np.meshgrid(xs, ys)
    free = world.distance(np.column_stack((gx.ravel(), gy.ravel()))).reshape(gx.shape) > robot_radius
    labels, _ = ndimage.label(free)

    def label_at(pose):
        return labels[int((pose.y - y0) / RESOLUTION), int((pose.x - x0) / RESOLUTION)]

    start = label_at(world.start)
    assert start, "start is not free for this radius"
    return [g.name or i for i, g in enumerate(world.goals) if label_at(g) == start]
