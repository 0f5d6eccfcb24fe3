"""Global relocalization by the scan matcher (localization/relocalization.py): global localization and recovery seed
the particles round the matcher's candidates over the whole map, on two rooms that look alike but for one thing."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from simplebot_navigation.geometry import compose2, inverse2
from simplebot_navigation.localization import Amcl, AmclParams, RangeScan
from simplebot_navigation.slam.scan_matcher import CorrelationGrid, ScanMatcher
from simplebot_navigation.sim.world import World, world_from_dict
from simplebot_navigation.testing.amcl_scenes import Scanner, occupancy_grid

#: two 6 m x 5 m rooms joined by a door, each the other turned half a turn about (6, 2.5), furniture and all; only
#: the east room has a pillar
TWIN_ROOMS = {
    "name": "twin_rooms",
    "walls": [{"from": a, "to": b, "thickness": 0.15} for a, b in (
        ([0, 0], [12, 0]), ([12, 0], [12, 5]), ([12, 5], [0, 5]), ([0, 5], [0, 0]), ([6, 0], [6, 2]),
        ([6, 3], [6, 5]))],
    "boxes": [{"center": [1.5, 1.0], "size": [1.2, 0.6]}, {"center": [4.0, 4.2], "size": [0.8, 0.8]},
              {"center": [10.5, 4.0], "size": [1.2, 0.6]}, {"center": [8.0, 0.8], "size": [0.8, 0.8]}],
    "cylinders": [{"center": [9.0, 2.2], "radius": 0.25}],
    "start": {"x": 3.0, "y": 2.5, "yaw": 0.0},
}
#: in the east room, the pillar in view; its look-alike in the west room is the same pose turned about (6, 2.5)
TRUTH = (10.3, 2.0, 2.8)
LOOK_ALIKE = (12.0 - TRUTH[0], 5.0 - TRUTH[1], TRUTH[2] - math.pi)
#: the lab's laser model (config/map/amcl.yaml) with fewer particles
PARAMS = dict(max_particles=5000, min_particles=500, laser_model_type="likelihood_field_prob", laser_max_beams=60,
              laser_z_hit=0.9, laser_z_rand=0.1, laser_sigma_hit=0.4, update_min_d=0.1, update_min_a=0.1)


@functools.cache
def twin_rooms() -> World:
    return world_from_dict(TWIN_ROOMS, source="twin_rooms")


def make_amcl(map_origin=None, **overrides) -> Amcl:
    data, resolution, origin = occupancy_grid(twin_rooms())
    return Amcl(AmclParams(**{**PARAMS, **overrides}), data, resolution, map_origin or origin)


def near(pose, target, metres=0.2, degrees=5.0) -> bool:
    return (math.hypot(pose[0] - target[0], pose[1] - target[1]) < metres
            and abs(math.degrees(math.remainder(pose[2] - target[2], 2 * math.pi))) < degrees)


def turned(pose, angle: float) -> tuple[float, float, float]:
    return pose[0], pose[1], pose[2] + angle


class Spot:
    """A robot turning on the spot at 0.6 rad/s (its odometry 1 % fast), both lidars' scans every 0.1 s as two
    sources. ``frame``: the map's global frame in the world's (a rotated map); ``timed``: stamps given."""

    def __init__(self, pose, seed: int, timed: bool = True, frame=(0.0, 0.0, 0.0)):
        self.truth, self.odom, self.t = np.array(pose, dtype=float), np.zeros(3), 0.0
        self.rng, self.scanner = np.random.default_rng(seed), Scanner(twin_rooms())
        self.timed, self.frame = timed, frame

    def turn(self, amcl: Amcl, steps: int) -> list[bool]:
        """Whether the estimate was within 0.2 m and 5 deg of the truth after each step."""
        out = []
        for _ in range(steps):
            self.truth[2] += 0.06
            self.odom[2] += 0.0606
            self.t += 0.1
            amcl.odometry_update(self.odom)
            front, back = self.scanner.scans(self.truth, self.rng)
            amcl.sensor_update([front], "front", stamp=self.t if self.timed else None)
            amcl.sensor_update([back], "back", stamp=self.t + 0.05 if self.timed else None)
            e = amcl.estimate()
            out.append(near(compose2(self.frame, (e.x, e.y, e.yaw)), self.truth))
        return out


def counting(monkeypatch, calls: list) -> None:
    """Count the whole-map searches (and still run them)."""
    original = ScanMatcher.global_candidates
    monkeypatch.setattr(ScanMatcher, "global_candidates",
                        lambda self, *args, **kwargs: calls.append(1) or original(self, *args, **kwargs))


def test_one_scan_seeds_the_candidates_and_the_filter_settles_on_the_true_room_not_its_look_alike():
    amcl = make_amcl()
    amcl.global_localization()
    found = Spot(TRUTH, 1).turn(amcl, 10)
    poses, responses = amcl.relocalizer.candidates               # of the first scan, after a 0.06 rad turn
    assert near(poses[0], turned(TRUTH, 0.06), 0.1, 3.0)
    assert any(near(p, turned(LOOK_ALIKE, 0.06), 0.3, 5.0) for p in poses[1:3])
    assert responses[0] - responses[1] < 0.1, "the two rooms should look alike to the matcher"
    assert all(found[2:]), found


def test_the_seeded_particles_are_clusters_round_the_candidates_plus_a_uniform_share():
    amcl = make_amcl(global_localization_uniform_share=0.2)
    amcl.relocalizer.observe("", Scanner(twin_rooms()).scans(TRUTH, np.random.default_rng(2)), (0.0, 0.0, 0.0))
    assert amcl.relocalizer.match((0.0, 0.0, 0.0), 0.0, amcl.params)
    poses, responses = amcl.relocalizer.candidates
    particles = amcl.relocalizer.poses(10000, amcl.params, (0.0, 0.0, 0.0), np.random.default_rng(3),
                                       amcl.filter.random_poses)
    assert particles.shape == (10000, 3) and (np.abs(particles[:, 2]) <= math.pi).all()
    distance = np.hypot(particles[:, None, 0] - poses[None, :, 0], particles[:, None, 1] - poses[None, :, 1])
    assert 0.8 <= np.mean(distance.min(axis=1) < 0.5) < 0.85    # the uniform 20 % lands near a candidate now and then
    at_truth = np.mean(distance[:, 0] < 0.5)
    assert at_truth == pytest.approx(0.8 * responses[0] / responses.sum(), abs=0.02)


def test_without_a_scan_global_localization_is_uniform_and_the_next_scans_seed_it():
    amcl = make_amcl()
    amcl.global_localization()
    particles = amcl.particles
    data, resolution, origin = occupancy_grid(twin_rooms())
    cols = np.floor((particles[:, 0] - origin[0]) / resolution).astype(int)
    rows = np.floor((particles[:, 1] - origin[1]) / resolution).astype(int)
    assert len(particles) == 5000 and (data[rows, cols] == 0).all()
    assert particles[:, 0].std() > 3.0 and particles[:, 2].std() > 1.5
    assert amcl.relocalizer.candidates[1].size == 0
    found = Spot(TRUTH, 4).turn(amcl, 6)
    assert amcl.relocalizer.candidates[1].size > 0 and all(found[2:]), found


def test_with_no_candidates_asked_for_global_localization_stays_uniform_and_never_matches(monkeypatch):
    calls: list = []
    counting(monkeypatch, calls)
    amcl = make_amcl(global_localization_candidates=0)
    amcl.global_localization()
    Spot(TRUTH, 5).turn(amcl, 3)
    assert calls == [] and amcl.relocalizer.candidates[1].size == 0


def test_scans_of_nan_inf_or_nothing_leave_the_particles_uniform_until_a_usable_one_comes():
    amcl = make_amcl()
    amcl.global_localization()
    amcl.odometry_update((0.0, 0.0, 0.0))
    n = 683
    hostile = [RangeScan(np.full(n, np.nan), -2.0, 0.006, 0.2, 5.6),
               RangeScan(np.full(n, np.inf), -2.0, 0.006, 0.2, 5.6),
               RangeScan(np.full(n, -np.inf), -2.0, 0.006, 0.2, 5.6),
               RangeScan(np.zeros(0), -2.0, 0.006, 0.2, 5.6),
               RangeScan(np.full(n, 3.0), -2.0, 0.006, 0.2, 5.6, (1e12, -1e12, 0.0))]     # returns far off
    for scan in hostile:
        amcl.sensor_update([scan], "front", stamp=0.0)
        assert amcl.relocalizer.pending and amcl.relocalizer.candidates[1].size == 0
        assert len(amcl.particles) == 5000 and amcl.particles[:, 0].std() > 3.0
    with pytest.raises(ValueError, match="stamp: must be finite"):
        amcl.sensor_update([hostile[0]], "front", stamp=math.nan)
    front, back = Scanner(twin_rooms()).scans(TRUTH, np.random.default_rng(6))
    half_nan = np.where(np.arange(len(front.ranges)) % 2 == 0, np.nan, front.ranges).astype(np.float32)
    front = RangeScan(half_nan, front.angle_min, front.angle_increment, front.range_min, front.range_max,
                      front.sensor_pose)
    amcl.sensor_update([front, back], "front", stamp=0.1)
    assert not amcl.relocalizer.pending and near(amcl.relocalizer.candidates[0][0], TRUTH, 0.1, 3.0)


def test_a_pose_given_while_the_seeding_waits_wins():
    amcl = make_amcl()
    amcl.global_localization()
    amcl.set_initial_pose(*TRUTH, np.diag([0.01, 0.01, 0.01]))
    assert all(Spot(TRUTH, 7).turn(amcl, 3))
    assert amcl.relocalizer.candidates[1].size == 0


def test_recovery_injects_candidates_matched_at_most_once_per_interval_and_finds_a_carried_robot(monkeypatch):
    calls: list = []
    counting(monkeypatch, calls)
    amcl = make_amcl(recovery_match_interval=2.0)
    west = (3.0, 2.5, 0.0)
    amcl.set_initial_pose(*west, np.diag([0.01, 0.01, 0.01]))
    spot = Spot(west, 8)
    assert all(spot.turn(amcl, 20)[5:])
    spot.truth[:] = TRUTH                                   # carried to the east room, nobody told
    found = spot.turn(amcl, 100)
    assert len(calls) <= 1 + 12.0 / 2.0
    assert True in found[:60] and all(found[found.index(True) + 10:]), found     # amcl's uniform: not in 100


def test_without_stamps_recovery_injects_uniform_particles_as_amcl(monkeypatch):
    calls: list = []
    counting(monkeypatch, calls)
    amcl = make_amcl()
    west = (3.0, 2.5, 0.0)
    amcl.set_initial_pose(*west, np.diag([0.01, 0.01, 0.01]))
    spot = Spot(west, 9, timed=False)
    spot.turn(amcl, 10)
    spot.truth[:] = TRUTH
    spot.turn(amcl, 30)
    assert calls == []


def test_the_field_is_built_once_per_map_and_a_new_map_builds_its_own(monkeypatch):
    built = []
    original = CorrelationGrid.from_occupancy.__func__
    monkeypatch.setattr(CorrelationGrid, "from_occupancy",
                        classmethod(lambda cls, *args, **kwargs: built.append(1) or original(cls, *args, **kwargs)))
    amcl, spot = make_amcl(), Spot(TRUTH, 10)
    for _ in range(2):
        amcl.global_localization()
        spot.turn(amcl, 1)
    assert len(built) == 1
    data, resolution, origin = occupancy_grid(twin_rooms())
    amcl, _ = amcl.on_new_map(data, resolution, origin)
    amcl.global_localization()
    spot.turn(amcl, 1)
    assert len(built) == 2


def test_a_rotated_map_relocalizes_in_its_own_frame():
    data, resolution, origin = occupancy_grid(twin_rooms())
    frame = (1.0, -2.0, 0.7)                      # the map's global frame in the world's
    amcl = make_amcl(map_origin=compose2(inverse2(frame), origin))
    amcl.global_localization()
    assert all(Spot(TRUTH, 11, frame=frame).turn(amcl, 5)[2:])
