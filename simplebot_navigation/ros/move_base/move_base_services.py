"""move_base's own services: make_plan (ROS 1's planService) and clear_costmaps."""

from __future__ import annotations

from nav_msgs.srv import GetPlan

from simplebot_navigation.ros.conversions import path_msg
from simplebot_navigation.ros.move_base.move_base_goal import plan_request


class MoveBaseServices:
    """The handlers of ``~/make_plan`` and ``~/clear_costmaps``; the node serves them. They get the GoalArbiter
    (no plan for others while a goal is active), the global planner, both costmaps, the node's clock and logger."""

    def __init__(self, arbiter, planner, global_costmap, local_costmap, clock, logger):
        self._arbiter, self._planner = arbiter, planner
        self._global, self._local = global_costmap, local_costmap
        self._clock, self._log = clock, logger

    def make_plan(self, request: GetPlan.Request, response: GetPlan.Response) -> GetPlan.Response:
        """Refused while a goal is active; the request is read by plan_request, the rule of the planner's own
        make_plan."""
        frame = self._global.global_frame
        response.plan.header.frame_id = frame
        if self._arbiter.active is not None:
            self._log.error("move_base must be in an inactive state to make a plan for an external user")
            return response
        try:
            start, goal, tolerance = plan_request(request, self._global)
        except ValueError as err:
            self._log.error(f"make_plan: {err}")
            return response
        result = self._planner.make_plan(start, goal, tolerance)
        if result.ok:
            response.plan = path_msg(result.poses, frame, self._clock.now().to_msg())
        return response

    def clear_costmaps(self, _request, response):
        for costmap in (self._global, self._local):
            with costmap.lock:
                costmap.reset_layers()
        self._log.info("costmaps cleared")
        return response
