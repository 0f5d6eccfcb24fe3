"""Scenario runner: simulator + move_base in this process, a list of goals, and how each went.

``python -m simplebot_navigation.scenarios --help``; the same from Python::

    results, worlds = run_scenarios(ScenarioOptions(world="lab", goals="nw_office;library"))
"""

from simplebot_navigation.scenarios.runner import (GoalResult, ScenarioOptions, parse_goals, run_goal, run_scenarios,
                                                   time_budget)
from simplebot_navigation.scenarios.process_session import ProcessSession, RemoteSession
from simplebot_navigation.scenarios.session import GoalRun, NavigationSession

__all__ = ["GoalResult", "GoalRun", "NavigationSession", "ProcessSession", "RemoteSession", "ScenarioOptions",
           "parse_goals", "run_goal", "run_scenarios", "time_budget"]
