"""The space-time search (planning/space_time.py) against answers known in closed form: the free run, a corridor
closed until a known time (one safe interval after it), one closed for good, and a dead end an obstacle sweeps
into, where no robot escapes; and the paths it traces back through them."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from simplebot_navigation.planning.space_time import _DISC, _OFFSETS, MovingDiscs, SpaceTimeSearch
from simplebot_navigation.planning.space_time_kernels import grown_within

RES = 0.05
ROBOT = 0.25


def corridor(length: float = 6.0, half_width: float = 0.3) -> SpaceTimeSearch:
    """A corridor along x from -0.5 to length, the robot's centre free within half_width of y = 0."""
    rows, cols = int(2.0 / RES), int((length + 0.5) / RES)
    y = -1.0 + (np.arange(rows) + 0.5) * RES
    free = np.repeat((np.abs(y) <= half_width)[:, None], cols, axis=1)
    return SpaceTimeSearch(free, (-0.5, -1.0), RES)


def disc_at(x: float, y: float, radius: float, until: float = np.inf, vx: float = 0.0, since: float = 0.0):
    """One obstacle (radius plus the robot's) at (x + vx (t - since), y) while since <= t < until, far away else."""
    def discs(t: float) -> MovingDiscs:
        here = since <= t < until
        cx = x + vx * (t - since) if here else 1e6
        return MovingDiscs(np.array([[cx, y]]), np.array([radius + ROBOT]), np.array([abs(vx)]))
    return discs


def nothing(t: float) -> MovingDiscs:
    return MovingDiscs(np.zeros((0, 2)), np.zeros(0), np.zeros(0))


def test_with_nothing_in_the_way_the_arrival_is_the_straight_line_at_top_speed():
    search = corridor()
    arrival = search.earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, 1.0, nothing, 0.0, 30.0)
    assert arrival.solvable and 4.9 - 1e-9 <= arrival.arrival_s <= 4.9 + search.step_s(1.0)
    faster = search.earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, 2.0, nothing, 10.0, 30.0)
    assert 12.45 - 1e-9 <= faster.arrival_s <= 12.45 + search.step_s(2.0)      # from t0 = 10 s


def test_a_corridor_closed_until_four_seconds_is_passed_in_its_safe_interval_after():
    """The robot waits before the obstacle (2.5 - 0.5 - 0.25 - half a step of travel = 1.7 m at best) until it goes
    at t = 4 s, then drives the remaining 3.2 m: 7.2 s, to within a step of travel."""
    search = corridor()
    arrival = search.earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, 1.0, disc_at(2.5, 0.0, 0.5, until=4.0), 0.0, 30.0)
    assert arrival.solvable and 7.2 - 1e-9 <= arrival.arrival_s <= 7.2 + 2 * search.step_s(1.0), arrival


def test_a_corridor_closed_for_good_is_unsolvable_but_the_robot_survives_before_it():
    arrival = corridor().earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, 1.0, disc_at(2.5, 0.0, 0.5), 0.0, 20.0)
    assert not arrival.solvable and arrival.reachable_cells > 0


def test_an_obstacle_sweeping_into_a_dead_end_catches_the_robot_wherever_it_goes():
    """The corridor ends at x = -0.5 behind the robot; a disc filling it comes from x = 3 at 1 m/s."""
    arrival = corridor().earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, 1.0,
                                          disc_at(3.0, 0.0, 0.5, vx=-1.0), 0.0, 20.0)
    assert not arrival.solvable and arrival.reachable_cells == 0 and arrival.steps < 40


def test_a_crossing_obstacle_delays_the_robot_or_not_never_speeds_it_up():
    search = corridor(half_width=0.8)
    free_run = search.earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, 1.0, nothing, 0.0, 30.0).arrival_s
    for since in np.arange(0.0, 5.0, 0.5):
        def discs(t: float, since=since) -> MovingDiscs:
            y = -1.5 + 1.0 * (t - since)
            return MovingDiscs(np.array([[2.5, y]]), np.array([0.3 + ROBOT]), np.array([1.0]))
        arrival = search.earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, 1.0, discs, 0.0, 30.0)
        assert arrival.solvable and free_run - 1e-9 <= arrival.arrival_s <= free_run + 3.0, since


