"""Run a node module as a child of the launcher: ``python -m simplebot_navigation.launch.child <module> ...``.

The child asks the kernel for SIGTERM when its parent dies (Linux PR_SET_PDEATHSIG), so even a
launcher killed with SIGKILL leaves no orphaned nodes behind.
"""

import ctypes
import os
import runpy
import signal
import sys

PR_SET_PDEATHSIG = 1


def main() -> None:
    launcher_pid = int(os.environ.get("SIMPLEBOT_LAUNCHER_PID", "0"))
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        pass  # not Linux: the launcher's own shutdown still stops its children
    if launcher_pid and os.getppid() != launcher_pid:
        sys.exit(1)  # the launcher died before the request above took effect
    module = sys.argv[1]
    sys.argv = [module] + sys.argv[2:]
    runpy.run_module(module, run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
