"""Real-time load: the lab tour through the launcher's processes at real time, with and without stress.

    .venv/bin/python bench/realtime.py [--goals nw_office,library] [--stress 2] [--baseline ../other-checkout]
    .venv/bin/python bench/realtime.py --arg map:=lab --stress 0    # on a map: amcl's CPU too, goals in map
    .venv/bin/python bench/realtime.py --arg slam:=true --goals="-4.5,0,3.14;-7.5,0,3.14;-8,4.5,1.57;-2.5,3,0;-1,0,0" \
        --stress 0                                                # mapping: slam's CPU, goals in the map being built
    .venv/bin/python bench/realtime.py --world crowd:2 --arg robot:=round --arg radius:=0.25 --arg tight:=true \
        --set TebLocalPlannerROS.max_vel_x=1.0 ... --stress 0      # a crowd world: 24 moving obstacles in view
    .venv/bin/python bench/realtime.py --world forest:3 --arg robot:=round --arg radius:=0.25 --arg tight:=true \
        --arg max_speed:=2.0 --time-budget 100 --stress 0        # a forest of the benchmark set, at 2 m/s

Each run starts ``python -m simplebot_navigation.launch navigation world:=lab rtf:=1`` (every node its
own process, as a user runs it; ``--world``, ``--arg`` and ``--set`` change what it starts), sends the tour's goals one after the other through the move_base
action and measures, only while a goal is active ("while driving"):

  CPU %       utime + stime of the move_base, simulator, collision_monitor and (with map:=...) amcl, (with
              slam:=true) slam processes
              (/proc/<pid>/stat, all threads), as a percentage of one core; "/sim s" is move_base's
              per simulated second, which stays comparable when a loaded machine makes the simulator
              fall behind; "-" for a process the version does not run.
  cycle       move_base's control-cycle compute times from its /diagnostics reports ("move_base:
              control loop": p50/p95/max over every cycle_times_ms of the drive; missed % =
              missed_total / cycles_total over the drive). "-" when move_base has no such report.
  cmd_vel     the intervals between consecutive /simplebot_controller/cmd_vel messages, taken from
              the publisher's DDS source timestamps, so this process's own scheduling does not
              enter: what any version can be compared by. "late" is the share of intervals longer
              than 1.5 controller periods.

A generated world (``forest:N``, ``crowd:N``, ``people:N``) is driven from its start to its own goals (a forest's
``exit``), as the scenario runner drives it. ``--arg max_speed:=V`` derives move_base's speed parameters as the
launcher does (docs/reference.md §10); the budget of each goal then follows V (or ``--time-budget``: the BARN
challenge's 100 s, say).

Runs: this tree at the machine's load, then (with --without-monitor) this tree with collision_monitor:=false, then (with --baseline, a checkout with its own .venv, or --baseline-python) the
baseline; then both again with --stress busy-loop processes beside them (--stress 0: no stress
runs). Each version runs in its own ROS domain. The table ends with the 1-minute load average at
the end of each run (/proc/loadavg).
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

import rclpy  # noqa: E402
from action_msgs.msg import GoalStatus  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from geometry_msgs.msg import Twist  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from move_base_msgs.action import MoveBase  # noqa: E402
from simplebot_description import robot_description  # noqa: E402
from simplebot_navigation.geometry import pose_in_frame  # noqa: E402
from simplebot_navigation.launch.loader import LaunchError, load_launch  # noqa: E402
from simplebot_navigation.launch.overrides import apply_set, speed_assignments  # noqa: E402
from simplebot_navigation.ros.conversions import quaternion_msg, yaw_of  # noqa: E402
from simplebot_navigation.scenarios.runner import parse_goals, time_budget  # noqa: E402
from simplebot_navigation.sim.diff_drive import drive_for  # noqa: E402
from simplebot_navigation.sim.world import Pose2D, World  # noqa: E402
from simplebot_navigation.sim.world_loader import load_world  # noqa: E402
from simplebot_navigation.testing.proc_stats import cpu_seconds, loadavg, start_stress, stop_stress  # noqa: E402

WORLD = "lab"
NODES = ("move_base", "simulator", "collision_monitor", "amcl", "slam")
LOOP_STATUS = "move_base: control loop"
LATE_FACTOR = 1.5
WARM_UP_S = 2.0          # sim seconds before the first goal, as the scenario runner waits
START_TIMEOUT_S = 120.0  # wall seconds for the launcher's nodes to come up
CANCEL_WAIT_S = 5.0
STOP_GRACE_S = 15.0
STATUS_NAMES = {GoalStatus.STATUS_SUCCEEDED: "reached", GoalStatus.STATUS_ABORTED: "aborted",
                GoalStatus.STATUS_CANCELED: "canceled over budget", GoalStatus.STATUS_UNKNOWN: "no result"}


@dataclass(frozen=True)
class Version:
    label: str
    python: str
    checkout: Path
    domain: int
    launch_args: tuple[str, ...] = ()
    world: str = WORLD


@dataclass
class RunResult:
    version: str
    load: str
    goals_reached: int = 0
    goals: int = 0
    drive_s: float = 0.0
    drive_sim_s: float = 0.0
    cpu_s: dict[str, float] = field(default_factory=dict)
    cycle_ms: list[float] = field(default_factory=list)
    cycles: int = 0
    missed: int = 0
    has_diagnostics: bool = False
    intervals_ms: list[float] = field(default_factory=list)
    loadavg: str = ""
    error: str = ""


def node_pids(launcher_pid: int, names: tuple[str, ...]) -> dict[str, int]:
    """The launcher's child process of each node, found by the ``__node:=<name>`` of its command line."""
    found = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", encoding="ascii") as handle:
                ppid = int(handle.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{entry}/cmdline", "rb") as handle:
                argv = handle.read().decode(errors="replace").split("\0")
        except OSError:
            continue
        if ppid != launcher_pid:
            continue
        for name in names:
            if f"__node:={name}" in argv:
                found[name] = int(entry)
    return found


class BenchClient(Node):
    """Goals through the action; cmd_vel publish times, loop diagnostics and ground truth from topics."""

    def __init__(self, context):
        super().__init__("realtime_bench", context=context,
                         parameter_overrides=[Parameter("use_sim_time", value=True)])
        self.action = ActionClient(self, MoveBase, "move_base")
        self.pose: Pose2D | None = None
        self.cmd_stamps_ns: list[int] = []
        self.loop_reports: list[dict[str, str]] = []
        self.create_subscription(Twist, "/simplebot_controller/cmd_vel", self._on_cmd_vel, 100)
        self.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        self.create_subscription(Odometry, "/simplebot/ground_truth", self._on_truth, 10)

    def _on_cmd_vel(self, _msg: Twist, info) -> None:
        self.cmd_stamps_ns.append(info["source_timestamp"])

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name == LOOP_STATUS:
                self.loop_reports.append({kv.key: kv.value for kv in status.values})

    def _on_truth(self, msg: Odometry) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        self.pose = Pose2D(p.x, p.y, yaw_of(q))

    def sim_time(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9


class Run:
    """One launcher of one version, driven through the goals; close() stops every process it started."""

    def __init__(self, version: Version, log_dir: str):
        self.version = version
        self.log_file = os.path.join(log_dir, f"{version.label.split()[0]}_{version.domain}_{time.time():.0f}.log")
        env = dict(os.environ, ROS_DOMAIN_ID=str(version.domain))
        with open(self.log_file, "w", encoding="utf-8") as log:
            self.launcher = subprocess.Popen(
                [version.python, "-u", "-m", "simplebot_navigation.launch", "navigation", f"world:={version.world}",
                 "rtf:=1", *version.launch_args], cwd=version.checkout, env=env, stdout=log, stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL, start_new_session=True)
        self.context = rclpy.Context()
        # not the bench's own command line: rcl would read its --arg robot:=round as a remap rule
        rclpy.init(args=[], context=self.context, domain_id=version.domain)
        self.client = BenchClient(self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.client)
        self.pids: dict[str, int] = {}

    def spin_until(self, done, wall_timeout_s: float) -> bool:
        deadline = time.monotonic() + wall_timeout_s
        while not done():
            if self.launcher.poll() is not None:
                raise RuntimeError(f"the launcher ended with exit code {self.launcher.returncode}; "
                                   f"see {self.log_file}")
            if time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=0.01)
        return True

    def wait_ready(self) -> None:
        def ready() -> bool:
            if not {"move_base", "simulator"} <= set(self.pids):
                self.pids = node_pids(self.launcher.pid, NODES)
            return ({"move_base", "simulator"} <= set(self.pids) and self.client.pose is not None
                    and self.client.sim_time() >= WARM_UP_S and self.client.action.server_is_ready())
        if not self.spin_until(ready, START_TIMEOUT_S):
            raise RuntimeError(f"the nodes did not come up within {START_TIMEOUT_S:g} s; see {self.log_file}")
        self.pids = node_pids(self.launcher.pid, NODES)     # and the collision monitor, where the version has one

    def drive(self, world: World, goals: list[Pose2D], max_vel_x: float, result: RunResult,
              budget_s: float | None = None) -> None:
        """Each goal in turn; CPU, cycles and cmd_vel intervals accumulate over the goals' active spans."""
        for goal in goals:
            budget = budget_s or time_budget(world, self.client.pose, goal, max_vel_x)
            cpu0 = {name: cpu_seconds(pid) for name, pid in self.pids.items()}
            wall0, sim0 = time.monotonic(), self.client.sim_time()
            epoch0 = time.time_ns()
            reports0 = len(self.client.loop_reports)
            status = self.send(goal, world.start, budget)
            wall1, epoch1 = time.monotonic(), time.time_ns()
            for name, pid in self.pids.items():
                result.cpu_s[name] = result.cpu_s.get(name, 0.0) + cpu_seconds(pid) - cpu0[name]
            result.drive_s += wall1 - wall0
            result.drive_sim_s += self.client.sim_time() - sim0
            result.goals += 1
            result.goals_reached += status == GoalStatus.STATUS_SUCCEEDED
            stamps = [t for t in self.client.cmd_stamps_ns if epoch0 <= t <= epoch1]
            result.intervals_ms += list(np.diff(stamps) * 1e-6)
            self.add_cycles(reports0, result)
            print(f"  {goal.name}: {STATUS_NAMES.get(status, f'status {status}')} in {wall1 - wall0:.0f} s "
                  f"(budget {budget:.0f} s)", flush=True)

    def send(self, goal: Pose2D, start: Pose2D, budget_s: float) -> int:
        """Send a goal (world frame), wait for its result (cancel after budget_s); its final status. On a map
        (map:=...) the goal is in map, which is the world frame."""
        on_map = any(arg.startswith("map:=") and arg != "map:=" or arg == "slam:=true"
                     for arg in self.version.launch_args)
        x, y, yaw = (goal.x, goal.y, goal.yaw) if on_map else \
            pose_in_frame((start.x, start.y, start.yaw), (goal.x, goal.y, goal.yaw))
        msg = MoveBase.Goal()
        msg.target_pose.header.frame_id = "map" if on_map else "odom"
        msg.target_pose.header.stamp = self.client.get_clock().now().to_msg()
        msg.target_pose.pose.position.x, msg.target_pose.pose.position.y = x, y
        msg.target_pose.pose.orientation = quaternion_msg(yaw)
        sent = self.client.action.send_goal_async(msg)
        if not self.spin_until(sent.done, 10.0) or not sent.result().accepted:
            return GoalStatus.STATUS_UNKNOWN
        handle = sent.result()
        result = handle.get_result_async()
        if not self.spin_until(result.done, budget_s):
            handle.cancel_goal_async()
            if not self.spin_until(result.done, CANCEL_WAIT_S):
                return GoalStatus.STATUS_UNKNOWN
        return result.result().status

    def add_cycles(self, first_report: int, result: RunResult) -> None:
        """Cycle times of the reports that arrived during the goal; counters against the report before it."""
        reports = self.client.loop_reports
        during = reports[first_report:]
        if not during:
            return
        result.has_diagnostics = True
        for report in during:
            result.cycle_ms += [float(v) for v in report.get("cycle_times_ms", "").split()]
        before = reports[first_report - 1] if first_report else {"cycles_total": "0", "missed_total": "0"}
        result.cycles += int(during[-1]["cycles_total"]) - int(before["cycles_total"])
        result.missed += int(during[-1]["missed_total"]) - int(before["missed_total"])

    def close(self) -> None:
        if self.launcher.poll() is None:
            os.killpg(self.launcher.pid, signal.SIGINT)
            try:
                self.launcher.wait(timeout=STOP_GRACE_S)
            except subprocess.TimeoutExpired:
                os.killpg(self.launcher.pid, signal.SIGKILL)
                self.launcher.wait()
        self.executor.shutdown()
        self.client.destroy_node()
        if self.context.ok():  # Ctrl-C has shut it down already
            rclpy.shutdown(context=self.context)


def run_tour(version: Version, load: str, world: World, goals: list[Pose2D], max_vel_x: float,
             log_dir: str, budget_s: float | None = None) -> RunResult:
    result = RunResult(version.label, load)
    print(f"{version.label}, {load}:", flush=True)
    run = Run(version, log_dir)
    try:
        run.wait_ready()
        run.drive(world, goals, max_vel_x, result, budget_s)
    except (RuntimeError, OSError) as err:  # OSError: a node's /proc entry vanished (it died)
        result.error = str(err)
        print(f"  {err}", flush=True)
    finally:
        result.loadavg = loadavg()
        run.close()
    return result


def percentiles(values: list[float]) -> str:
    if not values:
        return "-"
    p50, p95 = np.percentile(values, [50, 95])
    return f"{p50:.1f}/{p95:.1f}/{max(values):.1f}"


def table(results: list[RunResult], period_ms: float) -> str:
    header = (f"{'version':40} {'load':9} {'goals':>5} {'mb CPU%':>7} {'/sim s':>6} {'sim CPU%':>8} {'cm CPU%':>7} "
              f"{'amcl CPU%':>9} {'slam CPU%':>9} "
              f"{'cycle p50/p95/max ms':>21} "
              f"{'missed%':>7} {'cmd_vel p50/p95/max ms':>23} {'late%':>6} {'load1':>5}")
    lines = [header, "-" * len(header)]
    for r in results:
        cpu = {name: f"{100 * r.cpu_s[name] / r.drive_s:.1f}" if r.drive_s and name in r.cpu_s else "-"
               for name in NODES}
        per_sim = f"{100 * r.cpu_s['move_base'] / r.drive_sim_s:.1f}" if r.drive_sim_s > 0 else "-"
        missed = f"{100 * r.missed / r.cycles:.2f}" if r.has_diagnostics and r.cycles else "-"
        late = (f"{100 * np.mean(np.asarray(r.intervals_ms) > LATE_FACTOR * period_ms):.2f}"
                if r.intervals_ms else "-")
        lines.append(f"{r.version:40} {r.load:9} {f'{r.goals_reached}/{r.goals}':>5} {cpu['move_base']:>7} "
                     f"{per_sim:>6} {cpu['simulator']:>8} {cpu['collision_monitor']:>7} {cpu['amcl']:>9} {cpu['slam']:>9} "
                     f"{percentiles(r.cycle_ms):>21} {missed:>7} "
                     f"{percentiles(r.intervals_ms):>23} {late:>6} {r.loadavg:>5}"
                     + (f"  ({r.error})" if r.error else ""))
    return "\n".join(lines)


def describe(checkout: Path) -> str:
    """Short commit of a checkout, with '+' when its tracked files differ from it."""
    commit = subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip() or "?"
    dirty = subprocess.run(["git", "-C", str(checkout), "diff", "--quiet", "HEAD"]).returncode != 0
    return commit + ("+" if dirty else "")


@dataclass
class Plan:
    """What the command line asks for, checked before anything starts."""

    world: World
    goals: list[Pose2D]
    versions: list[Version]
    max_vel_x: float
    period_ms: float
    stress: int
    time_budget: float | None
    speed_report: list[str]


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--world", default=WORLD,
                   help=f"the world to drive in (default: {WORLD}); a generated one (forest:3) from its start to its "
                        "goals")
    p.add_argument("--goals", help="goal names of the world, comma-separated, or 'x,y[,yaw];...' (default: all its "
                                   "goals: the lab's tour, a forest's exit)")
    p.add_argument("--arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="a launch argument for every version (robot:=round, tight:=true, max_speed:=2.0, ...)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a move_base parameter for every version (the launcher's --set; it wins over max_speed's)")
    p.add_argument("--time-budget", type=float,
                   help="wall seconds per goal before it is canceled (default: from the shortest path and the top "
                        "speed, as the scenario runner's)")
    p.add_argument("--stress", type=int, default=2, help="busy-loop processes of the stress runs (0: none)")
    p.add_argument("--baseline", type=Path, help="a checkout to compare against")
    p.add_argument("--baseline-python", type=Path,
                   help="interpreter of the baseline (default: the baseline checkout's .venv/bin/python)")
    p.add_argument("--python", default=sys.executable, help="interpreter of this tree (default: this one)")
    p.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "42")),
                   help="ROS domain of this tree's runs (default: $ROS_DOMAIN_ID or 42)")
    p.add_argument("--baseline-domain", type=int, default=44, help="ROS domain of the baseline's runs")
    p.add_argument("--without-monitor", action="store_true",
                   help="also run this tree with collision_monitor:=false (in ROS domain --domain + 1)")
    return p


