"""Start the nodes of a launch config: each in its own process (default) or all under one executor."""

from __future__ import annotations

import contextlib
import gc
import importlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import yaml

from simplebot_navigation.launch.loader import LaunchConfig, NodeSpec
from simplebot_navigation.launch.nodes import Executable, ExecutableNotFound, resolve_executable

SHUTDOWN_GRACE_S = 5.0
#: what a node's main() returns when it cannot be built from its parameters (ros/node_main.py: run_node)
EXIT_BAD_CONFIGURATION = 2
#: respawns are also counted over this window, so a node that keeps dying stands out in the log
RESPAWN_WINDOW_S = 60.0


def ros_args(spec: NodeSpec, params_file: str) -> list[str]:
    args = ["--ros-args", "-r", f"__node:={spec.name}", "-r", f"__ns:={spec.namespace}",
            "--params-file", params_file]
    for src, dst in spec.remaps:
        args += ["-r", f"{src}:={dst}"]
    return args


def write_params_file(spec: NodeSpec, folder: str) -> str:
    path = os.path.join(folder, f"{spec.full_name.strip('/').replace('/', '__') or 'root'}.params.yaml")
    with open(path, "w", encoding="utf-8") as handle:
        yaml.safe_dump({spec.full_name: {"ros__parameters": spec.parameters}}, handle, sort_keys=False)
    return path


def _log(message: str) -> None:
    print(f"[launch] {message}", flush=True)


@contextlib.contextmanager
def run_directory(keep: bool, logs: Callable[[], list[str]]) -> Iterator[str]:
    """A fresh simplebot_launch_* folder in the system temp folder for the nodes' parameter files.

    It is removed afterwards, unless the user asked to keep it or it holds the output of
    output="log" nodes (``logs()`` names those files), which would otherwise be lost.
    """
    path = tempfile.mkdtemp(prefix="simplebot_launch_")
    try:
        yield path
    finally:
        kept_logs = logs()
        if keep:
            _log(f"run directory kept: {path}")
        elif kept_logs:
            _log(f"node output kept in {path}: {', '.join(kept_logs)}")
        else:
            shutil.rmtree(path, ignore_errors=True)


@dataclass
class _Process:
    spec: NodeSpec
    command: list[str]
    popen: subprocess.Popen | None = None
    exit_code: int | None = None
    respawns: int = 0
    recent_respawns: deque = field(default_factory=deque)  # monotonic times within RESPAWN_WINDOW_S
    restart_at: float | None = None
    log_file: str | None = None
    threads: list[threading.Thread] = field(default_factory=list)


