"""The simulator on one host and move_base on another, talking DDS over a real (virtual) network.

Two network namespaces stand for the workstation and the robot, each with loopback and one veth end
and nothing else: joined directly (one subnet, discovery by multicast), or through a third namespace
that routes between two subnets, which multicast does not cross (discovery by ROS_STATIC_PEERS). The
simulator launch runs on the workstation, the move_base launch on the robot, with SUBNET discovery and
Fast DDS's shared-memory transport off, so every sample crosses the veth as UDP. A goal sent from the
workstation must be reached, and what the kernel shows (interfaces, sockets, the veth's counters, the
processes' mappings) must agree that the veth was the only way. Needs root and iproute2; without them
the test fails and says so."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

pytestmark = [pytest.mark.timeout(240), pytest.mark.e2e]

DDS_MULTICAST = "239.255.0.1"     # the RTPS default discovery group
WORLD = "empty"
GOAL = (1.5, 0.5, 1.57)           # x, y, yaw: a short drive with a turn
GOAL_CLIENT = Path(__file__).with_name("remote_goal.py")
GOAL_BUDGET_S = 40.0              # sim time for the goal itself
CLIENT_WALL_S = 100.0             # wall time for the start-up of both launches (5 to 25 s here) and the goal
#: bytes the robot's veth must receive: /clock at 100 Hz, TF, odometry and two lidars at 10 Hz (about 100 kB/s;
#: 1.5 MB in a run here, against tens of kB for discovery alone)
MIN_ROBOT_RX_BYTES = 500_000
#: and send: discovery, cmd_vel at 20 Hz, move_base's status and the goal's result
MIN_ROBOT_TX_BYTES = 20_000


@dataclass
class Host:
    """One network namespace: its name, its end of the veth and that end's address."""

    netns: str
    veth: str
    address: str

    def run(self, *command: str) -> str:
        return ip("netns", "exec", self.netns, *command).stdout

    def addresses(self) -> list[tuple[str, str]]:
        """(interface, address) of every address in the namespace."""
        return [(line.split()[1], line.split()[3].split("/")[0]) for line in self.run("ip", "-o", "addr").splitlines()]

    def veth_bytes(self) -> tuple[int, int]:
        stats = json.loads(self.run("ip", "-j", "-s", "link", "show", "dev", self.veth))[0]["stats64"]
        return stats["rx"]["bytes"], stats["tx"]["bytes"]


def ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    result = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if check and result.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)} failed: {result.stderr.strip()}")
    return result


def require_netns() -> None:
    """Fail, naming what is missing, where network namespaces cannot be made: this test must not vanish."""
    missing = [tool for tool in ("ip", "ss") if shutil.which(tool) is None]
    if missing:
        pytest.fail(f"the two-host test needs iproute2: {' and '.join(missing)} not on PATH (apt-get install iproute2)")
    if os.geteuid() != 0:
        pytest.fail(f"the two-host test needs root to create network namespaces (running as uid {os.geteuid()})")


def netns_pids(netns: str) -> list[int]:
    return [int(pid) for pid in ip("netns", "pids", netns).stdout.split()]


def veth_pair(a: str, a_netns: str, a_address: str, b: str, b_netns: str, b_address: str) -> None:
    """A veth pair from one namespace to another, both ends up, addressed (/24) and multicast-capable."""
    ip("link", "add", a, "netns", a_netns, "type", "veth", "peer", "name", b, "netns", b_netns)
    for name, netns, address in ((a, a_netns, a_address), (b, b_netns, b_address)):
        ip("-n", netns, "addr", "add", f"{address}/24", "dev", name)
        ip("-n", netns, "link", "set", name, "multicast", "on", "up")


@contextlib.contextmanager
def two_hosts(routed: bool):
    """Workstation and robot namespaces, joined by one veth pair (one subnet) or, routed, each by a veth pair
    to a router namespace (two subnets: multicast does not cross the router). On exit every process left in
    them is killed and the namespaces are deleted, which deletes the veths."""
    require_netns()
    tag = os.getpid()
    workstation = Host(f"simplebot-ws-{tag}", f"sbws{tag}", "10.213.1.2" if routed else "10.213.0.1")
    robot = Host(f"simplebot-robot-{tag}", f"sbrb{tag}", "10.213.2.2" if routed else "10.213.0.2")
    router = f"simplebot-router-{tag}"
    created = []
    try:
        for netns in (workstation.netns, robot.netns, *([router] if routed else [])):
            result = ip("netns", "add", netns, check=False)
            if result.returncode != 0:
                pytest.fail(f"the two-host test needs root and iproute2 (ip netns add failed: {result.stderr.strip()})")
            created.append(netns)
            ip("-n", netns, "link", "set", "lo", "up")
        if not routed:
            veth_pair(workstation.veth, workstation.netns, workstation.address, robot.veth, robot.netns, robot.address)
        else:
            for number, host in enumerate((workstation, robot), start=1):
                gateway = f"10.213.{number}.1"
                veth_pair(host.veth, host.netns, host.address, f"sbr{number}{tag}", router, gateway)
                ip("-n", host.netns, "route", "add", "default", "via", gateway)
            ip("netns", "exec", router, "sh", "-c", "echo 1 > /proc/sys/net/ipv4/ip_forward")
        yield workstation, robot
    finally:
        for netns in created:
            for pid in netns_pids(netns):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
        for netns in created:
            ip("netns", "del", netns, check=False)


