"""costmap_2d cost values and the OccupancyGrid translation table (docs/reference.md §2.1)."""

import numpy as np

FREE_SPACE = 0
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255


def _translation_table() -> np.ndarray:
    table = np.empty(256, dtype=np.int8)
    table[0] = 0
    cost = np.arange(1, 253)
    table[1:253] = 1 + (97 * (cost - 1)) // 251
    table[INSCRIBED_INFLATED_OBSTACLE] = 99
    table[LETHAL_OBSTACLE] = 100
    table[NO_INFORMATION] = -1
    return table


#: costmap cost (uint8) -> nav_msgs/OccupancyGrid value (int8); index with a uint8 array.
OCCUPANCY_GRID_TABLE = _translation_table()
