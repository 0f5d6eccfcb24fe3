"""Moving obstacles in world files: the ``moving:`` format, its errors, and the motion between keyframes."""

import math
import textwrap

import numpy as np
import pytest

from simplebot_description import builtin_worlds
from simplebot_navigation.sim import MovingObstacle, MovingTracks, load_world, world_from_dict, write_world
from simplebot_navigation.sim.world import World

WALKER = {"shape": "cylinder", "radius": 0.3, "keyframes": [[0, 0, 0], [2, 2, 0], [4, 2, 2]]}


def parse(entry: dict, source="w.yaml"):
    return world_from_dict({"moving": [WALKER, entry]}, source=source).moving[1]


def test_entries_load_with_their_defaults():
    world = world_from_dict({"moving": [WALKER, {"shape": "box", "size": [1, 0.5], "name": "cart", "height": 0.8,
                                                 "keyframes": [[1, 0, 0], [3, 1, 1]], "interpolation": "spline",
                                                 "loop": True, "phase": 0.5}]})
    walker, cart = world.moving
    assert walker == MovingObstacle("cylinder", ((0.0, 0.0, 0.0), (2.0, 2.0, 0.0), (4.0, 2.0, 2.0)), radius=0.3)
    assert (walker.height, walker.interpolation, walker.loop, walker.phase, walker.name) == (1.0, "linear",
                                                                                           False, 0.0, None)
    assert cart == MovingObstacle("box", ((1.0, 0.0, 0.0), (3.0, 1.0, 1.0)), size=(1.0, 0.5), height=0.8,
                                  interpolation="spline", loop=True, phase=0.5, name="cart")
    assert walker.bounding_radius() == 0.3 and cart.bounding_radius() == pytest.approx(math.hypot(1, 0.5) / 2)
    assert list(world.obstacles()) == []


def test_write_world_round_trips_moving_obstacles(tmp_path):
    trolley = {"shape": "box", "size": [0.4, 0.6], "keyframes": [[0, 1, 1], [1, 2, 1]],
               "interpolation": "spline", "loop": True, "phase": 2.5, "name": "trolley"}
    world = world_from_dict({"name": "crowd", "moving": [WALKER, trolley]})
    write_world(world, tmp_path / "crowd.yaml")
    again = load_world(tmp_path / "crowd.yaml")
    assert again.moving == world.moving and again.warnings == ()
    assert "moving" not in load_world("lab").to_dict()


