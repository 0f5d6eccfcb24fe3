"""The round body's Jackal drive in SimplebotSim: its top speed, yaw rate and acceleration limits, turning at
speed, and the stopping distance from full speed when an obstacle appears ahead (what the drive can do for a
perfect controller: zero velocity commanded the moment the obstacle is there)."""

import numpy as np
import pytest

from simplebot_description import robot_description
from simplebot_navigation.sim import MovingObstacle, SimplebotSim, World
from simplebot_navigation.sim.diff_drive import (
    JACKAL_ACCEL, JACKAL_MAX_SPEED, JACKAL_MAX_YAW_RATE, JACKAL_YAW_ACCEL, drive_for)

ROUND = robot_description("round", 0.25)
JACKAL = drive_for(ROUND, 2.0)
#: the obstacle that appears: a box this deep along the path and wide across it, at this sim time
DEPTH, WIDTH = 0.2, 2.0
APPEAR = 2.0
#: the physics step (SimplebotSim's default 100 Hz)
DT = 0.01


@pytest.fixture
def make_sim():
    sims = []

    def make(world, **kwargs):
        sims.append(SimplebotSim(world, ROUND, drive=JACKAL, **kwargs))
        return sims[-1]

    yield make
    for sim in sims:
        sim.close()


def drive(sim, v, w, until, rate=20.0):
    """Send (v, w) at `rate` Hz, as a controller would, until sim time `until`."""
    while sim.sim_time < until - 1e-9:
        sim.set_cmd_vel(v, w)
        sim.step_until(min(until, sim.sim_time + 1.0 / rate))


def step_series(sim, v, w, steps, field):
    """One command per physics step; the ground truth's `field` after each."""
    values = []
    for _ in range(steps):
        sim.set_cmd_vel(v, w)
        sim.step()
        values.append(getattr(sim.ground_truth(), field))
    return np.array(values)


def test_the_jackal_drive_reaches_2_m_s_at_its_acceleration_limit(make_sim):
    sim = make_sim(World("empty"))
    speeds = step_series(sim, 3.0, 0.0, 150, "vx")
    accel = np.diff(speeds) / sim.dt
    assert speeds.max() == pytest.approx(JACKAL_MAX_SPEED, abs=0.005)
    assert JACKAL_ACCEL * 0.98 <= accel.max() <= JACKAL_ACCEL * 1.02
    # From rest to the top speed in v / a, not sooner.
    assert np.argmax(speeds > JACKAL_MAX_SPEED - 0.01) * sim.dt == pytest.approx(JACKAL_MAX_SPEED / JACKAL_ACCEL,
                                                                                 abs=0.02)
    assert sim.odometry().vx == pytest.approx(JACKAL_MAX_SPEED, abs=0.005)


def test_the_jackal_drive_turns_on_the_spot_at_4_rad_s(make_sim):
    sim = make_sim(World("empty"))
    rates = step_series(sim, 0.0, 6.0, 150, "wz")
    alpha = np.diff(rates) / sim.dt
    assert rates.max() == pytest.approx(JACKAL_MAX_YAW_RATE, abs=0.01)
    assert alpha.max() <= JACKAL_YAW_ACCEL * 1.02
    assert sim.odometry().wz == pytest.approx(JACKAL_MAX_YAW_RATE, abs=0.01)
    gt = sim.ground_truth()
    assert np.hypot(gt.x, gt.y) < 0.01


def test_turning_at_speed_keeps_the_curvature_and_the_grip(make_sim):
    sim = make_sim(World("empty"))
    drive(sim, 2.0, 4.0, until=3.0)
    odom, gt = sim.odometry(), sim.ground_truth()
    # The outer wheel at the top speed, along the commanded curvature of 2 rad/m.
    assert odom.wz / odom.vx == pytest.approx(2.0, abs=0.01)
    assert odom.vx + odom.wz * ROUND.wheel_separation / 2 == pytest.approx(JACKAL_MAX_SPEED, abs=0.01)
    # A centripetal 4.3 m/s^2 on wheels of friction 1: the tyres slip a little sideways, as real ones do.
    assert abs(gt.vy) < 0.1
    assert np.hypot(gt.x - odom.x, gt.y - odom.y) < 0.03


def front_at_appearance(speed: float) -> float:
    """x of the body's front at APPEAR, driven at `speed` from rest at the origin: v t - v^2 / (2 a), plus half a
    step's travel (the ramp acts at the start of each step), plus the radius."""
    return speed * APPEAR - speed ** 2 / (2 * JACKAL_ACCEL) + speed * DT / 2 + ROUND.radius


def appearing_box(x: float) -> World:
    """A world with a box whose near face is at x from APPEAR on; before, it stands 20 m aside (parked, unseen)."""
    centre = x + DEPTH / 2
    box = MovingObstacle("box", ((0.0, centre, 20.0), (APPEAR - DT, centre, 20.0), (APPEAR, centre, 0.0)),
                         size=(DEPTH, WIDTH))
    return World("appearing box", moving=(box,))


@pytest.mark.parametrize("speed, gap", [(2.0, 2.0), (2.0, 3.0), (1.5, 2.0), (1.0, 2.0)])
def test_the_drive_stops_short_of_an_obstacle_appearing_ahead(make_sim, speed, gap):
    front = front_at_appearance(speed)
    sim = make_sim(appearing_box(front + gap))
    drive(sim, speed, 0.0, until=APPEAR)
    start, odom_start = sim.ground_truth(), sim.odometry()
    assert start.vx == pytest.approx(speed, abs=0.005)
    measured_gap = front + gap - (start.x + ROUND.radius)
    assert measured_gap == pytest.approx(gap, abs=0.002)
    assert sim.collisions().count == 0

    sim.set_cmd_vel(0.0, 0.0)
    sim.step_until(APPEAR + 2.0)
    end = sim.ground_truth()
    stopping = end.x - start.x
    minimum = speed ** 2 / (2 * JACKAL_ACCEL)
    assert abs(end.vx) < 1e-3
    assert sim.collisions().count == 0 and not sim.collisions().in_contact
    assert stopping < measured_gap
    # The physical minimum v^2 / (2 a) (less half a step's travel: the ramp acts at the start of a step), and
    # nothing lost to skidding: the wheels, and so the odometry, tell the same distance.
    assert minimum - speed * DT <= stopping <= 1.1 * minimum
    assert sim.odometry().x - odom_start.x == pytest.approx(stopping, abs=0.002)


def test_the_obstacle_appears_at_once_and_is_hit_without_braking(make_sim):
    speed, gap = 2.0, 2.0
    sim = make_sim(appearing_box(front_at_appearance(speed) + gap))
    drive(sim, speed, 0.0, until=APPEAR)
    scans = [s for s in sim.due_scans() if s.frame == "front_laser_link"]
    laser_x = ROUND.laser_poses["front_laser_link"][0]
    centre = len(scans[-1].ranges) // 2
    assert scans[-2].stamp == pytest.approx(APPEAR - 0.1) and np.isinf(scans[-2].ranges[centre])
    assert scans[-1].stamp == pytest.approx(APPEAR)
    assert scans[-1].ranges[centre] == pytest.approx(gap + ROUND.radius - laser_x, abs=0.03)
    drive(sim, speed, 0.0, until=APPEAR + gap / speed + 0.1)
    report = sim.collisions()
    assert report.count >= 1 and report.last_obstacle == "moving[0]"   # at 2 m/s it bounces off and comes back
