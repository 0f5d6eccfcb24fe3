"""TEB control-cycle time for the lab robot, homotopy class planning off and on, side by side.

    python bench/teb.py [--cycles N] [--scene corridor|barrier|door|crowd|all] [--profile]
                        [--velocity-sigma S] [--set NAME=VALUE ...]

The lab robot (0.9 x 0.6 m box, padding 0.03, diff-drive) with the lab's teb_local_planner.yaml
(two_circles model, offsets and radii 0.2) and TEB defaults otherwise. The local costmap is the
lab's rolling window, 5 x 5 m at 0.05 m, re-cut around the robot every cycle from a world grid
whose lethal cells are what the front and back scans mark together: wall lines and box outlines.

Scenes:
  corridor  3.2 m wide corridor (walls at y = +-1.6 m), four 0.4 m boxes staggered 0.5 m off the
            centre line every 2 m; the global plan is a slalom between them to x = 10 m.
  barrier   open floor with a 2 m wall straight across a straight 3.5 m plan (an obstacle the
            global plan did not know about): the case homotopy class planning exists for.
  door      the lab's corridor (walls at y = +-1.25 m) with a 1.2 m door in the north wall at
            x = 1.5 m; the plan leaves the corridor through the door and turns west into the room
            behind it to (-2.5, 3.0, yaw 0), as the global planner routes the lab's meeting_north
            goal. The walls run on beyond the local costmap, so the part far behind the robot is
            not in the optimiser's obstacle container.
  crowd     an open 17 x 12 m field with 24 people, circles of radius 0.5 m walking straight at
            1 to 1.9 m/s in random directions (bouncing off the field's edges), all of them given
            to the planner every cycle at their current position and velocity; the round robot
            (circular model and costmap footprint, radius 0.25 m) at max_vel_x 1 m/s with
            include_dynamic_obstacles true crosses the field along an 11 m plan. With --velocity-sigma S
            each person comes with a covariance, as the tracker's filter gives one: position sigma
            0.03 m, velocity sigma S (m/s); the people still walk straight.

--set NAME=VALUE overrides a TEB parameter of every scene (a number, true/false, or text), e.g.
--set dynamic_obstacle_max_uncertainty=0.2.

Two robots run in lock step, one per planner configuration, each integrating its own (v, omega)
with a unicycle model at the lab's 20 Hz controller period, so both are timed in the same run under
the same machine load. A cycle is one compute_velocity_commands call (plan pruning/transform,
obstacle extraction, optimisation of every band, feasibility check, command): wall clock, and
the calling thread's CPU time ("cpu"), which other processes on the machine disturb less.
"bands" is the mean number of bands optimised per cycle, "failed" the cycles without a valid
command, "clearance" the smallest distance from the unpadded robot outline to a lethal cell centre
or a person's circle (negative: contact; the crowd's people do not avoid the robot, and a robot
stopped by an infeasible cycle may still be walked into).
The compiled kernels are loaded (warm_up) before the first cycle, as the node does.

After each scene, "compiled vs reference evaluation" times one evaluation with Jacobian and
normal equations (residuals, J^T J, J^T r) of the bands the homotopy run optimised (sampled every
SAMPLE_EVERY cycles, each with its own association), by the compiled kernel and by the numpy
reference (testing/teb_reference.py), and gives the median of the per-band ratios.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE  # noqa: E402
from simplebot_navigation.costmap.costmap_2d import Costmap2D  # noqa: E402
from simplebot_navigation.geometry import inverse_transform_points  # noqa: E402
from simplebot_navigation.teb import edge_kernels, warm_up  # noqa: E402
from simplebot_navigation.teb.config import TebConfig  # noqa: E402
from simplebot_navigation.teb.planner import TebLocalPlanner  # noqa: E402
from simplebot_navigation.testing.teb_reference import ReferenceEvaluation  # noqa: E402

RES = 0.05
WORLD_ORIGIN = (-6.0, -6.0)
WORLD_CELLS = (400, 280)                # 20 x 14 m
LAB_FOOTPRINT = np.array([[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]])
PADDING = 0.03
LAB_PARAMS = {
    "odom_topic": "/odom",
    "map_frame": "/odom",
    "footprint_model": {"type": "two_circles", "front_offset": 0.2, "front_radius": 0.2,
                        "rear_offset": 0.2, "rear_radius": 0.2},
}
PERIOD = 0.05
SAMPLE_EVERY = 10
ROUND_RADIUS = 0.25
ROUND_PARAMS = {"odom_topic": "/odom", "map_frame": "/odom", "include_dynamic_obstacles": True,
                "max_vel_x": 1.0, "max_vel_theta": 1.5, "acc_lim_x": 1.0, "acc_lim_theta": 1.5,
                "footprint_model": {"type": "circular", "radius": ROUND_RADIUS}}
_ANGLES = np.linspace(0.0, 2 * math.pi, 16, endpoint=False)
ROUND_FOOTPRINT = ROUND_RADIUS * np.column_stack([np.cos(_ANGLES), np.sin(_ANGLES)])
#: the crowd's field, (x_min, y_min, x_max, y_max)
FIELD = (-3.0, -5.0, 14.0, 7.0)


@dataclass
class Scene:
    world: np.ndarray
    plan: np.ndarray
    params: dict
    footprint: np.ndarray
    robot_radius: float | None = None                  # None: the lab box
    crowd: "Crowd | None" = None


class Crowd:
    """People walking straight at constant speed, bouncing off the field's edges."""

    def __init__(self, count: int = 24, radius: float = 0.5, seed: int = 7):
        rng = np.random.default_rng(seed)
        x0, y0, x1, y1 = FIELD
        pos = []
        while len(pos) < count:                         # none starts within 2 m of the robot
            p = rng.uniform((x0 + radius, y0 + radius), (x1 - radius, y1 - radius))
            if math.hypot(*p) > 2.0:
                pos.append(p)
        heading, speed = rng.uniform(-math.pi, math.pi, count), rng.uniform(1.0, 1.9, count)
        self.state = np.column_stack([np.array(pos), speed * np.cos(heading), speed * np.sin(heading),
                                      np.full(count, radius)])

    def step(self, dt: float) -> None:
        s = self.state
        s[:, :2] += dt * s[:, 2:4]
        for axis, (lo, hi) in enumerate(((FIELD[0], FIELD[2]), (FIELD[1], FIELD[3]))):
            out = ((s[:, axis] < lo + s[:, 4]) & (s[:, 2 + axis] < 0)) | ((s[:, axis] > hi - s[:, 4]) & (s[:, 2 + axis] > 0))
            s[out, 2 + axis] *= -1.0


