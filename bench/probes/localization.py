"""Hostile input for amcl and map_server on the live launch (map:=lab): every live number of amcl beyond its bounds,
map_server's file and frame, bursts of 50 global_localization and 200 GetMap requests, and a map larger than the
bound. Afterwards amcl is put back on the robot's true pose and must be localized, and both nodes must be the
processes that started."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.srv import GetMap
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from std_srvs.srv import Empty

from bench.probes._common import set_parameters
from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.maps import MAX_CELLS
from simplebot_navigation.parameters import fields_of
from simplebot_navigation.ros.qos import LATCHED, SERVICE_QOS

WAIT_S = 30.0


def _hostile_values(spec) -> list:
    """Far beyond either bound, not a number, and 0 where 0 is illegal."""
    values = [2 ** 62, -2 ** 62] if spec.kind is int else [1e308, -1e308, math.nan]
    if spec.low is not None and (spec.low > 0 or (spec.low == 0 and spec.low_open)):
        values.append(spec.kind(0))
    return values


def _hostile_amcl_parameters(session) -> list[tuple[str, str, str, bool]]:
    """Round by round, every numeric parameter's next hostile value in one request (each answered on its own)."""
    client = AsyncParameterClient(session.client, "/amcl")
    hostile = {name: _hostile_values(spec) for name, spec in fields_of(AmclParams).items()
               if spec.kind in (int, float) and spec.dynamic}
    refusals: dict[str, list[str]] = {name: [] for name in hostile}
    accepted: dict[str, list] = {name: [] for name in hostile}
    for round_ in range(max(map(len, hostile.values()))):
        params = [Parameter(name, value=values[round_]) for name, values in hostile.items() if len(values) > round_]
        for param, result in zip(params, set_parameters(session, client, params)):
            if result.successful:
                accepted[param.name].append(param.value)
            else:
                refusals[param.name].append(result.reason)
    rows = []
    for name, values in hostile.items():
        ok = not accepted[name] and len(refusals[name]) == len(values) and all(name in r for r in refusals[name])
        outcome = refusals[name][0] if refusals[name] else "NO ANSWER"
        rows.append((f"param set /amcl {name}", ", ".join(map(repr, values)),
                     outcome + (f"; ACCEPTED {accepted[name]}" if accepted[name] else ""), ok))
    return rows


def _big_map(folder: Path) -> Path:
    side = math.isqrt(MAX_CELLS) + 1
    (folder / "big.pgm").write_bytes(f"P5\n{side} {side}\n255\n".encode() + bytes(side * side))
    (folder / "big.yaml").write_text("image: big.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    return folder / "big.yaml"


def _hostile_map_server_parameters(session, folder: Path) -> list[tuple[str, str, str, bool]]:
    client = AsyncParameterClient(session.client, "/map_server")
    rows = []
    for name, value in (("yaml_filename", str(_big_map(folder))), ("yaml_filename", "/dev/zero"),
                        ("yaml_filename", str(folder / "missing.yaml")), ("yaml_filename", "atlantis"),
                        ("frame_id", ""), ("frame_id", "/")):
        results = set_parameters(session, client, [Parameter(name, value=value)])
        ok = bool(results) and not results[0].successful and bool(results[0].reason)
        rows.append((f"param set /map_server {name}", value[-46:], results[0].reason if results else "NO ANSWER", ok))
    return rows


def _burst(session, srv_type, name: str, count: int) -> tuple[str, str, str, bool]:
    client = session.client.create_client(srv_type, name, qos_profile=SERVICE_QOS)   # room for the answers too
    if not client.wait_for_service(timeout_sec=10.0):
        return (f"burst {name}", f"{count} at once", "no service", False)
    futures = [client.call_async(srv_type.Request()) for _ in range(count)]
    session.spin_wall(WAIT_S, lambda: all(f.done() for f in futures))
    answered = sum(f.done() for f in futures)
    session.client.destroy_client(client)
    # The service queues SERVICE_QOS.depth requests: of a larger burst, those beyond are the middleware's to drop.
    queued = min(count, SERVICE_QOS.depth)
    return (f"burst {name}", f"{count} at once", f"{answered} answered (queue {SERVICE_QOS.depth})",
            answered >= queued)


def _relocalize(session) -> tuple[str, str, str, bool]:
    """/initialpose at the true pose, then amcl's estimate must come within 0.3 m of it (a standing robot makes
    no filter update, so no-motion updates are asked for)."""
    estimates: list[PoseWithCovarianceStamped] = []
    session.client.create_subscription(PoseWithCovarianceStamped, "/amcl_pose", estimates.append, LATCHED)
    publisher = session.client.create_publisher(PoseWithCovarianceStamped, "/initialpose", 1)
    truth = session.pose()
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = "map"
    msg.pose.pose.position.x, msg.pose.pose.position.y = truth.x, truth.y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(truth.yaw / 2), math.cos(truth.yaw / 2)
    msg.pose.covariance[0] = msg.pose.covariance[7] = 0.01
    msg.pose.covariance[35] = 0.003
    session.spin_wall(1.0, lambda: publisher.get_subscription_count() > 0)
    publisher.publish(msg)
    session.client.destroy_publisher(publisher)

    def error() -> float:
        truth, last = session.pose(), estimates[-1].pose.pose.position
        return math.hypot(last.x - truth.x, last.y - truth.y)
    nomotion = session.client.create_client(Empty, "/request_nomotion_update", qos_profile=SERVICE_QOS)
    for _ in range(5):
        session.spin_wall(1.0, nomotion.service_is_ready)
        nomotion.call_async(Empty.Request())
        if session.spin_wall(2.0, lambda: estimates and error() < 0.3):
            break
    session.client.destroy_client(nomotion)
    said = f"{error():.2f} m from the truth" if estimates else "no /amcl_pose"
    return ("amcl localized afterwards", "initialpose at the true pose", said, bool(estimates) and error() < 0.3)


def run(session) -> list[tuple[str, str, str, bool]]:
    pids = {name: session.node_pid(name) for name in ("amcl", "map_server")}
    rows: list[tuple[str, str, str, bool]] = []
    rows.append(_burst(session, Empty, "/global_localization", 50))
    rows.append(_burst(session, GetMap, "/map_server/map", 200))
    rows += _hostile_amcl_parameters(session)
    with tempfile.TemporaryDirectory(prefix="probe_maps_") as folder:
        rows += _hostile_map_server_parameters(session, Path(folder))
    rows.append(_relocalize(session))
    same = {name: session.node_pid(name) == pid for name, pid in pids.items()}
    rows.append(("amcl and map_server the same processes", str(pids), str(same), all(same.values())))
    return rows
