"""Scripted drives that feed the obstacle tracker from the simulator's lidars (bench/tracking_truth.py).

A crowd or people world is driven in a straight line from its start towards its goal, steering around nothing,
and the tracker is scored against the moving obstacles' ground truth (testing/tracking_truth.py). A static world
(the lab's tour, a forest) is driven along a route planned on its map, and every moving track is counted: all of
them are false. Both lidars go into the tracker one scan per update, as move_base feeds it, 10 times a second.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from simplebot_description import robot_description
from simplebot_navigation.perception import ObstacleTracker
from simplebot_navigation.sim import SimplebotSim
from simplebot_navigation.sim.diff_drive import drive_for
from simplebot_navigation.sim.world import World
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.testing.scripted_drive import PathFollower, planned_route
from simplebot_navigation.testing.tracking_truth import CrowdScore, FalseMotion, in_sight, outline_radius, \
    scans_in_world

SCAN_PERIOD_S = 0.1
RANGE_NOISE_M = 0.01
#: the crowd benchmark's robot, and the lab's
ROUND_BODY = ("round", 0.25)
LAB_BODY = ("box", 0.3)
#: the lab's TEB max_vel_x; the forests are driven at the BARN challenge's top speed
LAB_SPEED = 0.4
FOREST_SPEED = 2.0
#: the routes' cost scaling (1/m), as tried with the follower: the box drives the lab tour without a contact
#: with 8 (with 4 it touches a door frame), the round robot forests 0-19 at 2 m/s with 4 (with 8, forest:2 a tree)
LAB_COST_SCALING = 8.0
FOREST_COST_SCALING = 4.0
#: the follower's turn rate where the drive sets no limit of its own (rad/s)
TURN_RATE = 2.0
#: time allowed over the route's length at speed, for turns and slowing down
SLACK_S = 20.0


@dataclass
class Run:
    world: str
    score: CrowdScore | FalseMotion
    seconds: float = 0.0                 # simulated time measured
    contact_at: float | None = None      # the first contact's sim time
    reached: bool = False                # the route's end
    update_ms: list[float] = field(default_factory=list)      # tracker time per scan pair


def _drive(world: World, body: tuple, route: list[np.ndarray], speed: float, seconds: float, run: Run,
           on_scan: Callable, stop_at_contact: bool) -> Run:
    """Follow the route until its end, `seconds` or (if asked) the first contact; on_scan(sim, scans, tracker)
    after every scan pair the tracker has taken."""
    description = robot_description(*body)
    drive = drive_for(description, speed)
    follower = PathFollower(route, speed, max_turn_rate=drive.max_yaw_rate or TURN_RATE)
    tracker = ObstacleTracker()
    with SimplebotSim(world, description, range_noise_std=RANGE_NOISE_M, drive=drive) as sim:
        while sim.sim_time < seconds - 1e-9 and not follower.done:
            truth = sim.ground_truth()
            sim.set_cmd_vel(*follower.command(truth.x, truth.y, truth.yaw))
            sim.step_until(sim.sim_time + SCAN_PERIOD_S)
            scans = scans_in_world(sim, description)
            began = time.perf_counter()
            for scan in scans:
                tracker.update([scan], sim.sim_time)
            run.update_ms.append(1e3 * (time.perf_counter() - began))
            if run.contact_at is None and sim.collisions().count:
                run.contact_at = sim.sim_time
                if stop_at_contact:
                    break
            on_scan(sim, scans, tracker)
            run.seconds = sim.sim_time
        run.reached = follower.done
    return run


def crowd_run(name: str, speed: float, seconds: float | None = None, stop_at_contact: bool = True) -> Run:
    """World `name` (crowd:N, people:N) driven from its start straight towards its first goal at `speed`, the
    tracker scored against the ground truth, until the goal, `seconds` or (stop_at_contact) the first contact."""
    world = load_world(name, robot_radius=ROUND_BODY[1])
    if not world.moving or not world.goals:
        raise ValueError(f"{name}: a world with moving obstacles and a goal is needed")
    goal = world.goals[0]
    route = [np.array([[world.start.x, world.start.y], [goal.x, goal.y]])]
    score = CrowdScore()

    def on_scan(sim, scans, tracker):
        truth = sim.ground_truth()
        states = sim.moving_obstacle_states()
        centres = np.array([[s.x, s.y] for s in states])
        seen = in_sight(scans, centres, np.array([outline_radius(s.extent) for s in states]))
        score.add(sim.sim_time, (truth.x, truth.y), ROUND_BODY[1], states, seen, tracker.tracks())

    budget = seconds or _route_length(route) / speed + SLACK_S
    run = _drive(world, ROUND_BODY, route, speed, budget, Run(name, score), on_scan, stop_at_contact)
    score.finish()
    return run


def static_run(name: str, body: tuple, speed: float, cost_scaling: float, seconds: float | None = None) -> Run:
    """World `name`, without moving obstacles, driven along a route planned through all its goals in order at
    `speed` (planned_route's cost_scaling); every moving track counts as false."""
    inscribed = robot_description(*body).inscribed_radius
    world = load_world(name, robot_radius=inscribed)
    if world.moving:
        raise ValueError(f"{name} has moving obstacles: every moving track must be false here")
    route = planned_route(world, list(world.goals), inscribed, cost_scaling)
    motion = FalseMotion()
    budget = seconds or _route_length(route) / speed + SLACK_S
    return _drive(world, body, route, speed, budget, Run(name, motion),
                  lambda sim, scans, tracker: motion.add(SCAN_PERIOD_S, tracker.tracks()), stop_at_contact=False)


def _route_length(legs: list[np.ndarray]) -> float:
    return sum(float(np.hypot(*np.diff(leg, axis=0).T).sum()) for leg in legs)