def world_grid(walls, boxes) -> np.ndarray:
    """Lethal world cells: horizontal wall lines (y, x_from, x_to) and outlines of (cx, cy, hx, hy) boxes."""
    grid = np.zeros(WORLD_CELLS[::-1], dtype=np.uint8)
    xs = WORLD_ORIGIN[0] + (np.arange(WORLD_CELLS[0]) + 0.5) * RES
    ys = WORLD_ORIGIN[1] + (np.arange(WORLD_CELLS[1]) + 0.5) * RES
    X, Y = np.meshgrid(xs, ys)
    for wall_y, x_from, x_to in walls:
        grid[(np.abs(Y - wall_y) < RES / 2) & (X >= x_from) & (X <= x_to)] = LETHAL_OBSTACLE
    for bx, by, hx, hy in boxes:
        inside = (np.abs(X - bx) <= hx) & (np.abs(Y - by) <= hy)
        interior = (np.abs(X - bx) <= hx - RES) & (np.abs(Y - by) <= hy - RES)
        grid[inside & ~interior] = LETHAL_OBSTACLE
    return grid


def corridor():
    boxes = [(2.0, 0.5, 0.2, 0.2), (4.0, -0.5, 0.2, 0.2), (6.0, 0.5, 0.2, 0.2), (8.0, -0.5, 0.2, 0.2)]
    xs = np.arange(0.0, 10.0 + 1e-9, RES)
    # a slalom keeping about 0.8 m from the box edges, as a global planner on the inflated
    # costmap would route it, with yaw along the path
    ramp = np.clip(xs / 1.5, 0.0, 1.0) * np.clip((10.0 - xs) / 1.5, 0.0, 1.0)
    ys = -0.55 * ramp * np.cos(np.pi * (xs - 2.0) / 2.0)
    yaw = np.arctan2(np.gradient(ys), np.gradient(xs))
    return lab_scene(world_grid([(-1.6, -np.inf, np.inf), (1.6, -np.inf, np.inf)], boxes),
                     np.column_stack([xs, ys, yaw]))


