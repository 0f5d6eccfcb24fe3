"""Where campaign runs execute: worker processes on this machine (--jobs N) or Ray tasks (--ray).

Either way each run is a fresh worker process (``campaign/worker.py``) with a ROS domain id of its own and
localhost-only discovery, set in its environment before Python starts. The domain id is leased
with a lock file on the host (``flock``), so runs that share a machine - threads of one campaign,
Ray tasks, or two campaigns at once - never share a domain. A run that exits without a result is
a crash, one that outlives its wall timeout is killed as hung; both come back as an error with the
tail of the run's log.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import fcntl
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections import deque
from typing import Iterator

from simplebot_navigation.scenarios.campaign.spec import Run

DOMAIN_IDS = range(0, 102)       # valid Fast DDS domain ids on one host
LOCK_FOLDER = os.path.join(tempfile.gettempdir(), "simplebot-ros-domains")
LEASE_POLL_S = 0.5
RAY_CONNECT_TIMEOUT_S = 30.0
LOG_TAIL_LINES = 30
WORKER_MODULE = ("-u", "-m", "simplebot_navigation.scenarios.campaign.worker")


class CampaignError(RuntimeError):
    """The campaign cannot run at all (no Ray, an unreachable cluster, a results file that does not fit)."""


@contextlib.contextmanager
def domain_lease(first: int, avoid: int | None) -> Iterator[int]:
    """Hold a ROS domain id no other run on this host holds, trying ``first`` and then the ones after it."""
    os.makedirs(LOCK_FOLDER, exist_ok=True)
    order = sorted((d for d in DOMAIN_IDS if d != avoid), key=lambda d: (d - first) % len(DOMAIN_IDS))
    while True:
        for domain in order:
            handle = open(os.path.join(LOCK_FOLDER, f"{domain}.lock"), "w")
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                handle.close()
                continue
            try:
                yield domain
            finally:
                handle.close()  # releases the lock
            return
        time.sleep(LEASE_POLL_S)


def parent_domain() -> int | None:
    value = os.environ.get("ROS_DOMAIN_ID", "")
    return int(value) if value.isdigit() else None


def run_isolated(run: dict, timeout_s: float, first_domain: int, avoid_domain: int | None,
                 command: tuple[str, ...] | None = None) -> dict:
    """One run in a fresh process; returns the worker's result, or ``error`` and ``log_tail``, and where it ran.

    ``command`` replaces the worker (tests); by default it is this host's Python, which on a Ray
    node need not be the driver's.
    """
    command = command or (sys.executable, *WORKER_MODULE)
    started = time.monotonic()
    with domain_lease(first_domain, avoid_domain) as domain, \
            tempfile.TemporaryDirectory(prefix="simplebot_campaign_run_") as folder:
        out, log_path = os.path.join(folder, "result.json"), os.path.join(folder, "run.log")
        # One CPU per run, as Ray gives its tasks: without the cap each run's BLAS/OpenMP threads fight the others'.
        env = {"OMP_NUM_THREADS": "1", **os.environ, "ROS_DOMAIN_ID": str(domain),
               "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
        with open(log_path, "w", encoding="utf-8") as log:
            process = subprocess.Popen([*command, json.dumps(run), out], stdout=log, stderr=subprocess.STDOUT,
                                       stdin=subprocess.DEVNULL, env=env)  # Ctrl-C reaches it too
        try:
            code = process.wait(timeout=timeout_s)
            error = None if code == 0 and os.path.exists(out) else (
                f"crashed: killed by signal {signal.Signals(-code).name}" if code < 0 else
                f"crashed: exit code {code}")
        except subprocess.TimeoutExpired:
            process.kill()  # the stack runs inside the worker itself: no children to reap
            process.wait()
            error = f"hung: no result within the {timeout_s:g} s run timeout, killed"
        where = {"host": socket.gethostname(), "domain_id": domain, "wall_s": round(time.monotonic() - started, 3)}
        if error is None:
            with open(out, encoding="utf-8") as handle:
                return {**json.load(handle), **where, "error": None}
        with open(log_path, encoding="utf-8", errors="replace") as log:
            tail = "".join(deque(log, maxlen=LOG_TAIL_LINES))
        return {**where, "error": error, "log_tail": tail}


class _Executor:
    """What both executors share: ``slots`` runs at a time, each in a fresh process with a leased domain."""

    slots: int

    def __init__(self, command: tuple[str, ...] | None):
        self.command = command
        self.avoid = parent_domain()
        self.submitted = 0

    def _arguments(self, run: Run, timeout_s: float) -> tuple:
        """run_isolated's arguments; the slots start their leases at successive ids just above the campaign's."""
        first = (self.avoid if self.avoid is not None else -1) + 1 + self.submitted % self.slots
        self.submitted += 1
        return run.to_dict(), timeout_s, first, self.avoid, self.command


class LocalExecutor(_Executor):
    """--jobs N: N threads on this machine, each waiting on one worker process at a time."""

    def __init__(self, jobs: int, command: tuple[str, ...] | None = None):
        super().__init__(command)
        self.slots = jobs
        self.pool = concurrent.futures.ThreadPoolExecutor(max_workers=jobs, thread_name_prefix="campaign")

    def submit(self, run: Run, timeout_s: float) -> concurrent.futures.Future:
        return self.pool.submit(run_isolated, *self._arguments(run, timeout_s))

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


def check_reachable(address: str, timeout_s: float = RAY_CONNECT_TIMEOUT_S) -> None:
    """CampaignError unless something accepts a connection at a Ray address (ray://host:port or host:port) within
    timeout_s: ray.init waits for ever on an address where nothing answers."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        raise CampaignError(f"--ray {address}: expected local, auto, host:port or ray://host:port")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except OSError as err:
        raise CampaignError(f"--ray {address}: nothing answers there within {timeout_s:g} s "
                            f"({err.strerror or err})") from err


class RayExecutor(_Executor):
    """--ray: one Ray task (one CPU) per run, on the cluster at ``address`` or a local Ray instance.

    'local' starts an embedded Ray; 'auto' joins the cluster this machine belongs to (or starts
    one if there is none); anything else is a cluster address (ray://host:10001 or host:6379).
    An already initialised Ray (a test's ``ray.init(num_cpus=2)``) is used as it is.
    """

    def __init__(self, address: str, command: tuple[str, ...] | None = None):
        try:
            import ray
        except ImportError as err:
            raise CampaignError("--ray: Ray is not installed; pip install -e '.[cluster]' "
                                "(or pip install 'ray[default]>=2.40,<3')") from err
        super().__init__(command)
        self.ray = ray
        self.started_ray = not ray.is_initialized()
        if self.started_ray:
            if address not in ("local", "auto"):
                check_reachable(address)
            try:
                ray.init(address=None if address == "auto" else address,
                         **({"include_dashboard": False} if address == "local" else {}))
            except (ConnectionError, RuntimeError, ValueError) as err:
                raise CampaignError(f"--ray {address}: {err}") from err
        self.slots = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self.task = ray.remote(num_cpus=1, max_retries=0, runtime_env={
            "env_vars": {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}})(run_isolated)

    def submit(self, run: Run, timeout_s: float) -> concurrent.futures.Future:
        return self.task.remote(*self._arguments(run, timeout_s)).future()

    def close(self) -> None:
        if self.started_ray:
            self.ray.shutdown()
