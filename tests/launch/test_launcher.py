"""The launcher as a user runs it: processes start with their parameters, respawn, stop cleanly."""

import ctypes
import os
import queue
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from tests.conftest import process_running

from simplebot_navigation.launch.loader import LaunchError, load_launch

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def write_launch(tmp_path, nodes: str) -> str:
    path = tmp_path / "test_launch.py"
    path.write_text(textwrap.dedent("""
        from simplebot_navigation.launch.description import Node, Param
        LAUNCH = [
        """) + textwrap.indent(textwrap.dedent(nodes), "    ") + "]\n")
    return str(path)


def _die_with_this_test() -> None:
    ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG: no launcher outlives a killed test run


def start(launch_file: str, *options: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "simplebot_navigation.launch", launch_file, *options], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            preexec_fn=_die_with_this_test, env=None if env is None else {**os.environ, **env})


def read_until(proc: subprocess.Popen, pattern: str, timeout: float = 90.0, lines: list | None = None) -> list[str]:
    """Collect output lines until one matches; a reader thread keeps the deadline real."""
    lines = [] if lines is None else lines
    if not hasattr(proc, "lines"):
        proc.lines = queue.Queue()
        threading.Thread(target=lambda: [proc.lines.put(line) for line in proc.stdout] + [proc.lines.put(None)],
                         daemon=True).start()
    if any(re.search(pattern, line) for line in lines):
        return lines  # nodes print in any order: an earlier call may have read it already
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            line = proc.lines.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            break
        if line is None:
            break
        lines.append(line.rstrip("\n"))
        if re.search(pattern, line):
            return lines
    raise AssertionError(f"{pattern!r} not seen; output so far:\n" + "\n".join(lines))


def rest_of_output(proc: subprocess.Popen) -> list[str]:
    """Every line left once the launcher has ended (after read_until)."""
    proc.wait(timeout=20)
    lines = []
    while (line := proc.lines.get(timeout=5)) is not None:
        lines.append(line.rstrip("\n"))
    return lines


def alive(pid: int) -> bool:
    return process_running(pid)


def child_pids(lines: list[str]) -> list[int]:
    return [int(m.group(1)) for line in lines for m in [re.search(r"started .* pid (\d+)", line)] if m]


def test_nodes_get_their_params_and_stop_on_sigint(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="alpha", params=[Param("greeting", "hi")]),
        Node(pkg="python", type="tests.launch.dummy_node", name="beta", ns="robot"),
    """)
    proc = start(launch)
    try:
        lines = read_until(proc, r"\[alpha\] /alpha says hi")
        read_until(proc, r"\[beta\] /robot/beta says hello", lines=lines)
        pids = child_pids(lines)
        assert len(pids) == 2
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=20)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, "\n".join(lines)
    assert not any(alive(pid) for pid in pids), "a node outlived the launcher"


def test_nodes_die_with_a_killed_launcher(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="orphan"),
    """)
    proc = start(launch)
    try:
        lines = read_until(proc, r"\[orphan\] /orphan says hello")
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        pids = child_pids(lines)
        deadline = time.monotonic() + 10
        while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
            time.sleep(0.1)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert pids and not any(alive(pid) for pid in pids), "a node outlived its SIGKILLed launcher"


def test_respawn_restarts_a_dying_node(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="phoenix", respawn=True, respawn_delay=0.2,
             params=[Param("exit_after", 0.3), Param("exit_code", 3)]),
    """)
    proc = start(launch)
    try:
        lines = read_until(proc, r"respawning /phoenix")
        read_until(proc, r"started /phoenix", lines=lines)
        read_until(proc, r"respawning /phoenix", lines=lines)
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=20)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0
    assert not any(alive(pid) for pid in child_pids(lines))


def test_failed_node_sets_the_exit_code(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="fails",
             params=[Param("exit_after", 0.2), Param("exit_code", 4)]),
    """)
    proc = start(launch)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert re.search(r"process /fails \(pid \d+\) ended with exit code 4", out)
    assert "failed: /fails (exit code 4)" in out


