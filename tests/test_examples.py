"""The user examples in examples/: they start, say how to use them, and use ROS's own packages only (a Nav2
user's code knows nothing of simplebot_navigation). What they do against a running stack is what
tests/e2e/test_nav2_clients.py checks with the same kind of client."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))
#: what an example may import besides the standard library
ROS_PACKAGES = {"rclpy", "action_msgs", "builtin_interfaces", "geometry_msgs", "lifecycle_msgs", "nav2_msgs",
                "nav_msgs", "std_msgs"}


def test_there_are_examples():
    assert EXAMPLES


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_an_example_imports_only_ros_packages(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    imported = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
                for alias in node.names}
    imported |= {node.module.split(".")[0] for node in ast.walk(tree)
                 if isinstance(node, ast.ImportFrom) and node.module and not node.level}
    foreign = imported - ROS_PACKAGES - set(sys.stdlib_module_names) - {"__future__"}
    assert not foreign, f"{path.name} imports {sorted(foreign)}"
    assert any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body), f"{path.name}: no main()"


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_an_example_prints_its_usage(path):
    out = subprocess.run([sys.executable, str(path), "--help"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "usage:" in out.stdout and "simplebot_navigation.launch" in out.stdout
