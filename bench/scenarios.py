"""Navigation scenarios: success, time to goal, path, collisions, clearance, replans, recoveries, cycle p95.

    python bench/scenarios.py --world lab --json lab.json --plot lab.png
    python bench/scenarios.py --world doors --robot round --goals door_1.5x --repeat 5
    python bench/scenarios.py --world clutter --repeat 10     (seeds 0..9, one world each)

The same command as ``python -m simplebot_navigation.scenarios`` (see its --help): simulator and
move_base in one process, lockstep unless --rtf is given, so the numbers do not depend on how busy
the machine is, except the controller cycle time (wall clock), which is reported as p95.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from simplebot_navigation.scenarios.__main__ import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