def plan(argv: list[str] | None = None) -> Plan:
    """Parse and check the command line: the world, its goals, the versions to run and move_base's top speed and
    control period as the launcher will derive them (max_speed:=V, then --set). A bad value exits with status 2."""
    p = parser()
    args = p.parse_args(argv)
    if args.stress < 0:
        p.error(f"--stress must be >= 0, got {args.stress}")
    if args.time_budget is not None and not (math.isfinite(args.time_budget) and args.time_budget > 0):
        p.error(f"--time-budget must be a positive number of seconds, got {args.time_budget}")
    bad = [a for a in args.arg if ":=" not in a or not a.partition(":=")[0]]
    if bad:
        p.error(f"--arg {bad[0]!r}: expected NAME:=VALUE")
    launch_args = {name: value for name, _, value in (a.partition(":=") for a in args.arg)}
    if "world" in launch_args:
        p.error("--arg world:=...: use --world")
    common = tuple(args.arg) + tuple(f"--set={s}" for s in args.set)
    try:
        world = load_world(args.world)
        goals = parse_goals(args.goals, world)
        config = load_launch("navigation", {"world": args.world, **launch_args})
        derived, speed_report = speed_assignments(config, args.set)
        apply_set(config, derived + args.set)          # as the launcher does: an explicit --set wins
        simulator = next(n for n in config.nodes if n.type == "simulator").parameters
        try:                                           # what the simulator would refuse at its start (exit 2)
            drive_for(robot_description(simulator["robot"], float(simulator["radius"])),
                      None if simulator["max_speed"] == "" else simulator["max_speed"])
        except ValueError as err:
            raise ValueError(f"max_speed:={simulator['max_speed']}: {err}") from None
    except (ValueError, LaunchError) as err:
        p.error(str(err))
    versions = [Version(f"current {describe(ROOT)}", args.python, ROOT, args.domain, common, args.world)]
    if args.without_monitor:
        versions.append(Version(f"current {describe(ROOT)} collision_monitor:=false", args.python, ROOT,
                                args.domain + 1, common + ("collision_monitor:=false",), args.world))
    if args.baseline is not None:
        python = args.baseline_python or args.baseline / ".venv" / "bin" / "python"
        if not python.exists():
            p.error(f"--baseline {args.baseline}: no {python}")
        versions.append(Version(f"baseline {describe(args.baseline)}", str(python), args.baseline.resolve(),
                                args.baseline_domain, common, args.world))
    move_base = next(n for n in config.nodes if n.name == "move_base")
    max_vel_x = float(move_base.parameters.get("TebLocalPlannerROS.max_vel_x", 0.4))
    period_ms = 1e3 / float(move_base.parameters.get("controller_frequency", 20.0))
    return Plan(world, goals, versions, max_vel_x, period_ms, args.stress, args.time_budget, speed_report)


