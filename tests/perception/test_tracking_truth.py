"""bench/tracking_truth.py kept working: its sight test and scoring on scenes whose answer is known, and the bench
itself on a small scale (a hard crowd world for a few seconds, the start of the lab tour). Only what holds for any
sane tracker is asserted, not the bench's targets."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from simplebot_navigation.sim import MovingObstacleState
from simplebot_navigation.testing.lidar_scenes import Cylinder, scans_at
from simplebot_navigation.testing.tracking_truth import CrowdScore, FalseMotion, in_sight

BENCH = "tracking_truth"    # the conftest's bench fixture loads bench/tracking_truth.py


def test_in_sight_means_a_lidar_beam_ends_on_the_obstacle():
    people = [Cylinder(0.3, (2.0, 0.0)),      # ahead
              Cylinder(0.3, (4.0, 0.0)),      # behind the first
              Cylinder(0.3, (0.0, 3.0)),      # behind a wall
              Cylinder(0.3, (0.0, -7.0)),     # beyond the lidars' range
              Cylinder(0.3, (-2.0, 0.5))]     # behind the robot: the back lidar's
    scans = scans_at((0.0, 0.0, 0.0), 0.0, people, [(-3.0, 2.0, 3.0, 2.0)])
    centres = np.array([c.start for c in people])
    assert in_sight(scans, centres, np.full(len(people), 0.3)).tolist() == [True, False, False, False, True]


def _track(position, moving, velocity=(1.0, 0.0)):
    return SimpleNamespace(id=0, position=np.array(position), velocity=np.array(velocity), moving=moving)


def test_a_sighting_is_judged_when_a_moving_track_comes_and_lost_when_none_came():
    score = CrowdScore()
    person = MovingObstacleState("walker", "cylinder", 2.0, 0.0, 1.0, 0.0, 0.5)
    for step in range(1, 31):
        t = round(0.1 * step, 1)
        seen = t <= 0.9 or 2.1 <= t <= 2.3           # seen, hidden for 1.2 s, seen briefly, gone
        tracks = [] if t < 0.4 or t > 1.0 else [_track((2.1, 0.0), moving=t >= 0.6, velocity=(0.8, 0.0))]
        score.add(t, (0.0, 0.0), 0.25, [person], np.array([seen]), tracks)
    score.finish()
    summary = score.summary()
    assert score.latencies == [pytest.approx(0.5)]
    assert summary["lost_share"] == 0.5 and summary["sightings"] == 2
    # 1.25 m between the outlines: in the band at every scan in sight
    assert score.band == {"moving": 4, "static": 2, "none": 6}
    assert summary["velocity_error_m_s"][0] == pytest.approx(0.2)
    assert summary["position_error_m"][0] == pytest.approx(0.1)


def test_false_motion_counts_each_track_reported_moving_and_how_long():
    motion = FalseMotion()
    for step in range(8):
        motion.add(0.1, [SimpleNamespace(id=1, moving=True), SimpleNamespace(id=2, moving=step < 3),
                         SimpleNamespace(id=3, moving=False)])
    assert motion.summary() == {"moving_tracks": 2, "lasting": 1, "total_s": pytest.approx(1.1)}


def test_the_bench_finds_moving_tracks_on_a_hard_crowd_and_drives_the_lab(bench, capsys):
    results = bench.main(["--worlds", "crowd:2", "--lab", "--seconds", "6"])
    out = capsys.readouterr().out
    assert "crowd:2" in out and "lab" in out and "load average" in out
    (crowd,), total = results["crowd"]
    summary = total.summary()
    assert crowd.seconds > 3.0 and len(crowd.update_ms) >= 30
    assert summary["band_samples"] >= 20
    assert summary["band_share"]["moving"] >= 0.5, summary
    assert summary["matched_samples"] >= 50
    for key in ("latency_s", "velocity_error_m_s", "position_error_m"):
        assert all(math.isfinite(x) for x in summary[key]), summary
    assert summary["position_error_m"][1] <= 0.6 and 0.0 <= summary["lost_share"] <= 1.0
    (lab,), _ = results["static"]
    assert lab.seconds == pytest.approx(6.0) and lab.contact_at is None and not lab.reached
    assert all(math.isfinite(t) and t > 0 for t in lab.update_ms)


@pytest.mark.parametrize("spec", ["crowd:hard", "crowd:0-3", "people:2"])
def test_world_specs_name_the_worlds(bench, spec):
    names = bench.world_names(spec)
    assert {"crowd:hard": len(names) == 10 and all(int(n[6:]) % 3 == 2 for n in names),
            "crowd:0-3": names == ["crowd:0", "crowd:1", "crowd:2", "crowd:3"],
            "people:2": names == ["people:2"]}[spec]


@pytest.mark.parametrize("spec", ["forest:1", "people:hard", "crowd:5-2", "crowd:x"])
def test_a_bad_world_spec_is_refused_naming_it(bench, spec):
    with pytest.raises(ValueError, match=spec):
        bench.world_names(spec)