class ProcessLauncher:
    """roslaunch's process monitor: prefixed output, respawn, required nodes, clean shutdown."""

    def __init__(self, config: LaunchConfig, keep_run_dir: bool = False):
        self.config = config
        self.keep_run_dir = keep_run_dir
        self.run_dir = ""
        self.processes: list[_Process] = []
        self.missing: list[str] = []
        self._stop = threading.Event()
        self._print_lock = threading.Lock()

    def _prepare(self) -> None:
        for spec in self.config.nodes:
            try:
                exe = resolve_executable(spec.pkg, spec.type)
            except ExecutableNotFound as err:
                self.missing.append(f"{spec.full_name}: {err}")
                continue
            params_file = write_params_file(spec, self.run_dir)
            command = [sys.executable, "-u", "-m", "simplebot_navigation.launch.child", exe.module,
                       *ros_args(spec, params_file)]
            self.processes.append(_Process(spec, command))

    def _pump(self, proc: _Process, stream, sink) -> None:
        """Copy one run's output to the console or its log file; closes both ends when the run ends."""
        prefix = f"[{proc.spec.name}] "
        try:
            for raw in iter(stream.readline, b""):
                line = raw.decode("utf-8", "replace").rstrip("\n")
                with self._print_lock:
                    if sink is not None:
                        sink.write(line + "\n")
                        sink.flush()
                    else:
                        print(prefix + line, flush=True)
        finally:
            stream.close()
            if sink is not None:
                sink.close()

    def _start(self, proc: _Process) -> None:
        sink = None
        if proc.spec.output == "log":
            proc.log_file = os.path.join(self.run_dir, f"{proc.spec.name}.log")
            sink = open(proc.log_file, "a", encoding="utf-8")  # noqa: SIM115 - the pump closes it
        proc.popen = subprocess.Popen(proc.command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                      stdin=subprocess.DEVNULL, start_new_session=True,
                                      env={**os.environ, "SIMPLEBOT_LAUNCHER_PID": str(os.getpid()),
                                           "SIMPLEBOT_RUN_DIR": self.run_dir})
        proc.exit_code = None
        proc.restart_at = None
        thread = threading.Thread(target=self._pump, args=(proc, proc.popen.stdout, sink), daemon=True)
        thread.start()
        proc.threads = [thread]
        where = f", output in {proc.log_file}" if proc.log_file else ""
        _log(f"started {proc.spec.full_name} ({proc.spec.pkg}/{proc.spec.type}) pid {proc.popen.pid}{where}")

    def request_stop(self, *_args) -> None:
        self._stop.set()

    def run(self) -> int:
        """Run until Ctrl-C/SIGTERM or until every process has ended; the exit code says what failed."""
        with run_directory(self.keep_run_dir, self._log_files) as self.run_dir:
            return self._run()

    def _log_files(self) -> list[str]:
        return [os.path.basename(p.log_file) for p in self.processes if p.log_file]

    def _run(self) -> int:
        self._prepare()
        for message in self.missing:
            _log(f"NOT STARTED {message}")
        if not self.processes:
            _log("no node of this launch file can be started")
            return 2
        previous = {sig: signal.signal(sig, self.request_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
        failed: list[str] = []
        bad_configuration = False
        try:
            for proc in self.processes:
                self._start(proc)
            while not self._stop.is_set():
                alive = 0
                for proc in self.processes:
                    if proc.restart_at is not None:
                        alive += 1
                        if time.monotonic() >= proc.restart_at and not self._stop.is_set():
                            self._start(proc)
                        continue
                    if proc.popen is None or proc.exit_code is not None:
                        continue
                    code = proc.popen.poll()
                    if code is None:
                        alive += 1
                        continue
                    proc.exit_code = code
                    for thread in proc.threads:
                        thread.join(timeout=1.0)
                    _log(f"process {proc.spec.full_name} (pid {proc.popen.pid}) ended with exit code {code}")
                    if code == EXIT_BAD_CONFIGURATION:
                        # Respawning cannot mend a configuration: it would fail the same way for ever.
                        _log(f"{proc.spec.full_name} could not start with its configuration (exit code {code}): "
                             "not respawned; stopping the launch")
                        failed.append(f"{proc.spec.full_name} (configuration error)")
                        bad_configuration = True
                        self._stop.set()
                    elif proc.spec.respawn:
                        self._schedule_respawn(proc)
                        alive += 1
                    elif code != 0:
                        failed.append(f"{proc.spec.full_name} (exit code {code})")
                        if proc.spec.required:
                            _log(f"required node {proc.spec.full_name} ended: shutting down")
                            self._stop.set()
                if alive == 0:
                    break
                self._stop.wait(0.1)
        finally:
            self.shutdown()
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        if failed:
            _log("failed: " + ", ".join(failed))
            return EXIT_BAD_CONFIGURATION if bad_configuration else 1
        return 0

    def _schedule_respawn(self, proc: _Process) -> None:
        now = time.monotonic()
        proc.respawns += 1
        proc.recent_respawns.append(now)
        while now - proc.recent_respawns[0] > RESPAWN_WINDOW_S:
            proc.recent_respawns.popleft()
        _log(f"respawning {proc.spec.full_name} in {proc.spec.respawn_delay:.1f} s (respawn #{proc.respawns}, "
             f"{len(proc.recent_respawns)} in the last {RESPAWN_WINDOW_S:.0f} s)")
        proc.restart_at = now + proc.spec.respawn_delay

    def shutdown(self) -> None:
        """SIGINT to every process group, then SIGTERM, then SIGKILL: no orphans."""
        running = [p for p in self.processes if p.popen is not None and p.popen.poll() is None]
        for sig, grace in ((signal.SIGINT, SHUTDOWN_GRACE_S), (signal.SIGTERM, 2.0), (signal.SIGKILL, 1.0)):
            for proc in running:
                try:
                    os.killpg(proc.popen.pid, sig)
                except ProcessLookupError:
                    pass
            deadline = time.monotonic() + grace
            while running and time.monotonic() < deadline:
                running = [p for p in running if p.popen.poll() is None]
                time.sleep(0.05)
            if not running:
                break
            _log(f"{', '.join(p.spec.full_name for p in running)} still running after {sig.name}")
        for proc in self.processes:
            for thread in proc.threads:
                thread.join(timeout=1.0)


def run_single_process(config: LaunchConfig, keep_run_dir: bool = False) -> int:
    """All nodes in this process under one executor (for debugging and profiling)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from simplebot_navigation.ros.simulator.lockstep import LockstepDriver
    from simplebot_navigation.ros.node_main import stopped_by_ctrl_c

    classes: list[tuple[NodeSpec, type]] = []
    for spec in config.nodes:
        try:
            exe: Executable = resolve_executable(spec.pkg, spec.type)
        except ExecutableNotFound as err:
            _log(f"NOT STARTED {spec.full_name}: {err}")
            continue
        if exe.node_class is None:
            _log(f"NOT STARTED {spec.full_name}: {exe.module} runs only as its own process")
            continue
        classes.append((spec, getattr(importlib.import_module(exe.module), exe.node_class)))
    if not classes:
        _log("no node of this launch file can be started")
        return 2
    rclpy.init()
    executor = SingleThreadedExecutor()
    nodes = []
    try:
        with stopped_by_ctrl_c(), run_directory(keep_run_dir, list) as run_dir:
            for spec, cls in classes:
                node = cls(cli_args=ros_args(spec, write_params_file(spec, run_dir)), use_global_arguments=False)
                nodes.append(node)
                executor.add_node(node)
                _log(f"started {spec.full_name} in this process")
            # Start-up objects are long-lived: keep them out of full collections, which otherwise stall
            # every node in this process for tens of milliseconds.
            gc.freeze()
            lockstep = LockstepDriver.of(nodes)
            if lockstep is not None:
                _log("lockstep: the simulator steps whenever every node is idle (real_time_factor 0)")
            (lockstep or executor).spin()
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()  # Ctrl-C's handler may be shutting the context down at this very moment
    return 0
