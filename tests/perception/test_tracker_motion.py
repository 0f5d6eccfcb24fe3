"""The tracker's start-up and motion models on synthetic scans: first sight, two-frame velocity, turning and
stopping people, cut outlines, occlusion, static things seen from a fast robot, what a map knows to be static."""

from dataclasses import dataclass

import numpy as np
import pytest

from simplebot_navigation.perception import ObstacleTracker, StaticCells, TrackerParams
from simplebot_navigation.testing.lidar_scenes import Cylinder, scans_at, truth_at

PERIOD = 0.1


@dataclass(frozen=True)
class StoppingPerson:
    """Walks at `velocity` from `start` until `stop_at`, then stands."""
    radius: float
    start: tuple[float, float]
    velocity: tuple[float, float]
    stop_at: float

    def state(self, t):
        moving = min(t, self.stop_at)
        v = np.asarray(self.velocity, dtype=float)
        return np.asarray(self.start) + v * moving, (v if t < self.stop_at else np.zeros(2))


def run(tracker, things, steps, robot=lambda t: (0.0, 0.0, 0.0), walls=(), seed=2, after=None):
    rng = np.random.default_rng(seed)
    for k in range(steps):
        t = k * PERIOD
        for scan in scans_at(robot(t), t, things, walls, noise=0.01, rng=rng):
            tracker.update([scan], t)
        if after is not None:
            after(t)


@dataclass(frozen=True)
class Swapped:
    """A post at `before` until `at`, then one at `after` (the segmentation handing a track another thing: a tree
    coming out from behind another as the first goes behind a third, two neighbours merged)."""
    radius: float
    before: tuple[float, float]
    after: tuple[float, float]
    at: float

    def state(self, t):
        return np.asarray(self.before if t < self.at else self.after, dtype=float), np.zeros(2)


def nearest(tracker, position):
    tracks = tracker.tracks()
    return min(tracks, key=lambda track: np.hypot(*(track.position - position)), default=None)


def test_a_person_is_a_track_at_first_sight_and_has_a_velocity_from_the_second():
    person = Cylinder(0.25, (2.0, -1.0), (0.0, 1.2))
    tracker = ObstacleTracker()
    run(tracker, [person], 1)
    first = nearest(tracker, truth_at(0.0, [person])[0][0])
    assert first is not None and np.hypot(*(first.position - (2.0, -1.0))) < 0.05
    assert np.sqrt(first.covariance[2, 2]) >= 1.0 and not first.moving       # velocity unknown yet
    run(tracker, [person], 2)
    second = nearest(tracker, truth_at(0.1, [person])[0][0])
    assert second.id == first.id
    assert np.hypot(*(second.velocity - (0.0, 1.2))) < 0.5
    assert 0.1 < np.sqrt(second.covariance[3, 3]) < 0.8        # what a 0.1 s displacement of 0.03 m centres implies


def test_walking_people_turn_moving_within_0_3_s_of_first_sight():
    people = [Cylinder(0.25, (2.0, -1.5), (0.0, 1.0)), Cylinder(0.3, (3.0, 1.5), (-1.0, -0.5)),
              Cylinder(0.25, (-2.5, 0.5), (1.4, 0.0), turn_rate=0.4)]
    tracker = ObstacleTracker()
    run(tracker, people, 4)                                              # t = 0 ... 0.3 s
    assert len(tracker.moving_obstacles()) == len(people)
    rows = tracker.moving_obstacles()
    assert len(tracker.moving_covariances()) == len(rows)


@pytest.mark.parametrize("seed", range(3))
def test_people_faster_than_1_m_s_turn_moving_at_their_third_sighting(seed):
    """0.2 s after first sight: the two displacements' velocity is judged by the moving models alone, not widened
    by the stopped model's start-up share."""
    people = [Cylinder(0.3, (3.0, 1.5), (-1.0, -0.5)), Cylinder(0.25, (-2.5, 0.5), (1.4, 0.0), turn_rate=0.4)]
    tracker = ObstacleTracker()
    run(tracker, people, 3, seed=seed)                                   # t = 0, 0.1, 0.2 s
    assert len(tracker.moving_obstacles()) == len(people)