@pytest.mark.parametrize("speed", [0.0, -1.0])
def test_a_speed_that_is_not_positive_is_refused(speed):
    with pytest.raises(ValueError, match="speed"):
        corridor().earliest_arrival((0.0, 0.0), (5.0, 0.0), 0.1, speed, nothing, 0.0, 10.0)


def way_to(x: float):
    return lambda xy: np.abs(xy[:, 0] - x)


def assert_drivable(search: SpaceTimeSearch, path, speed: float, discs) -> None:
    """Every step of the path is within a step's travel, and every point is clear of the obstacle at its time."""
    steps = np.hypot(*np.diff(path.xy, axis=0).T)
    assert steps.max() <= speed * search.step_s(speed) + RES, steps.max()
    for t, (x, y) in zip(path.times[1:], path.xy[1:]):
        d = discs(t)
        assert (np.hypot(*(d.centres - (x, y)).T) > d.radii).all(), (t, x, y)


def test_with_nothing_in_the_way_the_path_drives_straight_to_the_goal_and_stays():
    search = corridor()
    path = search.path((0.0, 0.0), way_to(5.0), 1.0, nothing, 0.0, 8.0)
    assert path.full and path.times[0] == 0.0 and path.times[-1] == pytest.approx(8.0, abs=search.step_s(1.0))
    assert_drivable(search, path, 1.0, nothing)
    there = np.flatnonzero(np.abs(path.xy[:, 0] - 5.0) <= RES)
    assert len(there) and path.times[there[0]] <= 4.9 + 2 * search.step_s(1.0)        # as early as it can
    assert (np.abs(path.xy[there[0]:, 0] - 5.0) <= RES).all()                          # then it waits there


def test_a_corridor_closed_until_four_seconds_waits_before_the_obstacle_and_goes_in_time():
    """The path goes up to the obstacle at once, waits there while it stands, and passes it once it is gone, to
    arrive as early as the earliest arrival says."""
    search, discs = corridor(), disc_at(2.5, 0.0, 0.5, until=4.0)
    path = search.path((0.0, 0.0), way_to(5.0), 1.0, discs, 0.0, 10.0)
    assert path.full
    assert_drivable(search, path, 1.0, discs)
    assert path.at(2.0)[0] == pytest.approx(1.7, abs=0.1)          # waiting before the obstacle by t = 2 s
    assert path.at(3.9)[0] < 2.5 - 0.75 + RES
    there = np.flatnonzero(np.abs(path.xy[:, 0] - 5.0) <= RES)
    assert path.times[there[0]] <= 7.2 + 2 * search.step_s(1.0)


def test_a_path_through_an_oncoming_obstacle_steps_aside_and_lets_it_pass():
    """A corridor 1.5 m wide and an obstacle coming down its middle: the path takes a side and holds it."""
    search = corridor(half_width=0.75)
    discs = disc_at(6.0, 0.0, 0.25, vx=-1.0)
    path = search.path((0.0, 0.0), way_to(5.0), 1.0, discs, 0.0, 8.0)
    assert path.full
    assert_drivable(search, path, 1.0, discs)
    meeting = path.times[np.argmin(np.abs(path.xy[:, 0] - (6.0 - path.times)))]
    assert np.abs(path.at(meeting)[1]) >= 0.5, meeting                 # beside the obstacle as it passes
    assert path.xy[-1, 0] == pytest.approx(5.0, abs=RES)               # and past it, at the goal


def test_a_robot_caught_in_a_dead_end_gets_a_path_only_until_it_is_caught():
    search, discs = corridor(), disc_at(3.0, 0.0, 0.5, vx=-1.0)
    path = search.path((0.0, 0.0), way_to(5.0), 1.0, discs, 0.0, 10.0)
    assert path is not None and not path.full and path.times[-1] < 3.0


@pytest.mark.parametrize("seed", range(4))
def test_the_compiled_growth_is_a_dilation_by_a_step_masked_by_the_free_cells(seed):
    """grown_within against scipy's binary dilation by the step's disc, on sets touching the grid's edges."""
    rng = np.random.default_rng(seed)
    reach = rng.random((40, 60)) < 0.02
    reach[0, 5] = reach[39, 59] = True
    allowed = rng.random((40, 60)) < 0.8
    want = ndimage.binary_dilation(reach, structure=_DISC) & allowed
    np.testing.assert_array_equal(grown_within(reach, allowed, _OFFSETS), want)
    assert not grown_within(np.zeros_like(reach), allowed, _OFFSETS).any()
