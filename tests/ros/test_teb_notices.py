"""TEB's notices reach the ROS log at their own severity, in any order."""

import rclpy.logging

from simplebot_navigation.ros.move_base.local_planner_shell import log_notices


def test_warnings_and_infos_alternate_without_upsetting_rclpys_logger(capfd):
    logger = rclpy.logging.get_logger("teb_notices_test")
    for _ in range(2):
        log_notices(logger, [("warn", "TEB: possible oscillation"), ("info", "TEB: oscillation recovery expired")])
    err = capfd.readouterr().err
    assert err.count("[WARN]") == 2 and err.count("[INFO]") == 2