def test_a_turning_and_a_stopping_person_are_followed():
    turning = Cylinder(0.25, (2.0, -1.0), (0.0, 1.2), turn_rate=-0.8)    # a circle of 1.5 m, 2-5 m away
    stopping = StoppingPerson(0.25, (-2.5, -1.5), (0.0, 1.2), stop_at=2.0)
    tracker = ObstacleTracker()
    errors = []

    def check(t):
        if t >= 0.5:
            track = nearest(tracker, turning.state(t)[0])
            errors.append(np.hypot(*(track.velocity - turning.state(t)[1])))
            assert track.moving, f"the turning person is not moving at t={t:.1f}"
        if 0.5 <= t < 2.0:
            assert nearest(tracker, stopping.state(t)[0]).moving
    run(tracker, [turning, stopping], 30, after=check)
    assert np.percentile(errors, 90) < 0.25, f"velocity error p90 {np.percentile(errors, 90):.3f} m/s"
    stopped = nearest(tracker, stopping.state(2.9)[0])
    assert not stopped.moving and np.hypot(*stopped.velocity) < 0.1       # 0.9 s after it stopped


def test_a_person_seen_cut_by_a_post_in_front_is_followed_by_the_fitted_outline():
    person = Cylinder(0.3, (3.0, -2.0), (0.0, 1.0))
    post = Cylinder(0.15, (1.5, -0.15))                 # hides part of the person while it passes behind
    tracker = ObstacleTracker()
    errors = []

    def check(t):
        p, v = person.state(t)
        if abs(p[1]) < 0.6 and t > 0.5:                 # behind the post: its outline is cut
            track = nearest(tracker, p)
            assert np.hypot(*(track.position - p)) < 0.15 and track.moving
            errors.append(np.hypot(*(track.velocity - v)))
    run(tracker, [person, post], 40, after=check)
    assert errors and max(errors) < 0.3, f"largest velocity error while cut {max(errors):.3f} m/s"


def test_a_person_hidden_for_2_s_keeps_its_track():
    person = Cylinder(0.25, (3.5, -3.0), (0.0, 1.0))
    screen = [(2.0, -0.5, 2.0, 0.5)]                    # a 1 m board in front: hidden for about 2 s
    tracker = ObstacleTracker()
    ids = []

    def check(t):
        p = person.state(t)[0]
        if abs(p[1]) > 1.2 and t > 0.3:
            track = nearest(tracker, p)
            assert np.hypot(*(track.position - p)) < 0.3, f"lost at t={t:.1f}"
            ids.append(track.id)
    run(tracker, [person], 60, walls=screen, after=check)
    assert len(set(ids)) == 1, set(ids)


def test_static_cylinders_seen_from_a_robot_at_2_m_s_never_move():
    rng = np.random.default_rng(5)
    trees = []
    while len(trees) < 40:
        c = rng.uniform([0.0, -4.0], [20.0, 4.0])
        if abs(c[1]) > 0.9 and all(np.hypot(*(c - t.start)) > 1.0 for t in trees):
            trees.append(Cylinder(float(rng.uniform(0.07, 0.3)), tuple(c)))
    tracker = ObstacleTracker()
    moving = set()
    run(tracker, trees, 80, robot=lambda t: (2.0 * t, 0.3 * np.sin(0.7 * t), 0.3 * np.cos(0.7 * t)),
        after=lambda t: moving.update(track.id for track in tracker.tracks() if track.moving))
    assert not moving and len(tracker.tracks()) >= 5