def test_missing_executable_is_reported_not_a_traceback(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.no_such_node", name="ghost"),
    """)
    proc = start(launch)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert "NOT STARTED /ghost" in out and "module tests.launch.no_such_node does not exist" in out
    assert "Traceback" not in out


@pytest.mark.parametrize("argv, expected", [
    (["--list"], "navigation"),
    (["navigation", "--help"], "robot:=VALUE"),
])
def test_cli_help_and_list(argv, expected):
    out = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", *argv], cwd=REPO,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and expected in out.stdout


def test_cli_rejects_a_bad_argument_with_one_line():
    out = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", "navigation", "robot:=tank"],
                         cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        "[launch] error: " + os.path.join(REPO, "launch_py", "navigation.py")
        + ": argument robot='tank' is not one of box, round"]


def test_respawns_are_counted_and_sigint_ends_them(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="phoenix", respawn=True,
             params=[Param("exit_after", 0.2), Param("exit_code", 3)]),
    """)
    proc = start(launch)
    try:
        # roslaunch's default respawn_delay is 0; a node that keeps dying is restarted each time.
        lines = read_until(proc, r"respawning /phoenix in 0\.0 s \(respawn #3, 3 in the last 60 s\)")
        read_until(proc, r"started /phoenix", lines=lines)
        proc.send_signal(signal.SIGINT)
        after = rest_of_output(proc)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, "\n".join(lines + after)
    assert not any("started /phoenix" in line for line in after), "\n".join(after)
    assert not any(alive(pid) for pid in child_pids(lines))


def test_the_run_directory_goes_away_after_the_run(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="alpha"),
    """)
    temp = tmp_path / "tmp"
    temp.mkdir()
    proc = start(launch, env={"TMPDIR": str(temp)})
    try:
        lines = read_until(proc, r"\[alpha\] /alpha says hello")
        assert list(temp.glob("simplebot_launch_*")), "the run directory should exist while the nodes run"
        proc.send_signal(signal.SIGINT)
        lines += rest_of_output(proc)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, "\n".join(lines)
    assert not list(temp.glob("simplebot_launch_*"))


def test_node_logs_are_kept_and_closed_after_each_run(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="logger", output="log", respawn=True,
             params=[Param("exit_after", 0.2)]),
    """)
    temp = tmp_path / "tmp"
    temp.mkdir()
    proc = start(launch, env={"TMPDIR": str(temp), "PYTHONWARNINGS": "always::ResourceWarning"})
    try:
        lines = read_until(proc, r"respawning /logger .*respawn #3")
        proc.send_signal(signal.SIGINT)
        lines += rest_of_output(proc)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    output = "\n".join(lines)
    assert proc.returncode == 0 and "unclosed file" not in output, output
    log = next(temp.glob("simplebot_launch_*/logger.log"))
    assert f"node output kept in {log.parent}" in output
    assert log.read_text().count("/logger says hello") >= 3