def main(argv: list[str] | None = None) -> None:
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # stopped from outside, it still stops its launchers
    bench = plan(argv)
    world, goals, versions = bench.world, bench.goals, bench.versions
    log_dir = tempfile.mkdtemp(prefix="simplebot_realtime_")
    print(f"{versions[0].world}: {', '.join(g.name for g in goals)}; "
          f"top speed {bench.max_vel_x:g} m/s; launcher logs in {log_dir}", flush=True)
    for line in bench.speed_report:
        print(f"  {line}", flush=True)
    results = [run_tour(v, "normal", world, goals, bench.max_vel_x, log_dir, bench.time_budget) for v in versions]
    if bench.stress:
        stress = start_stress(bench.stress)
        try:
            results += [run_tour(v, f"stress {bench.stress}", world, goals, bench.max_vel_x, log_dir,
                                 bench.time_budget) for v in versions]
        finally:
            stop_stress(stress)
    print()
    print(f"CPU % of one core while a goal is active (/sim s: move_base's CPU per simulated second, which a "
          f"simulator falling behind real time does not flatter); cycle: move_base's /diagnostics; cmd_vel: intervals between "
          f"publishes, late > {LATE_FACTOR:g} x {bench.period_ms:g} ms; load1: 1-min load average at the end of the run")
    print(table(results, bench.period_ms))


if __name__ == "__main__":
    main()
