"""What bench/probe.py and the area probes share (a module whose name starts with _ is no area of its own)."""

from __future__ import annotations

ANSWER_S = 30.0


def set_parameters(session, client, params: list) -> list:
    """Set rclpy Parameters through a parameter client, spinning the session; their SetParametersResults, or []
    when the node did not answer within ANSWER_S."""
    future = client.set_parameters(params)
    if not session.spin_wall(ANSWER_S, future.done):
        return []
    return list(future.result().results)


def set_parameter(session, client, name, value) -> tuple[bool, str]:
    """(accepted, reason) of one parameter set."""
    from rclpy.parameter import Parameter

    results = set_parameters(session, client, [Parameter(name, value=value)])
    if not results:
        return False, f"NO ANSWER within {ANSWER_S:g} s"
    return results[0].successful, results[0].reason