def test_keep_run_dir_keeps_the_parameter_files(tmp_path):
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="fails",
             params=[Param("exit_after", 0.2), Param("exit_code", 4)]),
    """)
    temp = tmp_path / "tmp"
    temp.mkdir()
    proc = start(launch, "--keep-run-dir", env={"TMPDIR": str(temp)})
    out, _ = proc.communicate(timeout=60)
    params = next(temp.glob("simplebot_launch_*/fails.params.yaml"))
    assert f"run directory kept: {params.parent}" in out and "exit_after: 0.2" in params.read_text()


def test_navigation_respawns_its_nodes_unless_told_not_to():
    def respawn(args):
        return {node.name: (node.respawn, node.respawn_delay) for node in load_launch("navigation", args).nodes}

    assert respawn({}) == {"simulator": (True, 0.0), "move_base": (True, 0.0), "collision_monitor": (True, 0.0)}
    assert respawn({"respawn": "false"}) == {"simulator": (False, 0.0), "move_base": (False, 0.0),
                                             "collision_monitor": (False, 0.0)}
    shown = {"viewer": "true", "foxglove": "true"}    # a bridge that dies leaves the app blank until respawned
    assert respawn(shown)["viewer"] == respawn(shown)["foxglove_bridge"] == (True, 0.0)
    assert respawn({**shown, "respawn": "false"})["foxglove_bridge"] == (False, 0.0)


@pytest.mark.parametrize("monitor, nodes, move_base_commands", [
    ("true", {"simulator", "move_base", "collision_monitor"}, "cmd_vel_nav"),
    ("false", {"simulator", "move_base"}, "simplebot_controller/cmd_vel"),
])
def test_the_collision_monitor_stands_between_move_base_and_the_base_unless_left_out(monitor, nodes,
                                                                                     move_base_commands):
    launch = load_launch("navigation", {"collision_monitor": monitor})
    assert {node.name for node in launch.nodes} == nodes
    move_base = next(node for node in launch.nodes if node.name == "move_base")
    assert ("cmd_vel", move_base_commands) in move_base.remaps


@pytest.mark.parametrize("launch_file, args, move_base", [
    ("navigation", {}, "move_base"),
    ("multi_navigation", {"robots": "2"}, "robot2/move_base"),
])
@pytest.mark.parametrize("given, tracked", [(None, True), ("true", True), ("false", False)])
def test_moving_obstacles_are_tracked_and_predicted_unless_switched_off(launch_file, args, move_base, given, tracked):
    launch = load_launch(launch_file, {**args, **({} if given is None else {"moving_obstacles": given})})
    node = next(node for node in launch.nodes if node.full_name.lstrip("/") == move_base)
    assert node.parameters["obstacle_tracking.enabled"] is tracked
    assert node.parameters["TebLocalPlannerROS.include_dynamic_obstacles"] is tracked


@pytest.mark.parametrize("attributes, message", [
    ('respawn="maybe"', "node /n: respawn 'maybe' must be true or false"),
    ('respawn=True, respawn_delay="soon"', "node /n: respawn_delay 'soon' must be a number of seconds >= 0"),
    ('respawn=True, respawn_delay=-1', "node /n: respawn_delay '-1' must be a number of seconds >= 0"),
    ('respawn=True, required=True', "node /n: respawn and required cannot both be set"),
    ('args="--verbose"', "node /n: args='--verbose' is not supported: nodes here take parameters"),
])
def test_bad_respawn_attributes_are_named(tmp_path, attributes, message):
    launch = write_launch(tmp_path, f"""
        Node(pkg="python", type="tests.launch.dummy_node", name="n", {attributes}),
    """)
    with pytest.raises(LaunchError, match=re.escape(f"{launch}: {message}")):
        load_launch(launch)


def test_a_node_that_cannot_start_with_its_configuration_is_not_respawned(tmp_path):
    """Exit code 2 is a node's "cannot be built from these parameters": respawning would fail the same way for
    ever, so the launch stops with that code."""
    launch = write_launch(tmp_path, """
        Node(pkg="python", type="tests.launch.dummy_node", name="misconfigured", respawn=True, respawn_delay=0.2,
             params=[Param("exit_after", 0.2), Param("exit_code", 2)]),
        Node(pkg="python", type="tests.launch.dummy_node", name="bystander"),
    """)
    proc = start(launch)
    try:
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 2, out
    assert "/misconfigured could not start with its configuration (exit code 2): not respawned" in out
    assert "respawning /misconfigured" not in out


@pytest.mark.parametrize("args, message", [
    (["world:=../../etc/passwd"], "argument world='../../etc/passwd': not a built-in world"),
    (["world:=/nonexistent/office.yaml"], "argument world='/nonexistent/office.yaml': no such file"),
    (["namespace:=a b"], "argument namespace='a b': not a valid ROS namespace"),
    (["namespace:=1robot"], "argument namespace='1robot': not a valid ROS namespace"),
])
def test_bad_launch_arguments_are_one_line_and_exit_2_before_anything_starts(args, message):
    out = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", "navigation", *args], cwd=REPO,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and message in out.stderr, out.stderr
    assert "started" not in out.stdout


@pytest.mark.parametrize("args, code, message", [
    (["robots:=1000"], 2, "robots:='1000' must be a whole number from 1 to max_robots (32; max_robots:=N raises it)"),
    (["robots:=99999999999"], 2, "robots:='99999999999' must be a whole number from 1 to max_robots"),
    (["robots:=40", "--max-robots", "40", "--print-params"], 0, ""),
])
def test_the_number_of_robots_is_bounded(args, code, message):
    out = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", "multi_navigation", *args], cwd=REPO,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == code and message in out.stderr, out.stderr
    if code == 0:
        assert "/robot40/move_base/" in out.stdout
