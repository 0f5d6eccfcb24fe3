"""The office floor: a corridor loop around a block of rooms, with more rooms off its outer side, for SLAM.

A mapping run needs a loop long enough for odometry to drift before it closes (the corridor's centre
line, ``CORRIDOR_LOOP``, is about 100 m), and both loop closure and relocalization need places that do
not look alike: along the corridor there is a printer alcove (north), a water-cooler alcove (west), a
kitchen niche (south) and a lobby with two pillars and a reception desk (east), and no door faces
another. The plan is deliberately not symmetric, so no stretch of the map matches its mirror image.

Every door is at least 1.2 m clear and every corridor at least 1.68 m, so the lab's 0.9 x 0.6 m box
(circumscribed radius 0.54 m) can turn on the spot everywhere on its way to any goal; the rooms have
one door each, so the only way around the central block is the corridor. The shipped ``office.yaml``
is ``office_world()``; ``python -m simplebot_navigation.sim.world_gen`` rewrites it (a test checks it
matches).
"""

from __future__ import annotations

import math

from simplebot_navigation.sim.world import Box, Cylinder, Pose2D, Wall, World

#: the building's shell, as thick as the other generated worlds' outer walls
OUTER_THICKNESS = 0.2
#: partitions and corridor walls
INNER_THICKNESS = 0.12
#: the outer walls' centre lines: (xmin, ymin, xmax, ymax)
FLOOR = (-22.0, -16.0, 22.0, 16.0)
#: the corridor loop's centre line, counter-clockwise from its south-west corner
CORRIDOR_LOOP = ((-15.0, -10.0), (16.55, -10.0), (16.55, 9.05), (-15.0, 9.05))
#: the block of rooms the corridor runs around: its walls' centre lines (xmin, ymin, xmax, ymax)
CENTRAL_BLOCK = (-14.1, -9.0, 15.6, 8.1)
#: the closed stairs-and-lifts core inside the central block (no door): (xmin, ymin, xmax, ymax)
CORE = (-6.0, -3.5, 8.0, 2.0)

_EAST, _NORTH, _WEST, _SOUTH = 0.0, round(math.pi / 2, 4), round(math.pi, 4), round(-math.pi / 2, 4)

# Inner walls as (axis, at, start, end, openings, label): axis "h" runs along x at y = at, "v" along y at
# x = at; an opening is (its centre along the wall, clear width): a door, or the mouth of an alcove.
_INNER_WALLS = (
    # the corridor's outer side: doors to the outer rooms, the alcoves' mouths and the lobby
    ("h", 10.0, -22.0, 22.0, ((-12.0, 1.3), (-1.0, 1.2), (5.0, 2.0), (12.5, 1.2)), "corridor north"),
    ("v", -15.9, -11.0, 10.0, ((-6.5, 1.3), (1.0, 1.6), (4.5, 1.2)), "corridor west"),
    ("h", -11.0, -22.0, 22.0, ((-10.0, 1.2), (-2.0, 3.6), (4.5, 1.2), (12.0, 1.3)), "corridor south"),
    ("v", 17.5, -11.0, 10.0, ((-5.0, 1.2), (5.5, 6.0)), "corridor east"),
    # the corridor's inner side: the central block's doors
    ("h", 8.1, -14.1, 15.6, ((-9.0, 1.2), (2.0, 1.3), (11.0, 1.2)), "block north"),
    ("v", -14.1, -9.0, 8.1, ((-1.2, 1.2),), "block west"),
    ("h", -9.0, -14.1, 15.6, ((-8.0, 1.2), (7.0, 1.4)), "block south"),
    ("v", 15.6, -9.0, 8.1, ((-0.5, 1.2),), "block east"),
    # partitions between the outer rooms
    ("v", -7.0, 10.0, 16.0, (), "partition"),
    ("v", 8.0, 10.0, 16.0, (), "partition"),
    ("h", -1.0, -22.0, -15.9, (), "partition"),
    ("v", -6.5, -16.0, -11.0, (), "partition"),
    ("v", 9.0, -16.0, -11.0, (), "partition"),
    ("h", 2.5, 17.5, 22.0, (), "partition"),
    # the central block: a north row, a middle row around the core, a south row
    ("v", -5.0, 2.0, 8.1, (), "partition"),
    ("v", 6.0, 2.0, 8.1, (), "partition"),
    ("h", 2.0, -14.1, 15.6, (), "core north"),
    ("h", -3.5, -14.1, 15.6, (), "core south"),
    ("v", -6.0, -3.5, 2.0, (), "core west"),
    ("v", 8.0, -3.5, 2.0, (), "core east"),
    ("v", 1.5, -9.0, -3.5, (), "partition"),
    # the alcoves behind the corridor's openings
    ("v", 4.0, 10.0, 11.2, (), "printer alcove"),
    ("h", 11.2, 4.0, 6.0, (), "printer alcove"),
    ("v", 6.0, 10.0, 11.2, (), "printer alcove"),
    ("h", 0.2, -17.0, -15.9, (), "cooler alcove"),
    ("v", -17.0, 0.2, 1.8, (), "cooler alcove"),
    ("h", 1.8, -17.0, -15.9, (), "cooler alcove"),
    ("v", -3.8, -12.8, -11.0, (), "kitchen"),
    ("h", -12.8, -3.8, -0.2, (), "kitchen"),
    ("v", -0.2, -12.8, -11.0, (), "kitchen"),
)

