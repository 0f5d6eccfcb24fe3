"""Fixtures shared by the tests: a ROS domain of each test's own, and a check that nothing is left behind.

Every test module leases a ROS domain id for itself (the campaign workers' lock-file lease), and every test
leases one more for itself unless the module's own fixtures already run ROS (a context, a node or a process
made before the test), in which case the test shares the module's domain. Nodes, contexts and processes
(in-process rclpy, launched stacks, `ros2`-style helpers) therefore never see another test's graph or the
ghosts of its killed processes. After each test, and after each module, whatever it started and left running
fails it: a node not destroyed, a context not shut down, a child process still alive. The leftovers are then
stopped, so one leaky test does not spoil the next.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.util
import os
import signal
import sys
import time
import weakref
from pathlib import Path

import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node

from simplebot_navigation.scenarios.campaign.execution import DOMAIN_IDS, domain_lease

#: the domain of the whole pytest process (conftest.py at the root, or CI's): leased domains avoid it
SESSION_DOMAIN = int(os.environ["ROS_DOMAIN_ID"])
#: how long a test's processes may take to exit after its teardown before they count as left behind
EXIT_GRACE_S = 5.0
PR_SET_CHILD_SUBREAPER = 36

# Processes orphaned by a test (a launcher killed before its nodes) are re-parented to this process rather than
# to init, so that the check below still sees them.
with contextlib.suppress(OSError, AttributeError):
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)

#: test folders whose modules run whole stacks (lockstep sessions, launched processes) for tens of seconds each: they
#: are collected first. The README's command deals modules out to a worker per core in collection order
#: (--dist loadscope), so a long module dealt last keeps the other worker idle until it ends; longest first, the
#: short unit modules fill the gaps at the end
LONG_FIRST = ("e2e", "reliability", "scenarios", "network", "launch")


def pytest_collection_modifyitems(session, config, items):
    """Modules of the LONG_FIRST folders first, in that order; everything else after them, as collected."""
    def rank(item) -> int:
        parts = Path(str(item.fspath)).relative_to(Path(__file__).parent).parts
        return LONG_FIRST.index(parts[0]) if len(parts) > 1 and parts[0] in LONG_FIRST else len(LONG_FIRST)
    items.sort(key=rank)


@pytest.fixture(scope="module")
def bench(request):
    """The benchmark script bench/<BENCH>.py of the checkout, for a test module that sets ``BENCH``: a test of
    what the benchmark computes (its scores, its command line) without running it from a shell."""
    name = request.module.BENCH
    spec = importlib.util.spec_from_file_location(f"bench_{name}", Path(__file__).parents[1] / "bench" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module            # its dataclasses look their module up
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules[spec.name]


_contexts: weakref.WeakSet[Context] = weakref.WeakSet()
_nodes: weakref.WeakSet[Node] = weakref.WeakSet()
_context_init, _node_init = Context.init, Node.__init__


def _tracked_context_init(self, *args, **kwargs):
    _context_init(self, *args, **kwargs)
    _contexts.add(self)


def _tracked_node_init(self, *args, **kwargs):
    _node_init(self, *args, **kwargs)
    _nodes.add(self)


Context.init = _tracked_context_init
Node.__init__ = _tracked_node_init


def _node_alive(node: Node) -> bool:
    try:
        with node.handle:
            pass
    except Exception:  # noqa: BLE001 - InvalidHandle, or a node whose construction failed half-way
        return False
    return node.context.ok()


def _descendants() -> dict[int, str]:
    """pid -> command line of every live (not zombie) process below this one."""
    found: dict[int, str] = {}
    todo = [os.getpid()]
    while todo:
        pid = todo.pop()
        for children in Path(f"/proc/{pid}/task").glob("*/children"):
            with contextlib.suppress(OSError):
                for child in map(int, children.read_text().split()):
                    if child not in found and process_running(child):
                        found[child] = _command_line(child)
                        todo.append(child)
    return found


def process_running(pid: int) -> bool:
    """Whether pid runs: a zombie (reaped here if it is an orphan handed to this process) does not."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    if state == "Z":
        with contextlib.suppress(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)   # an orphan re-parented here: nobody else will reap it
        return False
    return True


def _command_line(pid: int) -> str:
    with contextlib.suppress(OSError):
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()[:160]
    return "?"


class _Running:
    """What runs ROS or processes at one moment: the baseline a test's leftovers are measured against."""

    def __init__(self):
        self.contexts = {id(c) for c in _contexts if c.ok()}
        self.nodes = {id(n) for n in _nodes if _node_alive(n)}
        self.processes = set(_descendants())

    @property
    def empty(self) -> bool:
        return not (self.contexts or self.nodes or self.processes)

    def leftovers_since(self, grace_s: float) -> list[str]:
        """Name, stop and report what was started after this baseline and still runs."""
        deadline = time.monotonic() + grace_s
        while (processes := {p: c for p, c in _descendants().items() if p not in self.processes}) \
                and time.monotonic() < deadline:
            time.sleep(0.05)
        found = [f"process {pid}: {command}" for pid, command in processes.items()]
        for pid in processes:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        for node in [n for n in _nodes if id(n) not in self.nodes and _node_alive(n)]:
            found.append(f"node {node.get_fully_qualified_name()}")
            with contextlib.suppress(Exception):
                node.destroy_node()
        for context in [c for c in _contexts if id(c) not in self.contexts and c.ok()]:
            found.append(f"rclpy context in ROS domain {context.get_domain_id()}")
            context.try_shutdown()
        return found


_next_domain = SESSION_DOMAIN + 1


@contextlib.contextmanager
def _own_domain():
    """Lease a domain id and make it this process's (and its children's) ROS_DOMAIN_ID for the block.

    Leases go round the whole range, so a domain is used again only after a hundred others: long after the
    ghosts of processes killed in it have timed out of DDS discovery."""
    global _next_domain
    with domain_lease(_next_domain % len(DOMAIN_IDS), SESSION_DOMAIN) as domain:
        _next_domain = domain + 1
        previous = os.environ["ROS_DOMAIN_ID"]
        os.environ["ROS_DOMAIN_ID"] = str(domain)
        try:
            yield domain
        finally:
            os.environ["ROS_DOMAIN_ID"] = previous


@pytest.fixture(scope="module", autouse=True)
def ros_domain_of_module():
    """The module's ROS domain, for its module-scoped fixtures; they must stop everything by the module's end."""
    baseline = _Running()
    with _own_domain() as domain:
        yield domain
        left = baseline.leftovers_since(EXIT_GRACE_S)
    if left:
        pytest.fail("the module's fixtures left running: " + "; ".join(left))


@pytest.fixture(autouse=True)
def ros_domain(ros_domain_of_module):
    """The test's ROS domain: its own, unless the module's fixtures already run ROS nodes or processes."""
    baseline = _Running()
    with _own_domain() if baseline.empty else contextlib.nullcontext(ros_domain_of_module) as domain:
        yield domain
        left = baseline.leftovers_since(EXIT_GRACE_S)
    if left:
        pytest.fail("the test left running: " + "; ".join(left))


def fresh_context():
    """An rclpy Context of the test's own, shut down afterwards (the default context stays untouched)."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    ctx.try_shutdown()


@pytest.fixture(scope="module")
def context():
    yield from fresh_context()

