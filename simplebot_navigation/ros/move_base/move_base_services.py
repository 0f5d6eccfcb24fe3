"""move_base's own services: make_plan (ROS 1's planService) and clear_costmaps."""

from __future__ import annotations

from nav_msgs.srv import GetPlan
from std_srvs.srv import Empty

from simplebot_navigation.ros.conversions import path_msg
from simplebot_navigation.ros.move_base.move_base_goal import plan_request
from simplebot_navigation.ros.qos import SERVICE_QOS


def serve_move_base_services(node) -> None:
    """``~/make_plan`` and ``~/clear_costmaps`` on the move_base node."""

    def make_plan(request: GetPlan.Request, response: GetPlan.Response) -> GetPlan.Response:
        """Refused while a goal is active; the request is read by plan_request, the rule of the planner's own
        make_plan."""
        frame = node.global_costmap.global_frame
        response.plan.header.frame_id = frame
        if node.goal is not None:
            node.get_logger().error("move_base must be in an inactive state to make a plan for an external user")
            return response
        try:
            start, goal, tolerance = plan_request(request, node.global_costmap)
        except ValueError as err:
            node.get_logger().error(f"make_plan: {err}")
            return response
        result = node.planner.make_plan(start, goal, tolerance)
        if result.ok:
            response.plan = path_msg(result.poses, frame, node.get_clock().now().to_msg())
        return response

    def clear_costmaps(_request, response):
        for costmap in (node.global_costmap, node.local_costmap):
            with costmap.lock:
                costmap.reset_layers()
        node.get_logger().info("costmaps cleared")
        return response

    node.create_service(GetPlan, "~/make_plan", make_plan, qos_profile=SERVICE_QOS)
    node.create_service(Empty, "~/clear_costmaps", clear_costmaps, qos_profile=SERVICE_QOS)