def test_what_a_map_knows_to_be_static_starts_no_track():
    person = Cylinder(0.25, (2.0, -1.5), (0.0, 1.0))
    post = Cylinder(0.2, (2.5, 1.5))
    occupied = np.zeros((100, 100), dtype=bool)           # 0.05 m cells from (-2.5, -2.5): the post's outline
    ys, xs = np.mgrid[0:100, 0:100]
    centre = ((xs + 0.5) * 0.05 - 2.5, (ys + 0.5) * 0.05 - 2.5)
    occupied[np.abs(np.hypot(centre[0] - 2.5, centre[1] - 1.5) - 0.2) < 0.05] = True
    tracker = ObstacleTracker()
    tracker.set_static_cells(StaticCells(occupied, 0.05, (-2.5, -2.5)))
    run(tracker, [person, post], 10)
    assert nearest(tracker, np.array([2.5, 1.5])).position[1] < 1.0       # no track at the post
    assert len(tracker.moving_obstacles()) == 1
    unknowing = ObstacleTracker()
    run(unknowing, [person, post], 1)
    assert np.hypot(*(nearest(unknowing, np.array([2.5, 1.5])).position - (2.5, 1.5))) < 0.1


def test_moving_covariances_follow_the_rows_and_grow_with_time():
    people = [Cylinder(0.25, (2.0, -1.5), (0.0, 1.0)), Cylinder(0.25, (-2.0, 1.5), (1.0, 0.0))]
    tracker = ObstacleTracker()
    run(tracker, people, 10)
    rows, now = tracker.moving_obstacles(0.9), tracker.moving_covariances(0.9)
    later = tracker.moving_covariances(1.9)
    assert now.shape == (len(rows), 4, 4) == later.shape
    assert (later[:, 0, 0] > now[:, 0, 0]).all() and np.allclose(later, np.swapaxes(later, 1, 2))
    assert (np.linalg.eigvalsh(now) > 0).all()


@pytest.mark.parametrize("displacement", [1.0, 0.0])
def test_a_moving_tracks_marks_are_cleared_once_it_has_left_where_it_was_first_seen(displacement):
    """The costmaps clear after a moving track only once it is clearing_displacement from where it was first seen
    (0: as soon as it moves): a static thing taken for moving for a moment keeps its marks."""
    person = Cylinder(0.25, (2.0, -1.5), (0.0, 1.0))
    tracker = ObstacleTracker(TrackerParams(clearing_displacement=displacement))
    seen = []
    run(tracker, [person], 15,
        after=lambda t: seen.append((t, len(tracker.moving_obstacles(t)) > 0, len(tracker.clearing_circles(t)) > 0)))
    moving_at = next(t for t, moving, _ in seen if moving)
    clearing_at = next(t for t, _, clearing in seen if clearing)
    assert moving_at < 0.35
    if displacement == 0.0:
        assert clearing_at == moving_at
    else:
        assert displacement - 0.1 <= clearing_at <= displacement + 0.15       # 1 m/s



@pytest.mark.parametrize("offset", [0.35, 0.6])
def test_a_track_handed_another_thing_starts_again_there_and_never_moves(offset):
    """A post seen for 1 s, then one `offset` beside it: within the association gate, but no standing thing moves
    that far in a scan. The track starts again at the new post (its velocity measured anew) instead of reading
    the jump as a walk."""
    posts = [Swapped(0.15, (2.5, 0.0), (2.5, offset), at=1.0)]
    tracker = ObstacleTracker()
    moving, ids = [], set()
    run(tracker, posts, 25, after=lambda t: (moving.extend(tr.id for tr in tracker.tracks() if tr.moving),
                                             ids.update(tr.id for tr in tracker.tracks())))
    assert not moving, f"tracks reported moving: {sorted(set(moving))}"
    track = nearest(tracker, (2.5, offset))
    assert np.hypot(*(track.position - (2.5, offset))) < 0.05 and np.hypot(*track.velocity) < 0.1
    assert len(ids) == 1, "the post's track follows it to its new place, as before"