def dds_env(static_peer: str | None) -> dict[str, str]:
    """What a user sets on both hosts (README, "Two hosts"), plus UDP only: shared memory would carry the samples
    past the veth (both namespaces share /dev/shm), and this Fast DDS (2.14) honours FASTDDS_BUILTIN_TRANSPORTS."""
    env = {k: v for k, v in os.environ.items() if k not in ("ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY")}
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET", FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
               PYTHONUNBUFFERED="1", **({"ROS_STATIC_PEERS": static_peer} if static_peer else {}))
    return env


@contextlib.contextmanager
def launch(host: Host, env: dict[str, str], log: Path, *args: str):
    """``python -m simplebot_navigation.launch ARGS`` inside a namespace; Ctrl-C'd (then killed) on exit."""
    with open(log, "w", encoding="utf-8") as out:
        process = subprocess.Popen(["ip", "netns", "exec", host.netns, sys.executable, "-m",
                                    "simplebot_navigation.launch", *args],
                                   stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                   env=env, start_new_session=True)
    try:
        yield process
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGINT)
            try:
                process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()


def foreign_sockets(host: Host, allowed: set[str]) -> list[str]:
    """Lines of `ss` in the namespace whose local or peer address is not one of ``allowed``."""
    lines = host.run("ss", "-H", "-n", "-a", "-p", "-t", "-u").splitlines()
    assert any("python" in line for line in lines), f"no DDS socket of the nodes in {host.netns}:\n" + "\n".join(lines)

    def address(endpoint: str) -> str:
        return endpoint.rpartition(":")[0].split("%")[0].strip("[]")
    return [line for line in lines if not {address(line.split()[4]), address(line.split()[5])} <= allowed]


def shared_memory_users(host: Host) -> list[str]:
    """Processes in the namespace that map a Fast DDS shared-memory segment."""
    users = []
    for pid in netns_pids(host.netns):
        with contextlib.suppress(FileNotFoundError, ProcessLookupError):
            if "/dev/shm/fastrtps_" in Path(f"/proc/{pid}/maps").read_text():
                users.append(f"pid {pid}: {Path(f'/proc/{pid}/cmdline').read_text().replace(chr(0), ' ')}")
    return users


def tail(path: Path, lines: int = 30) -> str:
    return f"--- {path.name} ---\n" + "\n".join(path.read_text(errors="replace").splitlines()[-lines:])


@pytest.mark.parametrize("discovery", ["multicast", "static peers"])
def test_simulator_and_move_base_on_two_hosts(tmp_path, discovery):
    """On one subnet SUBNET discovery finds the other host by multicast; across a router, which multicast does
    not cross, ROS_STATIC_PEERS names it (README, "Two hosts")."""
    started = time.monotonic()
    static = discovery == "static peers"
    with two_hosts(routed=static) as (workstation, robot):
        for host in (workstation, robot):
            interfaces = {name for name, _ in host.addresses()}
            assert interfaces == {"lo", host.veth}, f"{host.netns} has {interfaces}, not only lo and the veth"
        workstation_env = dds_env(robot.address if static else None)
        robot_env = dds_env(workstation.address if static else None)
        logs = tmp_path / "simulator.log", tmp_path / "move_base.log"
        with launch(workstation, workstation_env, logs[0], "simulator", f"world:={WORLD}"), \
                launch(robot, robot_env, logs[1], "move_base"):
            client = subprocess.run(
                ["ip", "netns", "exec", workstation.netns, sys.executable, str(GOAL_CLIENT), WORLD,
                 *map(str, (*GOAL, GOAL_BUDGET_S, CLIENT_WALL_S))],
                capture_output=True, text=True, env=workstation_env, timeout=CLIENT_WALL_S + 30)
            output = client.stdout.strip().splitlines()
            context = "\n".join([client.stdout[-2000:], client.stderr[-2000:], *map(tail, logs)])
            assert client.returncode == 0 and output, f"the goal client failed:\n{context}"
            result = json.loads(output[-1])
            assert result["success"], f"goal from the workstation not reached: {result['failures']}\n{context}"

            # loopback, the wildcard, the veth ends and the discovery group; the IPv6 forms of the first two
            allowed = {"127.0.0.1", "::1", "0.0.0.0", "::", "*", DDS_MULTICAST, workstation.address, robot.address}
            for host in (workstation, robot):
                foreign, shm = foreign_sockets(host, allowed), shared_memory_users(host)
                assert not foreign, f"sockets in {host.netns} on other addresses:\n" + "\n".join(foreign)
                assert not shm, "Fast DDS shared memory in use, so samples need not cross the veth:\n" + "\n".join(shm)
            rx, tx = robot.veth_bytes()
            assert rx > MIN_ROBOT_RX_BYTES and tx > MIN_ROBOT_TX_BYTES, \
                f"too little traffic crossed the veth: the robot received {rx} and sent {tx} bytes"
    print(f"two hosts, {discovery}: goal {result['status']} in {result['time_s']:.1f} s sim, "
          f"{result['position_error']:.3f} m off; robot veth rx {rx} B, tx {tx} B; "
          f"test wall time {time.monotonic() - started:.0f} s")
