"""move_base's hostile-input probes (issue 43), run by bench/probe.py against its live launch: floods of hostile
obstacle messages on /move_base/TebLocalPlannerROS/obstacles (5 Hz for a few seconds each, while a goal runs),
with move_base's control loop (its /diagnostics missed periods), memory (VmRSS) and the goal watched; then 50
cancels at once on /navigate_to_pose and 50 calls at once on /move_base/clear_costmaps. Leaves the robot standing."""

from __future__ import annotations

import math
from pathlib import Path

FLOOD_S = 3.0
FLOOD_HZ = 5.0
BURST = 50
#: move_base's resident memory may grow this much over the floods (MB): the middleware keeps up to OBSTACLE_QUEUE
#: (5) samples of the largest message seen (42 MB for 100,000 obstacles) and rclpy copies the one taken; more of the
#: same traffic must not add to it (MEMORY_REPEAT_MB). Measured on 2 cores: +248 MB, then +0 MB.
MEMORY_BOUND_MB = 350.0
MEMORY_REPEAT_MB = 30.0
#: at most this share of the control periods may be missed while a flood runs. The regression this catches is the
#: issue's 0-2 cycles a second; 100,000 obstacles at 5 Hz are 210 MB/s the middleware must still receive and
#: copy, which on 2 cores (the probe publishing them on the same machine) cost ~60 % of the periods; the other
#: floods cost none (the message is refused after reading its lengths)
MISSED_SHARE = 0.75
GOALS = ((3.5, 0.0), (1.0, 0.0))


def rss_mb(pid: int | None) -> float:
    if pid is None:
        return math.nan
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return math.nan


class LoopWatch:
    """move_base's control-loop diagnostics: cycles and missed periods since start, as last reported."""

    def __init__(self, node):
        from diagnostic_msgs.msg import DiagnosticArray

        self.cycles = self.missed = 0
        node.create_subscription(DiagnosticArray, "/diagnostics", self._on, 10)

    def _on(self, msg) -> None:
        for status in msg.status:
            if status.name == "move_base: control loop" and status.hardware_id == "move_base":
                values = {kv.key: kv.value for kv in status.values}
                self.cycles, self.missed = int(values["cycles_total"]), int(values["missed_total"])


def flood(session, publisher, raw: bytes, watch: LoopWatch) -> tuple[int, int]:
    """Publish raw at FLOOD_HZ for FLOOD_S (wall), then wait for two reports: (missed periods, periods)."""
    missed = watch.missed
    for _ in range(int(FLOOD_S * FLOOD_HZ)):
        publisher.publish(raw)
        session.spin_wall(1.0 / FLOOD_HZ)
    session.spin_wall(2.2)
    return watch.missed - missed, int((FLOOD_S + 2.2) * 20)


def burst(session, futures) -> int:
    session.spin_wall(30.0, lambda: all(f.done() for f in futures))
    return sum(f.done() for f in futures)


def run(session) -> list[tuple[str, str, str, bool]]:
    from costmap_converter_msgs.msg import ObstacleArrayMsg
    from geometry_msgs.msg import PoseStamped
    from nav2_msgs.action import NavigateToPose
    from rclpy.action import ActionClient
    from std_srvs.srv import Empty

    from simplebot_navigation.ros.qos import SERVICE_QOS
    from simplebot_navigation.sim.world import Pose2D
    from simplebot_navigation.testing.hostile_obstacles import hostile_messages

    rows = []
    node = session.client
    pid = session.node_pid("move_base")
    watch = LoopWatch(node)
    publisher = node.create_publisher(ObstacleArrayMsg, "/move_base/TebLocalPlannerROS/obstacles", 10)
    session.spin_wall(3.0)
    pose = session.pose()
    far = max(GOALS, key=lambda g: math.dist(g, (pose.x, pose.y)))
    goal = session.send_goal(Pose2D(far[0], far[1], 0.0, "probe"))
    before = rss_mb(pid)
    messages = hostile_messages("map", pose.x + math.cos(pose.yaw), pose.y + math.sin(pose.yaw))
    for what, raw in messages:
        missed, periods = flood(session, publisher, raw, watch)
        rows.append((f"/move_base/TebLocalPlannerROS/obstacles {FLOOD_HZ:g} Hz, {FLOOD_S:g} s", what,
                     f"{missed} of ~{periods} control periods missed, VmRSS {rss_mb(pid):.0f} MB",
                     missed <= MISSED_SHARE * periods))
    after = rss_mb(pid)
    flood(session, publisher, messages[1][1], watch)
    again = rss_mb(pid)
    rows.append(("move_base memory over the floods", f"VmRSS before {before:.0f} MB",
                 f"after {after:.0f} MB, after another 100,000-obstacle flood {again:.0f} MB",
                 after - before <= MEMORY_BOUND_MB and again - after <= MEMORY_REPEAT_MB))
    session.spin_wall(120.0, lambda: goal.done)
    rows.append(("the goal during the floods", f"({far[0]}, {far[1]})", f"{goal.status} {goal.reason}".strip(),
                 goal.status == "SUCCEEDED"))

    client = ActionClient(node, NavigateToPose, "/navigate_to_pose", goal_service_qos_profile=SERVICE_QOS,
                          result_service_qos_profile=SERVICE_QOS, cancel_service_qos_profile=SERVICE_QOS)
    request = NavigateToPose.Goal(pose=PoseStamped())
    request.pose.header.frame_id = "map"
    here = session.pose()
    request.pose.pose.position.x, request.pose.pose.position.y = here.x, here.y
    request.pose.pose.orientation.w = 1.0
    sent = client.send_goal_async(request) if client.wait_for_server(timeout_sec=10.0) else None
    if sent is not None and session.spin_wall(30.0, sent.done) and sent.result().accepted:
        answered = burst(session, [sent.result().cancel_goal_async() for _ in range(BURST)])
        rows.append(("/navigate_to_pose cancels at once", f"{BURST} cancel requests", f"{answered} answered",
                     answered == BURST))
    else:
        rows.append(("/navigate_to_pose cancels at once", f"{BURST} cancel requests", "no goal accepted", False))
    client.destroy()
    service = node.create_client(Empty, "/move_base/clear_costmaps", qos_profile=SERVICE_QOS)
    answered = burst(session, [service.call_async(Empty.Request()) for _ in range(BURST)]) \
        if service.wait_for_service(timeout_sec=10.0) else 0
    rows.append(("/move_base/clear_costmaps calls at once", f"{BURST} calls", f"{answered} answered",
                 answered == BURST))
    node.destroy_client(service)
    node.destroy_publisher(publisher)
    rows.append(("move_base after its probes", f"pid {pid}", f"pid {session.node_pid('move_base')}",
                 session.node_pid("move_base") == pid))
    session.spin_wall(3.0)
    return rows
