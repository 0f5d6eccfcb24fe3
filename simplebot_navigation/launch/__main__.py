"""python -m simplebot_navigation.launch <launch-file> [arg:=value | --arg value ...]"""

from __future__ import annotations

import argparse
import sys

from simplebot_navigation import paths
from simplebot_navigation.launch.loader import LaunchError, declared_args, load_launch
from simplebot_navigation.launch.overrides import apply_set, speed_assignments
from simplebot_navigation.launch.rosparam import ParamError

USAGE = """python -m simplebot_navigation.launch <launch-file> [options] [arg:=value ...]

Launch files are read from launch_py/ (see --list) or given as a path.
Launch arguments can be given as name:=value (as roslaunch) or as --name value;
a flag without a value (--viewer) means true."""


def _split_launch_args(tokens: list[str], declared: set[str]) -> dict[str, str]:
    args: dict[str, str] = {}
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if ":=" in token:
            name, _, value = token.partition(":=")
        elif token.startswith("--"):
            name, eq, value = token[2:].partition("=")
            if not eq:
                if i + 1 < len(tokens) and not tokens[i + 1].startswith("--") and ":=" not in tokens[i + 1]:
                    value = tokens[i + 1]
                    i += 1
                else:
                    value = "true"
        else:
            raise LaunchError(f"unexpected argument {token!r} (use name:=value or --name value)")
        name = name.replace("-", "_")
        if name not in declared:
            raise LaunchError(f"unknown launch argument {name!r}; this launch file takes: "
                              f"{', '.join(sorted(declared)) or 'none'}")
        args[name] = value
        i += 1
    return args


def _print_params(config) -> None:
    print("# ROS 1 parameter tree (as roslaunch builds it)")
    for name, value in config.params.items("/"):
        print(f"{name}: {value!r}")
    for node in config.nodes:
        print(f"\n# ROS 2 parameters of {node.full_name} ({node.pkg}/{node.type}); remaps: "
              + (", ".join(f"{a}:={b}" for a, b in node.remaps) or "none"))
        for name, value in node.parameters.items():
            print(f"{name}: {value!r}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m simplebot_navigation.launch", usage=USAGE, add_help=False)
    parser.add_argument("launch_file", nargs="?")
    parser.add_argument("-h", "--help", action="store_true", help="show this help (and the launch file's arguments)")
    parser.add_argument("--list", action="store_true", help="list the launch files")
    parser.add_argument("--print-params", action="store_true", help="print the parameters each node gets, then exit")
    parser.add_argument("--single-process", action="store_true", help="run all nodes in this process, one executor")
    parser.add_argument("--record", metavar="FILE.mcap", help="record every topic of the run to an MCAP file")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="a move_base parameter by its ROS 2 name, e.g. TebLocalPlannerROS.max_vel_x=0.6 "
                             "(repeatable; checked like the parameter files)")
    parser.add_argument("--keep-run-dir", action="store_true",
                        help="keep the run directory (simplebot_launch_* in the system temp folder: each node's "
                             "parameter file, and the output of output=\"log\" nodes); without this option it is "
                             "removed on exit, unless output=\"log\" nodes wrote to it")
    opts, rest = parser.parse_known_args(argv)

    if opts.list:
        for name in paths.launch_files():
            print(name)
        return 0
    if opts.launch_file is None:
        parser.print_help()
        return 0 if opts.help else 2
    try:
        path = paths.launch_file(opts.launch_file)
        declared = declared_args(path)
        if opts.help:
            parser.print_help()
            print(f"\narguments of {opts.launch_file}:")
            for arg in declared:
                default = f" (default: {arg.default})" if arg.default is not None else " (required)"
                print(f"  {arg.name}:=VALUE  {arg.doc}{default}")
            return 0
        config = load_launch(path, _split_launch_args(rest, {a.name for a in declared}))
        derived, speed_report = speed_assignments(config, opts.set)
        apply_set(config, derived + opts.set)      # an explicit --set wins over what max_speed derived
        if not opts.print_params:
            for line in speed_report:
                print(f"[launch] {line}", file=sys.stderr)
        if opts.record:
            from simplebot_navigation.launch.record import recorder_spec
            config.nodes.insert(0, recorder_spec(opts.record))  # first up, so it misses the least
    except (LaunchError, ParamError, FileNotFoundError) as err:
        print(f"[launch] error: {err}", file=sys.stderr)
        return 2
    if opts.print_params:
        for line in speed_report:
            print(f"# {line}")
        if opts.set:
            print("# --set " + " --set ".join(opts.set))
        _print_params(config)
        return 0
    if opts.single_process:
        from simplebot_navigation.launch.runner import run_single_process
        return run_single_process(config, opts.keep_run_dir)
    from simplebot_navigation.launch.runner import ProcessLauncher
    return ProcessLauncher(config, opts.keep_run_dir).run()


if __name__ == "__main__":
    sys.exit(main())