def barrier():
    xs = np.arange(0.0, 3.5 + 1e-9, RES)
    return lab_scene(world_grid((), [(1.5, 0.0, 0.05, 1.0)]),
                     np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)]))


def door():
    walls = [(-1.25, -np.inf, np.inf), (1.25, -np.inf, 0.9), (1.25, 2.1, np.inf)]
    # corners rounded by corner cutting, as the global planner's gradient path cuts them
    pts = np.array([[0.0, 0.0], [1.5, 0.0], [1.5, 2.2], [-2.5, 3.0]])
    for _ in range(4):
        q = np.repeat(pts, 2, axis=0)[1:-1].reshape(-1, 2, 2)
        cut = np.concatenate([0.75 * q[:, 0] + 0.25 * q[:, 1], 0.25 * q[:, 0] + 0.75 * q[:, 1]], axis=1)
        pts = np.vstack([pts[:1], cut.reshape(-1, 2), pts[-1:]])
    seg = np.hypot(*np.diff(pts, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    t = np.arange(0.0, s[-1] + 1e-9, RES)
    xs, ys = np.interp(t, s, pts[:, 0]), np.interp(t, s, pts[:, 1])
    yaw = np.arctan2(np.gradient(ys), np.gradient(xs))
    yaw[-1] = 0.0                                       # the goal's own orientation
    return lab_scene(world_grid(walls, []), np.column_stack([xs, ys, yaw]))


def crowd():
    xs = np.arange(0.0, 11.0 + 1e-9, RES)
    plan = np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)])
    return Scene(world_grid((), []), plan, ROUND_PARAMS, ROUND_FOOTPRINT * (1.0 + PADDING / ROUND_RADIUS),
                 robot_radius=ROUND_RADIUS, crowd=Crowd())


def lab_scene(world: np.ndarray, plan: np.ndarray) -> Scene:
    return Scene(world, plan, LAB_PARAMS, LAB_FOOTPRINT + np.sign(LAB_FOOTPRINT) * PADDING)


SCENES = {"corridor": corridor, "barrier": barrier, "door": door, "crowd": crowd}


def local_costmap(world: np.ndarray, x: float, y: float) -> Costmap2D:
    """The 5 x 5 m rolling window around (x, y), aligned with the world cells; free beyond the world's edge
    (a robot that yields to the crowd may leave the field)."""
    size = 100
    mx0 = int(math.floor((x - WORLD_ORIGIN[0]) / RES)) - size // 2
    my0 = int(math.floor((y - WORLD_ORIGIN[1]) / RES)) - size // 2
    cm = Costmap2D(size, size, RES, WORLD_ORIGIN[0] + mx0 * RES, WORLD_ORIGIN[1] + my0 * RES)
    ys, xs = slice(max(my0, 0), min(my0 + size, world.shape[0])), slice(max(mx0, 0), min(mx0 + size, world.shape[1]))
    if ys.stop > ys.start and xs.stop > xs.start:
        cm.costmap[ys.start - my0:ys.stop - my0, xs.start - mx0:xs.stop - mx0] = world[ys, xs]
    return cm


#: TEB parameters from --set, over every scene's
OVERRIDES: dict = {}
#: position sigma (m) of the crowd's covariances with --velocity-sigma
POSITION_SIGMA = 0.03


def make_planner(homotopy: bool, scene: Scene) -> TebLocalPlanner:
    cfg = TebConfig.from_params({**scene.params, **OVERRIDES, "enable_homotopy_class_planning": homotopy})
    planner = TebLocalPlanner(cfg, scene.footprint, PERIOD)
    planner.set_plan(scene.plan)
    return planner


