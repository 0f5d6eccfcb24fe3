"""A broken $(eval ...) in a launch file is the launcher's one-line error, not a Python traceback."""

import textwrap

import pytest

from simplebot_navigation.launch.__main__ import main


@pytest.mark.parametrize("expression, message", [
    ("robot ==", "$(eval robot ==) is not a valid expression: invalid syntax"),
    ("robot == 'box' and", "$(eval robot == 'box' and) is not a valid expression: invalid syntax"),
    ("speed == 'fast'", "$(eval speed == 'fast'): 'speed' is not a declared argument"),
    ("robot in 3", "$(eval robot in 3): TypeError: argument of type 'int' is not iterable"),
])
def test_a_broken_eval_is_one_line(tmp_path, capsys, expression, message):
    launch = tmp_path / "eval_launch.py"
    launch.write_text(textwrap.dedent(f"""
        from simplebot_navigation.launch.description import Arg, Node, Param
        LAUNCH = [Arg("robot", default="box"),
                  Node(pkg="python", type="tests.launch.dummy_node", name="n",
                       params=[Param("round", "$(eval {expression})")])]
    """))
    assert main([str(launch), "--print-params"]) == 2
    out = capsys.readouterr()
    assert out.err.splitlines() == [f"[launch] error: {launch}: {message}"]
    assert out.out == ""