_DESK, _CLUSTER = (1.6, 0.8), (2.4, 1.6)

_BOXES = (
    # corridor features
    Box((5.0, 10.75), (1.0, 0.6), 0.0, 1.1, "printer"),
    Box((-2.0, -12.43), (3.4, 0.6), 0.0, 0.9, "kitchen counter"),
    Box((21.2, 6.0), (0.8, 2.4), 0.0, 1.1, "reception desk"),
    # north rooms: open-plan office, meeting room, office with a column
    Box((-19.5, 15.4), _DESK, 0.0, 0.75, "desk"), Box((-17.0, 15.4), _DESK, 0.0, 0.75, "desk"),
    Box((-10.0, 15.4), _DESK, 0.0, 0.75, "desk"), Box((-21.5, 12.0), (0.6, 1.6), 0.0, 1.8, "cabinet"),
    Box((-2.5, 14.0), (3.6, 1.2), 0.0, 0.75, "meeting table"),
    Box((10.0, 15.4), _DESK, 0.0, 0.75, "desk"), Box((12.5, 15.4), _DESK, 0.0, 0.75, "desk"),
    Box((20.0, 13.5), (0.8, 1.6), 0.0, 0.75, "desk"),
    # west rooms: office, store
    Box((-21.4, 8.0), (0.8, 1.6), 0.0, 0.75, "desk"), Box((-21.4, 5.0), (0.8, 1.6), 0.0, 0.75, "desk"),
    Box((-19.0, 9.6), (2.4, 0.5), 0.0, 2.0, "bookshelf"),
    Box((-21.4, -9.0), (0.8, 2.4), 0.0, 1.8, "shelf"), Box((-20.0, -3.5), (1.6, 1.6), 0.4, 0.75, "table"),
    # south rooms: open-plan office, office, workshop
    Box((-20.0, -15.4), _DESK, 0.0, 0.75, "desk"), Box((-17.5, -15.4), _DESK, 0.0, 0.75, "desk"),
    Box((-13.0, -13.5), _CLUSTER, 0.0, 0.75, "desk cluster"),
    Box((2.0, -15.4), _DESK, 0.0, 0.75, "desk"), Box((6.5, -15.4), _DESK, 0.0, 0.75, "desk"),
    Box((-6.1, -14.0), (0.6, 1.6), 0.0, 1.8, "cabinet"),
    Box((13.0, -15.5), (3.0, 0.7), 0.0, 0.9, "bench"), Box((20.0, -13.5), (0.8, 2.0), 0.3, 1.8, "rack"),
    # east room: archive
    Box((21.5, -8.0), (0.6, 3.0), 0.0, 2.0, "shelf"), Box((21.5, 0.0), (0.6, 2.5), 0.0, 2.0, "shelf"),
    Box((19.5, 1.5), (1.4, 0.8), 0.0, 0.75, "table"),
    # central block
    Box((-11.5, 4.0), _CLUSTER, 0.0, 0.75, "desk cluster"), Box((-7.0, 3.0), _DESK, 0.0, 0.75, "desk"),
    Box((-1.5, 4.5), (3.0, 1.4), 0.0, 0.75, "conference table"),
    Box((7.5, 2.6), _DESK, 0.0, 0.75, "desk"), Box((15.1, 3.5), (0.6, 1.5), 0.0, 1.8, "cabinet"),
    Box((-6.8, -0.75), (0.8, 1.6), 0.0, 0.75, "desk"), Box((-10.5, -2.8), (2.0, 0.8), 0.0, 0.75, "table"),
    Box((8.7, -0.75), (0.8, 2.0), 0.0, 1.8, "server rack"), Box((11.5, -2.9), (2.0, 0.7), 0.0, 0.9, "bench"),
    Box((-11.5, -5.5), _CLUSTER, 0.0, 0.75, "desk cluster"), Box((-4.5, -5.5), _CLUSTER, 0.0, 0.75, "desk cluster"),
    Box((3.0, -4.0), _DESK, 0.0, 0.75, "desk"), Box((5.5, -4.0), _DESK, 0.0, 0.75, "desk"),
    Box((13.0, -4.0), (3.0, 0.8), 0.0, 0.9, "bench"),
)