@pytest.mark.parametrize("entry, message", [
    ({"shape": "cylinder", "radius": 0.3, "keyframes": [[0, 0, 0]]},
     r"moving\[1\]\.keyframes: needs at least 2 keyframes \[t, x, y\], got 1"),
    ({"shape": "cylinder", "radius": 0.3, "keyframes": [[0, 0, 0], [1, 1, 1], [1, 2, 2]]},
     r"moving\[1\]\.keyframes\[2\]: time 1.0 is not after the previous keyframe's 1.0"),
    ({"shape": "cylinder", "radius": 0.3, "keyframes": [[0, 0, 0], [1, float("nan"), 1]]},
     r"moving\[1\]\.keyframes\[1\]\.x: expected a finite number, got nan"),
    ({"shape": "cylinder", "radius": 0.3, "keyframes": [[0, 0, 0], [1, 1]]},
     r"moving\[1\]\.keyframes\[1\]: expected \[t, x, y\], got \[1, 1\]"),
    ({"shape": "cylinder", "radius": 0.3, "keyframes": "0 0 0"},
     r"moving\[1\]\.keyframes: expected a list of \[t, x, y\], got str"),
    ({"shape": "cylinder", "radius": -0.3, "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.radius: radius must be positive and finite, got -0.3"),
    ({"shape": "cylinder", "radius": float("inf"), "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.radius: expected a finite number, got inf"),
    ({"shape": "box", "size": [1, 0], "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.size: size must be positive and finite, got \[1.0, 0.0\]"),
    ({"shape": "cylinder", "radius": 0.3, "height": 0, "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.height: height must be positive and finite, got 0.0"),
    ({"shape": "sphere", "radius": 0.3, "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.shape: unknown shape 'sphere' \(expected cylinder or box\)"),
    ({"shape": "cylinder", "radius": 0.3, "interpolation": "cubic", "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.interpolation: unknown interpolation 'cubic' \(expected linear or spline\)"),
    ({"shape": "cylinder", "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]: missing key 'radius' \(a cylinder needs it\)"),
    ({"shape": "box", "keyframes": [[0, 0, 0], [1, 1, 1]]}, r"moving\[1\]: missing key 'size' \(a box needs it\)"),
    ({"shape": "box", "size": [1, 1], "radius": 0.3, "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.radius: a box has size, not radius"),
    ({"shape": "cylinder", "radius": 0.3, "loop": "yes", "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]\.loop: expected true or false, got 'yes'"),
    ({"shape": "cylinder", "radius": 0.3, "speed": 1, "keyframes": [[0, 0, 0], [1, 1, 1]]},
     r"moving\[1\]: unknown key 'speed'"),
    ({"radius": 0.3, "keyframes": [[0, 0, 0], [1, 1, 1]]}, r"moving\[1\]: missing key 'shape'"),
])
def test_bad_entries_name_file_entry_and_key(entry, message):
    with pytest.raises(ValueError, match="^w.yaml: " + message):
        parse(entry)


def test_unknown_top_level_key_warns_with_the_closest_key(tmp_path):
    path = tmp_path / "lab.yaml"
    path.write_text(textwrap.dedent("""\
        name: lab
        movng: [{shape: cylinder, radius: 0.3, keyframes: [[0, 0, 0], [1, 1, 1]]}]
        """))
    world = load_world(path)
    assert world.warnings == ("lab.yaml: unknown world key 'movng' (did you mean 'moving'?); ignored",)
    assert world.moving == ()


@pytest.mark.parametrize("name", [*builtin_worlds(), "forest:3"])
def test_shipped_and_generated_worlds_load_without_warnings(tmp_path, name):
    world = load_world(name)
    assert world.warnings == ()
    write_world(world, tmp_path / "copy.yaml")
    again = load_world(tmp_path / "copy.yaml")
    assert again.warnings == () and dict(again.extra) == dict(world.extra)


# -- motion ------------------------------------------------------------------------------------

def walker(**kwargs) -> MovingObstacle:
    return MovingObstacle("cylinder", ((1.0, 0.0, 0.0), (3.0, 2.0, 0.0), (4.0, 2.0, 1.0)), radius=0.3, **kwargs)


def test_linear_motion_rests_before_and_after():
    w = walker()
    assert w.state(0.0) == (0.0, 0.0, 0.0, 0.0)            # before the first keyframe: resting there
    assert w.state(2.0) == pytest.approx((1.0, 0.0, 1.0, 0.0))
    assert w.state(3.5) == pytest.approx((2.0, 0.5, 0.0, 1.0))
    assert w.state(4.0) == (2.0, 1.0, 0.0, 0.0)            # at and after the last: resting there
    assert w.state(100.0) == (2.0, 1.0, 0.0, 0.0)


def test_phase_delays_the_animation():
    assert walker(phase=10.0).state(12.0) == pytest.approx(walker().state(2.0))
    assert walker(phase=10.0).state(5.0) == (0.0, 0.0, 0.0, 0.0)


def test_loop_jumps_back_to_the_first_keyframe():
    w = walker(loop=True)
    assert w.state(4.0) == pytest.approx((0.0, 0.0, 1.0, 0.0))   # tau 4 = 1 + 3: the first keyframe again
    assert w.state(2.0 + 3 * 7) == pytest.approx(w.state(2.0))
    assert w.state(0.5) == (0.0, 0.0, 0.0, 0.0)                # before the first keyframe it still rests


def test_spline_passes_through_the_keyframes_and_is_smooth():
    w = walker(interpolation="spline")
    for t, x, y in w.keyframes[:-1]:
        assert w.state(t)[:2] == pytest.approx((x, y))
    times = np.linspace(1.0, 3.999, 400)
    states = np.array([w.state(t) for t in times])
    assert np.all(np.abs(np.diff(states[:, 2:], axis=0)) < 0.05)    # velocity continuous through t = 3
    # velocity is the derivative of position
    numeric = np.gradient(states[:, :2], times, axis=0)
    assert np.allclose(numeric[1:-1], states[1:-1, 2:], atol=5e-3)


def test_a_closed_spline_loop_is_smooth_across_the_wrap():
    square = MovingObstacle("cylinder", ((0, 0, 0), (1, 1, 0), (2, 1, 1), (3, 0, 1), (4, 0, 0)), radius=0.2,
                            interpolation="spline", loop=True)
    assert square.state(3.999)[2:] == pytest.approx(square.state(4.0)[2:], abs=1e-2)


def test_tracks_evaluate_many_obstacles_as_each_alone():
    obstacles = [walker(), walker(phase=0.7, loop=True, interpolation="spline"),
                 MovingObstacle("box", ((0, 5, 5), (1, 6, 5), (2, 6, 6), (3, 5, 6), (5, 5, 5)), size=(1, 1))]
    tracks = MovingTracks(obstacles)
    for t in (0.0, 1.3, 2.0, 3.7, 4.9, 13.2):
        assert tracks.states(t) == pytest.approx(np.array([o.state(t) for o in obstacles]))
    assert MovingTracks([]).states(1.0).shape == (0, 4)


def test_constructing_in_code_checks_the_values_too():
    with pytest.raises(ValueError, match=r"keyframes\[1\]: time 0 is not after"):
        MovingObstacle("cylinder", ((0, 0, 0), (0, 1, 1)), radius=0.3)
    assert World("w", moving=(walker(),)).moving[0].name is None
