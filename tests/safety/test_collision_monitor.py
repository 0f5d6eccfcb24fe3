"""The collision monitor's judgement on commands against lidar points, for the box and the round body."""

import math

import numpy as np
import pytest

from simplebot_navigation.parameters.spec import ParameterError
from simplebot_navigation.safety import collision_kernels
from simplebot_navigation.safety.collision_monitor import (MAX_TRACK_RADIUS, MIN_TRACK_SPEED, PARAMETERS, Action,
                                                           CollisionMonitor, CollisionMonitorConfig, moved_by,
                                                           track_velocities)

BOX = [[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]


def wall(x: float, half_width: float = 1.0, spacing: float = 0.01) -> np.ndarray:
    """Points of a wall across the path at x (robot frame)."""
    y = np.arange(-half_width, half_width + 1e-9, spacing)
    return np.stack([np.full_like(y, x), y], axis=1)


#: zones and horizon these tests are written for (not the defaults, which may be tuned)
ZONES = {"stop_distance": 0.05, "slowdown_distance": 0.3, "slowdown_ratio": 0.5, "time_before_collision": 1.0}


@pytest.fixture(params=["box", "round"])
def monitor(request) -> CollisionMonitor:
    body = {"footprint": BOX} if request.param == "box" else {"robot_radius": 0.3}
    return CollisionMonitor(CollisionMonitorConfig(**body, **ZONES))


def front(monitor: CollisionMonitor) -> float:
    return 0.3 if monitor.radius > 0 else 0.45


def test_free_space_passes_the_command_unchanged(monitor):
    verdict = monitor.limit(1.0, 0.3, wall(front(monitor) + 3.0))
    assert (verdict.v, verdict.w, verdict.action) == (1.0, 0.3, Action.PASS)


def test_a_wall_within_the_stop_distance_ahead_stops_a_forward_command(monitor):
    verdict = monitor.limit(0.5, 0.2, wall(front(monitor) + 0.03))
    assert verdict.v == 0.0 and verdict.action is Action.STOP
    assert "ahead" in verdict.why
    # what is left is turning on the spot: free for the round body; the box's corners swing into the wall
    assert verdict.w == 0.2 if monitor.radius > 0 else 0.0 < verdict.w < 0.2


def test_the_same_wall_lets_the_robot_back_off_and_turn_in_place(monitor):
    points = wall(front(monitor) + 0.03)
    assert monitor.limit(-0.3, 0.0, points).action is Action.PASS
    turn = monitor.limit(0.0, 0.8, points)
    assert turn.w == 0.8 if monitor.radius > 0 else turn.w < 0.8   # the box's corners swing into the wall


def test_a_wall_behind_stops_reversing_only(monitor):
    points = -wall(front(monitor) + 0.03)
    assert monitor.limit(-0.3, 0.0, points).action is Action.STOP
    assert monitor.limit(0.3, 0.0, points).action is Action.PASS


def test_the_slowdown_zone_scales_the_command(monitor):
    verdict = monitor.limit(0.2, 0.1, wall(front(monitor) + 0.2))
    assert verdict.action is Action.SLOWDOWN
    assert verdict.v == pytest.approx(0.1) and verdict.w == pytest.approx(0.05)


def test_approach_scales_the_command_by_the_time_to_contact(monitor):
    verdict = monitor.limit(1.0, 0.0, wall(front(monitor) + 0.6))   # contact after 0.6 s at 1 m/s
    assert verdict.action is Action.APPROACH
    assert verdict.v == pytest.approx(0.55, abs=0.051)             # the last free pose of 0.05 s steps


def test_approach_follows_the_arc_not_the_straight_line(monitor):
    """A post straight ahead at 0.8 m is missed by a hard left arc; one on that arc is not."""
    post = np.array([[front(monitor) + 0.8, 0.0]] * 3)
    assert monitor.limit(0.5, 1.5, post).action is Action.PASS
    on_arc = moved_by(np.array([[front(monitor) + 0.05, 0.0]] * 3), -0.5, -1.5, 0.5)  # where the arc goes
    assert monitor.limit(0.5, 1.5, on_arc).action in (Action.APPROACH, Action.STOP, Action.SLOWDOWN)


def test_a_door_post_beside_the_body_does_not_stop_driving_through(monitor):
    """A door 1.15 x the body's width: posts 4.5 cm beside the body, the robot driving straight through."""
    half = 0.3 * 1.15
    posts = np.array([[x, s * half] for x in np.linspace(-0.5, 0.5, 21) for s in (-1, 1)])
    verdict = monitor.limit(0.4, 0.0, posts)
    assert (verdict.v, verdict.action) == (0.4, Action.PASS)


def test_fewer_than_min_points_do_not_act(monitor):
    speck = np.array([[front(monitor) + 0.02, 0.0]] * 2)
    assert monitor.limit(0.5, 0.0, speck).action is Action.PASS


def person(monitor: CollisionMonitor, gap: float, radius: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """(the lidar returns of a person ``gap`` ahead of the face, their track (1, 5) standing), robot frame."""
    centre = front(monitor) + gap + radius
    angles = np.linspace(math.pi * 0.6, math.pi * 1.4, 40)
    points = np.column_stack([centre + radius * np.cos(angles), radius * np.sin(angles)])
    return points, np.array([[centre, 0.0, radius, 0.0, 0.0]])


def walking(track: np.ndarray, vx: float, vy: float = 0.0) -> np.ndarray:
    out = track.copy()
    out[:, 3:5] = vx, vy
    return out


def test_a_person_walking_away_does_not_stop_the_robot_that_follows(monitor):
    """Issue 40: the monitor judged a person's returns as standing, and stopped the robot that followed one
    a centre-metre behind; the person moves on faster than the robot follows."""
    points, track = person(monitor, 0.015)
    assert monitor.limit(0.5, 0.0, points).action is Action.STOP
    verdict = monitor.limit(0.5, 0.0, points, track_velocities(points, walking(track, 1.0)))
    assert (verdict.v, verdict.action) == (0.5, Action.PASS)
    catching_up = monitor.limit(1.0, 0.0, points, track_velocities(points, walking(track, 0.3)))
    assert catching_up.action is not Action.PASS and catching_up.v < 1.0   # faster than the person: judged


def test_a_person_walking_into_the_robot_stops_the_command_towards_them_not_the_one_away(monitor):
    """Standing, the robot is reached in 0.3 s: driving towards the person is stopped short, backing away (the
    contact comes later, if at all) passes whole."""
    points, track = person(monitor, 0.3)
    velocities = track_velocities(points, walking(track, -1.0))
    towards = monitor.limit(0.8, 0.0, points, velocities)
    assert towards.action is not Action.PASS and towards.v < 0.4
    away = monitor.limit(-0.3, 0.0, points, velocities)
    assert (away.v, away.action) == (-0.3, Action.PASS)
    assert monitor.limit(-0.3, 0.0, points).action is Action.PASS          # the same when they stand


def test_a_post_beside_a_person_walking_away_still_stops_the_robot(monitor):
    points, track = person(monitor, 0.015)
    corner = (0.46, 0.29) if monitor.radius == 0 else 0.31 * np.array([1.0, 1.0]) / math.sqrt(2)
    post = np.array([corner] * 3)                    # a centimetre off the front-left, outside the person's circle
    everything = np.concatenate([points, post])
    assert not track_velocities(post, walking(track, 1.0)).any()
    verdict = monitor.limit(0.5, 0.0, everything, track_velocities(everything, walking(track, 1.0)))
    assert verdict.action is Action.STOP


def test_returns_move_with_the_track_whose_circle_holds_them():
    points = np.array([[1.3, 0.0], [1.0, 0.2], [3.0, 0.0], [0.0, 1.0]])
    tracks = np.array([[1.0, 0.0, 0.25, 1.0, 0.5],                      # holds the first two (margin 0.1 m)
                       [0.0, 1.0, MAX_TRACK_RADIUS + 0.5, 1.0, 0.0],     # too wide: a wall, not a person
                       [3.0, 0.0, 0.25, MIN_TRACK_SPEED / 2, 0.0]])      # too slow: standing
    assert track_velocities(points, tracks).tolist() == [[1.0, 0.5], [1.0, 0.5], [0.0, 0.0], [0.0, 0.0]]
    assert track_velocities(points, np.empty((0, 5))).tolist() == [[0.0, 0.0]] * 4


@pytest.mark.parametrize("radius", [0.3, 0.0])
def test_a_moving_point_enters_the_standing_body_when_it_reaches_it(radius):
    """The kernel's moving points against the closed form: 3 points 0.5 m from a circle (or the box), coming at
    1 m/s, enter at 0.5 s; with moving_until 0.5 s they are not counted."""
    vertices = np.array(BOX, dtype=float) if radius == 0.0 else np.empty((0, 2))
    face = 0.45 if radius == 0.0 else 0.3
    points = np.array([[face + 0.5, -0.01], [face + 0.5, 0.0], [face + 0.5, 0.01]])
    velocities = np.tile([-1.0, 0.0], (3, 1))
    k = collision_kernels.first_contact_step(points, velocities, math.inf, 0.0, 0.0, 0.01, 100, vertices, radius,
                                             0.6, 3)
    assert k * 0.01 == pytest.approx(0.51, abs=0.011)
    assert collision_kernels.first_contact_step(points, velocities, 0.5, 0.0, 0.0, 0.01, 100, vertices, radius,
                                                0.6, 3) == -1


def test_disabled_passes_everything():
    off = CollisionMonitor(CollisionMonitorConfig(footprint=BOX, enabled=False, **ZONES))
    assert off.limit(1.0, 0.0, wall(0.46)).action is Action.PASS


def test_scan_points_are_in_the_robot_frame_and_drop_invalid_returns(monitor):
    ranges = [1.0, math.nan, math.inf, -1.0, 6.0, 2.0]
    ahead = np.array([[1.0, 0.0, 0.5], [0.0, 1.0, 0.0]])       # a laser 0.5 m ahead of the base
    points = monitor.scan_points(ranges, -math.pi / 2, math.pi / 2, 0.2, 5.6, ahead)
    # beams at -90, 0, 90, ... degrees: kept are beam 0 (1 m) and beam 5 (2 m, a full turn on from 0)
    assert points == pytest.approx(np.array([[0.5, -1.0], [2.5, 0.0]]), abs=1e-9)
    upside_down = np.array([[1.0, 0.0, 0.5], [0.0, -1.0, 0.0]])  # rolled by pi: the scan plane is mirrored
    assert monitor.scan_points(ranges, -math.pi / 2, math.pi / 2, 0.2, 5.6, upside_down)[0] == pytest.approx([0.5, 1.0])
    with pytest.raises(ValueError, match="angle_increment"):
        monitor.scan_points(ranges, 0.0, math.nan, 0.2, 5.6, ahead)


def test_returns_below_range_min_are_points_the_robot_is_about_to_hit(monitor):
    """The lidar sits inside the body: a wall 5 cm ahead of the face is nearer to it than range_min. A return
    below range_min stays where it is; -inf ("too close") is put just outside the body along its beam."""
    laser = np.array([[1.0, 0.0, front(monitor) - 0.1], [0.0, 1.0, 0.0]])     # 10 cm inside the face
    points = monitor.scan_points([0.15, -math.inf], 0.0, 0.0, 0.2, 5.6, laser)
    assert points == pytest.approx(np.array([[front(monitor) + 0.05, 0.0], [front(monitor) + 0.005, 0.0]]))
    assert monitor.limit(0.3, 0.0, np.repeat(points[1:], 3, axis=0)).action is Action.STOP
    outside = np.array([[1.0, 0.0, front(monitor) + 0.1], [0.0, 1.0, 0.0]])   # a laser ahead of the body
    assert monitor.scan_points([-math.inf], 0.0, 0.0, 0.2, 5.6, outside) == pytest.approx(
        np.array([[front(monitor) + 0.105, 0.0]]))


@pytest.mark.parametrize("given, message", [
    ({}, "footprint or as robot_radius"),
    ({"footprint": [[0, 0], [1, 1]]}, "at least three points"),
    ({"robot_radius": 0.3, "stop_distance": 0.5, "slowdown_distance": 0.2}, "slowdown_distance"),
    ({"robot_radius": 0.3, "time_before_collision": 10.0, "simulation_time_step": 0.01}, "200 steps"),
])
def test_bad_configurations_are_refused_with_the_reason(given, message):
    with pytest.raises((ParameterError, ValueError), match=message):
        CollisionMonitorConfig(**given)


@pytest.mark.parametrize("given, message", [
    ({"min_points": 1000}, "min_points"),
    ({"time_before_collision": 0.0}, "time_before_collision"),
    ({"time_before_collision": 0.4, "max_linear_speed": 2.0}, "stopping from 2 m/s at 2.5 m/s"),
    ({"stop_distance": 0.0, "slowdown_distance": 0.0}, "stop_distance"),
    ({"simulation_time_step": 0.25, "time_before_collision": 1.0}, "past thin obstacles"),
    ({"source_timeout": 10.0}, "source_timeout"),
    ({"max_linear_accel": 0.01}, "max_linear_accel"),
])
def test_parameters_that_would_let_the_robot_hit_a_wall_are_refused(given, message):
    with pytest.raises(ParameterError, match=message):
        CollisionMonitorConfig(robot_radius=0.3, **{name: PARAMETERS[name].check(value, name)
                                                    for name, value in given.items()})


def test_the_stopping_time_follows_the_simulated_drive():
    from simplebot_navigation.sim.diff_drive import JACKAL_ACCEL, JACKAL_MAX_SPEED, DiffDriveParams

    lab = DiffDriveParams()
    assert (lab.max_wheel_speed * 0.07, lab.max_wheel_accel * 0.07) == pytest.approx((1.05, 1.75))
    assert CollisionMonitorConfig(robot_radius=0.3).stopping_time() == pytest.approx(1.05 / (2 * 1.75))
    jackal = CollisionMonitorConfig(robot_radius=0.3, max_linear_speed=JACKAL_MAX_SPEED)
    assert jackal.linear_accel() == JACKAL_ACCEL


def test_a_body_holds_another_only_when_it_covers_all_of_it():
    box = CollisionMonitor(CollisionMonitorConfig(footprint=BOX))
    two_cm = CollisionMonitor(CollisionMonitorConfig(footprint=[[0.01, 0.01], [0.01, -0.01], [-0.01, -0.01],
                                                                [-0.01, 0.01]]))
    longer = CollisionMonitor(CollisionMonitorConfig(footprint=[[0.6, 0.3], [0.6, -0.3], [-0.45, -0.3],
                                                                [-0.45, 0.3]]))
    notched = CollisionMonitor(CollisionMonitorConfig(footprint=[[0.45, 0.3], [0.45, 0.01], [0.3, 0.0],
                                                                 [0.45, -0.01], [0.45, -0.3], [-0.45, -0.3],
                                                                 [-0.45, 0.3]]))
    circle = CollisionMonitor(CollisionMonitorConfig(robot_radius=0.3))
    around = CollisionMonitor(CollisionMonitorConfig(robot_radius=0.55))
    assert box.holds(box) and longer.holds(box) and around.holds(box) and box.holds(circle)
    assert not two_cm.holds(box) and not notched.holds(box) and not circle.holds(box) and not box.holds(longer)
