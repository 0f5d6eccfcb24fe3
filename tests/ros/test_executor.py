"""The lean executor keeps rclpy's behaviour: timers, subscriptions, services, actions, coroutines, entities
added while it spins, and exceptions from callbacks; on an rclpy whose internals differ it is rclpy's own."""

import time

import pytest
from std_srvs.srv import SetBool
from rclpy.action import ActionClient, ActionServer
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String

from move_base_msgs.action import MoveBase
from simplebot_navigation.ros.executor import LeanExecutor, rclpy_differences

WARNING = "rclpy differs from what LeanExecutor relies on"


@pytest.fixture
def nodes(context):
    server, client = Node("lean_server", context=context), Node("lean_client", context=context)
    executor = LeanExecutor(context=context)
    executor.add_node(server)
    helper = SingleThreadedExecutor(context=context)   # the other side runs on rclpy's own executor
    helper.add_node(client)
    yield server, client, executor, helper
    executor.shutdown()
    helper.shutdown()
    server.destroy_node()
    client.destroy_node()


def spin_both(executor, helper, until, seconds=5.0):
    end = time.monotonic() + seconds
    while time.monotonic() < end and not until():
        executor.spin_once(timeout_sec=0.01)
        helper.spin_once(timeout_sec=0.0)
    return until()


def test_timers_subscriptions_and_entities_added_while_spinning(nodes):
    server, client, executor, helper = nodes
    ticks, heard, late = [], [], []
    server.create_timer(0.01, lambda: ticks.append(1))
    server.create_subscription(String, "lean_chatter", lambda m: heard.append(m.data), 10)
    pub = client.create_publisher(String, "lean_chatter", 10)
    assert spin_both(executor, helper, lambda: len(ticks) >= 5)
    assert spin_both(executor, helper, lambda: (pub.publish(String(data="hi")), bool(heard))[1])
    server.create_subscription(String, "lean_late", lambda m: late.append(m.data), 10)   # while spinning
    late_pub = client.create_publisher(String, "lean_late", 10)
    assert spin_both(executor, helper, lambda: (late_pub.publish(String(data="late")), bool(late))[1])


def test_a_coroutine_subscription_callback_runs_to_completion(nodes):
    server, client, executor, helper = nodes
    done = []

    async def callback(msg):
        done.append(msg.data)
    server.create_subscription(String, "lean_async", callback, 10)
    pub = client.create_publisher(String, "lean_async", 10)
    assert spin_both(executor, helper, lambda: (pub.publish(String(data="x")), bool(done))[1])


def test_services_and_actions_are_answered(nodes):
    server, client, executor, helper = nodes
    def answer(request, response):
        response.success, response.message = True, f"asked {request.data}"
        return response
    server.create_service(SetBool, "lean_set", answer)
    cli = client.create_client(SetBool, "lean_set")
    assert spin_both(executor, helper, cli.service_is_ready)
    future = cli.call_async(SetBool.Request(data=True))
    assert spin_both(executor, helper, future.done) and future.result().message == "asked True"

    async def execute(handle):
        handle.succeed()
        return MoveBase.Result()
    ActionServer(server, MoveBase, "lean_action", execute_callback=execute, callback_group=ReentrantCallbackGroup())
    action = ActionClient(client, MoveBase, "lean_action")
    assert spin_both(executor, helper, action.server_is_ready)
    sent = action.send_goal_async(MoveBase.Goal())
    assert spin_both(executor, helper, sent.done) and sent.result().accepted
    result = sent.result().get_result_async()
    assert spin_both(executor, helper, result.done) and result.result().status == 4    # SUCCEEDED


def test_an_exception_in_a_callback_reaches_the_spinner(nodes):
    server, _, executor, _ = nodes

    def boom():
        raise RuntimeError("timer failed")
    server.create_timer(0.01, boom)
    with pytest.raises(RuntimeError, match="timer failed"):
        for _ in range(100):
            executor.spin_once(timeout_sec=0.05)


@pytest.fixture
def rclpy_patch(monkeypatch):
    """A monkeypatch whose changes to rclpy the executor's check sees, and forgets once they are undone."""
    rclpy_differences.cache_clear()
    yield monkeypatch
    monkeypatch.undo()
    rclpy_differences.cache_clear()


def test_the_installed_rclpy_has_the_internals_the_executor_relies_on(context, rclpy_patch, capfd):
    assert rclpy_differences() == ()
    executor = LeanExecutor(context=context)
    assert type(executor) is LeanExecutor
    executor.shutdown()
    assert WARNING not in capfd.readouterr().err


@pytest.mark.parametrize("change, named", [
    (lambda patch: patch.delattr(Executor, "_make_handler"), "no Executor._make_handler"),
    (lambda patch: patch.setattr(Executor, "_take_timer", lambda self: None),
     "Executor._take_timer does not take 1 positional argument"),
    (lambda patch: patch.setattr(SingleThreadedExecutor, "_spin_once_impl", lambda self, timeout_sec=None: None),
     "SingleThreadedExecutor._spin_once_impl is not (self, timeout_sec, wait_condition)"),
    (lambda patch: patch.setattr(Node, "_wake_executor", lambda self: None), "Node._wake_executor does not use wake"),
], ids=["missing", "signature", "override", "no wake-up"])
def test_an_rclpy_with_other_internals_gets_its_own_executor_and_one_warning(context, rclpy_patch, capfd, change,
                                                                             named):
    change(rclpy_patch)
    executors = [LeanExecutor(context=context) for _ in range(3)]
    assert [type(e) for e in executors] == [SingleThreadedExecutor] * 3
    for executor in executors:
        executor.shutdown()
    warnings = [line for line in capfd.readouterr().err.splitlines() if WARNING in line]
    assert len(warnings) == 1 and named in warnings[0], warnings