_CYLINDERS = (
    # corridor features
    Cylinder((-16.55, 1.0), 0.18, 1.2, "water cooler"),
    Cylinder((-0.6, -11.7), 0.2, 0.7, "bin"),
    Cylinder((19.0, 4.2), 0.3, 1.0, "pillar"), Cylinder((19.0, 7.8), 0.3, 1.0, "pillar"),
    # rooms: columns, bins and plants
    Cylinder((-16.0, 12.5), 0.25, 1.0, "column"), Cylinder((-8.0, 15.5), 0.15, 0.5, "bin"),
    Cylinder((-6.3, 15.3), 0.25, 1.2, "plant"),
    Cylinder((16.5, 13.0), 0.3, 1.0, "column"), Cylinder((21.4, 10.6), 0.2, 0.5, "bin"),
    Cylinder((-21.5, 0.0), 0.15, 0.5, "bin"), Cylinder((-19.5, -7.5), 0.25, 1.0, "column"),
    Cylinder((-7.2, -15.5), 0.15, 0.5, "bin"), Cylinder((1.0, -13.2), 0.25, 1.0, "column"),
    Cylinder((16.0, -13.0), 0.3, 1.0, "column"), Cylinder((18.0, -10.5), 0.15, 0.5, "bin"),
    Cylinder((-13.6, 7.6), 0.15, 0.5, "bin"), Cylinder((5.4, 2.6), 0.25, 1.2, "plant"),
    Cylinder((13.5, 5.0), 0.3, 1.0, "column"), Cylinder((-13.6, 1.5), 0.15, 0.5, "bin"),
    Cylinder((12.0, 1.3), 0.25, 1.0, "column"), Cylinder((-1.0, -7.0), 0.25, 1.0, "column"),
    Cylinder((1.0, -4.0), 0.15, 0.5, "bin"), Cylinder((10.0, -6.5), 0.3, 1.0, "column"),
    Cylinder((15.0, -8.5), 0.15, 0.5, "bin"),
)

#: one goal per room, then the corridor's corners and features, facing along the loop (counter-clockwise)
_GOALS = (
    Pose2D(-13.0, 12.8, _NORTH, "room_a"), Pose2D(2.5, 13.0, _EAST, "room_b"),
    Pose2D(14.0, 12.5, _NORTH, "room_c"), Pose2D(-19.0, 4.5, _WEST, "room_d"),
    Pose2D(-18.6, -6.5, _WEST, "room_e"), Pose2D(-10.0, -13.5, _SOUTH, "room_f"),
    Pose2D(4.5, -13.5, _SOUTH, "room_g"), Pose2D(12.0, -13.3, _SOUTH, "room_h"),
    Pose2D(19.5, -5.0, _EAST, "room_i"), Pose2D(-9.0, 5.5, _SOUTH, "room_j"),
    Pose2D(2.5, 5.5, _SOUTH, "room_k"), Pose2D(10.5, 5.0, _SOUTH, "room_l"),
    Pose2D(-10.0, 0.0, _EAST, "room_m"), Pose2D(12.5, -0.7, _WEST, "room_n"),
    Pose2D(-8.0, -6.5, _NORTH, "room_o"), Pose2D(7.0, -6.5, _NORTH, "room_p"),
    Pose2D(-15.0, 9.05, _SOUTH, "corridor_nw"), Pose2D(16.55, 9.05, _WEST, "corridor_ne"),
    Pose2D(16.55, -10.0, _NORTH, "corridor_se"), Pose2D(-2.0, -10.3, _EAST, "kitchen"),
    Pose2D(19.8, 6.0, _NORTH, "lobby"),
)

#: in the south corridor, west of the kitchen, facing east along it
_START = Pose2D(-12.0, -10.0, _EAST)


def office_world() -> World:
    """The office floor: 44 x 32 m between its outer walls' centre lines, 16 rooms, a corridor loop of 101 m.

    Goals ``room_a`` ... ``room_p`` (one per room) and ``corridor_nw``, ``corridor_ne``, ``corridor_se``,
    ``kitchen``, ``lobby``; the start is in the south corridor, facing east along it.
    """
    xmin, ymin, xmax, ymax = FLOOR
    corners = [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]
    walls = [Wall(a, b, OUTER_THICKNESS, name="outer") for a, b in zip(corners, corners[1:] + corners[:1])]
    for axis, at, start, end, openings, label in _INNER_WALLS:
        walls += _wall_line(axis, at, start, end, openings, label)
    return World("office", tuple(walls), _BOXES, _CYLINDERS, _START, _GOALS, "<office_world>")


def _wall_line(axis: str, at: float, start: float, end: float, openings, label: str) -> list[Wall]:
    """The wall from start to end along one axis, cut at its openings (clear width between the cut ends)."""
    cuts = [start]
    for centre, width in sorted(openings):
        low, high = round(centre - width / 2, 4), round(centre + width / 2, 4)
        if not cuts[-1] < low < high < end:
            raise ValueError(f"office_world: opening at {centre} ({width} m) of {label} does not fit "
                             f"between {cuts[-1]} and {end}")
        cuts += [low, high]
    cuts.append(end)
    point = (lambda s: (s, at)) if axis == "h" else (lambda s: (at, s))
    return [Wall(point(a), point(b), INNER_THICKNESS, name=label) for a, b in zip(cuts[::2], cuts[1::2])]