def run(name: str, cycles: int, profile: bool, velocity_sigma: float = 0.0) -> None:
    scene = SCENES[name]()
    world = scene.world
    obstacles = np.column_stack(np.nonzero(world.T == LETHAL_OBSTACLE)) * RES + np.array(WORLD_ORIGIN) + RES / 2
    runs = {mode: {"planner": make_planner(hcp, scene), "pose": np.zeros(3), "vel": (0.0, 0.0), "times": [],
                   "cpu": [], "bands": [], "done": None, "failures": 0, "clearance": math.inf, "contacts": 0}
            for mode, hcp in (("homotopy off", False), ("homotopy on", True))}
    samples = []
    profiler = None
    if profile:
        from pyinstrument import Profiler
        profiler = Profiler()
        profiler.start()
    for k in range(cycles):
        movers = scene.crowd.state.copy() if scene.crowd else np.zeros((0, 5))
        for r in runs.values():
            if r["done"] is None:
                step(r, scene, obstacles, movers, k, samples, velocity_sigma)
        if scene.crowd:
            scene.crowd.step(PERIOD)
        if all(r["done"] is not None for r in runs.values()):
            break
    if profiler:
        profiler.stop()
        print(profiler.output_text(unicode=False, color=False, show_all=False))
    for mode, r in runs.items():
        t, c = np.array(r["times"]) * 1000.0, np.array(r["cpu"]) * 1000.0
        arrived = f"{r['done']:.1f}" if r["done"] is not None else "no"
        print(f"{name:9s} {mode:13s} {len(t):6d} {np.median(t):10.1f} {np.percentile(t, 95):8.1f} {t.max():8.1f} "
              f"{np.median(c):8.1f} {np.percentile(c, 95):8.1f} "
              f"{np.mean(r['bands']):6.2f} {r['failures']:6d} {arrived:>9s} {r['clearance']:11.3f}")
        if scene.crowd:
            print(f"{name:9s} {mode:13s} cycles in contact with a person: {r['contacts']}")
    off, on = (np.median(np.array(runs[n]["times"])) for n in runs)
    print(f"{name:9s} median ratio on/off: {on / off:.2f}")
    compare_evaluations(name, runs["homotopy on"]["planner"], samples)


def step(r: dict, scene: Scene, obstacles: np.ndarray, movers: np.ndarray, k: int, samples: list,
         velocity_sigma: float) -> None:
    """One timed control cycle of one robot, then its unicycle step."""
    pose, planner = r["pose"], r["planner"]
    costmap = local_costmap(scene.world, pose[0], pose[1])
    t0, c0 = time.perf_counter(), time.thread_time()
    if scene.crowd:
        planner.set_dynamic_obstacles(movers, np.tile(np.diag([POSITION_SIGMA ** 2] * 2 + [velocity_sigma ** 2] * 2),
                                                      (len(movers), 1, 1)) if velocity_sigma > 0 else None)
    cmd = planner.compute_velocity_commands(pose, r["vel"], costmap)
    r["times"].append(time.perf_counter() - t0)
    r["cpu"].append(time.thread_time() - c0)
    r["bands"].append(planner.planner.bands_optimized)
    if planner.planner.enabled and k % SAMPLE_EVERY == 0:
        samples += [(c.band.copy(), planner.obstacles.copy(), r["vel"], planner.planner.moving.copy())
                    for c in planner.planner.candidates]
    if cmd.goal_reached:
        r["done"] = k * PERIOD
        return
    r["failures"] += not cmd.ok
    v, w = cmd.v, cmd.omega
    pose += (v * math.cos(pose[2]) * PERIOD, v * math.sin(pose[2]) * PERIOD, w * PERIOD)
    r["vel"] = (v, w)
    gap = min(clearance(pose, obstacles, np.zeros(len(obstacles)), scene.robot_radius),
              clearance(pose, movers[:, :2] + PERIOD * movers[:, 2:4], movers[:, 4], scene.robot_radius))
    r["clearance"] = min(r["clearance"], gap)
    r["contacts"] += gap < 0


