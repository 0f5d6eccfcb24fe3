"""move_base's own front door: /move_base_simple/goal and the MoveBase action. Each goal's pose is checked once
(GoalCheck) and the goal handed to the GoalArbiter; one that fails the check still preempts the active goal and ends
aborted, as ROS 1's move_base does."""

from __future__ import annotations

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from geometry_msgs.msg import PoseStamped
from rclpy.task import Future

from move_base_msgs.action import MoveBase
from simplebot_navigation.ros.conversions import xyyaw_to_pose
from simplebot_navigation.ros.move_base.move_base_goal import MoveBaseGoal


class MoveBaseFrontDoor:
    """The simple goal's callback and the MoveBase action's execute callback (the node subscribes and serves them);
    they get the arbiter and the GoalCheck, whose frame the feedback is in."""

    def __init__(self, arbiter, check):
        self.arbiter, self.check = arbiter, check

    def submit(self, goal: MoveBaseGoal) -> None:
        target, reason, cause = self.check(goal.pose)
        if reason is None:
            self.arbiter.submit(goal, target)
        else:
            self.arbiter.reject(goal, reason, cause)

    def on_simple_goal(self, msg: PoseStamped) -> None:
        self.submit(MoveBaseGoal(msg))

    async def execute(self, handle):
        goal = MoveBaseGoal(handle.request.target_pose, handle,
                            feedback=lambda pose: handle.publish_feedback(self._feedback(pose)))
        goal.done = Future()
        self.submit(goal)
        status = await goal.done
        if status == ActionlibStatus.SUCCEEDED:
            handle.succeed()
        elif status == ActionlibStatus.PREEMPTED and handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        return MoveBase.Result()

    def _feedback(self, pose) -> MoveBase.Feedback:
        feedback = MoveBase.Feedback()
        feedback.base_position.header.frame_id = self.check.frame
        feedback.base_position.header.stamp = pose.stamp.to_msg()
        feedback.base_position.pose = xyyaw_to_pose(*pose[:3])
        return feedback
