"""Record every topic of a run to MCAP, and plot a recorded run: the command line and the launcher's
--record entry around ros/tools/recorder.py and launch/recording_plot.py.

    python -m simplebot_navigation.launch navigation --record run.mcap      # with the launcher
    python -m simplebot_navigation.launch.record run.mcap                  # join a running system
    python -m simplebot_navigation.launch.record --plot run.mcap run.png   # map, trajectory, plans
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rclpy.utilities import remove_ros_args

from simplebot_navigation.launch.loader import LaunchError, NodeSpec
from simplebot_navigation.ros.tools.recorder import Recorder
from simplebot_navigation.launch.recording_plot import plot_recording


def recorder_spec(path: str):
    """The launcher's node entry for --record: runs Recorder as one more node of the launch file."""
    target = Path(path).expanduser().resolve()
    if not target.parent.is_dir():
        raise LaunchError(f"--record {path}: folder {target.parent} does not exist")
    if target.suffix != ".mcap":
        raise LaunchError(f"--record {path}: the file name must end in .mcap")
    return NodeSpec(pkg="python", type=f"{Recorder.__module__}:Recorder", name="recorder", namespace="/", output="screen",
                    respawn=False, respawn_delay=0.0, required=False, parameters={"path": str(target)})


# -- command line -----------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    parser = argparse.ArgumentParser(prog="python -m simplebot_navigation.launch.record",
                                     description="record all topics to MCAP, or plot a recorded run")
    parser.add_argument("--plot", nargs=2, metavar=("RUN.mcap", "OUT.png"), help="render a recorded run to PNG")
    parser.add_argument("path", nargs="?", help="the .mcap file to record to (or the 'path' parameter)")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    if opts.plot:
        try:
            summary = plot_recording(*opts.plot)
        except (FileNotFoundError, ValueError) as err:
            print(f"record: {err}", file=sys.stderr)
            return 2
        print(f"wrote {opts.plot[1]}: " + ", ".join(f"{k} {v}" for k, v in summary.items()))
        return 0

    from simplebot_navigation.ros.node_main import run_node
    return run_node("recorder", lambda: Recorder(path=opts.path), argv)


if __name__ == "__main__":
    sys.exit(main())