def compare_evaluations(scene: str, planner: TebLocalPlanner, samples, repeats: int = 20) -> None:
    """Time the compiled and the reference evaluation (with Jacobian and normal equations) of the
    same bands at the final obstacle weight, median over repeats per band."""
    cfg, optimizer = planner.cfg, planner.planner.optimizer
    multiplier = cfg.optim.weight_adapt_factor ** (cfg.optim.no_outer_iterations - 1)
    compiled, reference = [], []
    for band, obstacles, vel, movers in samples:
        edges = optimizer.build_edges(band, obstacles, None, cfg.optim.weight_obstacle * multiplier, movers,
                                      cfg.optim.weight_dynamic_obstacle * multiplier)
        if edges.n < 1:
            continue
        optimizer.start_velocity, optimizer.free_goal_vel = vel, cfg.goal_tolerance.free_goal_vel
        params = optimizer.parameters(edges)
        args = (band.poses, band.time_diffs, params, edges.arrays, planner.model.kernel_model,
                optimizer.residual_count(edges, params))
        ref = ReferenceEvaluation(cfg, planner.model, vel, cfg.goal_tolerance.free_goal_vel)
        layout = ref.layout(edges)
        t_c, t_r = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            edge_kernels.normal_equations(*args)
            t1 = time.perf_counter()
            ref.normal_equations(ref.evaluate(band.poses, band.time_diffs, edges, True), layout)
            t2 = time.perf_counter()
            t_c.append(t1 - t0)
            t_r.append(t2 - t1)
        compiled.append(np.median(t_c))
        reference.append(np.median(t_r))
    compiled, reference = np.array(compiled) * 1e6, np.array(reference) * 1e6
    print(f"{scene:9s} compiled vs reference evaluation ({len(compiled)} bands): compiled median "
          f"{np.median(compiled):.1f} us, reference median {np.median(reference):.1f} us, "
          f"ratio median {np.median(reference / compiled):.1f}x (min {np.min(reference / compiled):.1f}x)")


def clearance(pose, centres: np.ndarray, radii: np.ndarray, robot_radius: float | None) -> float:
    """Distance from the robot's (unpadded) outline, the lab box or a circle, to the nearest of
    the circles (radius 0: a lethal cell centre)."""
    if len(centres) == 0:
        return math.inf
    local = inverse_transform_points(pose, centres)
    if robot_radius is None:
        out = np.maximum(np.abs(local) - (0.45, 0.3), 0.0)
        return float(np.min(np.hypot(out[:, 0], out[:, 1]) - radii))
    return float(np.min(np.hypot(local[:, 0], local[:, 1]) - robot_radius - radii))


def parse_value(text: str):
    """A --set value: a number, true/false, or the text itself."""
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=800, help="control cycles per planner (default 800)")
    parser.add_argument("--scene", choices=[*SCENES, "all"], default="all")
    parser.add_argument("--profile", action="store_true", help="print a pyinstrument profile of the run")
    parser.add_argument("--velocity-sigma", type=float, default=0.0,
                        help="velocity sigma (m/s) of the crowd's covariances (default 0: none given)")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="a TEB parameter")
    args = parser.parse_args()
    for item in args.set:
        name, _, value = item.partition("=")
        OVERRIDES[name] = parse_value(value)
    t0 = time.perf_counter()
    warm_up()
    print(f"warm_up: {time.perf_counter() - t0:.2f} s")
    print(f"{'scene':9s} {'mode':13s} {'cycles':>6s} {'median ms':>10s} {'p95 ms':>8s} {'max ms':>8s} "
          f"{'cpu med':>8s} {'cpu p95':>8s} {'bands':>6s} {'failed':>6s} {'arrived s':>9s} {'clearance m':>11s}")
    for scene in (SCENES if args.scene == "all" else [args.scene]):
        run(scene, args.cycles, args.profile, args.velocity_sigma)


if __name__ == "__main__":
    main()
