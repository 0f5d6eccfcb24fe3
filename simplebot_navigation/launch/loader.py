"""Interpret a launch_py file with roslaunch semantics into node specs and a parameter tree."""

from __future__ import annotations

import ast
import math
import os
import re
import runpy
from dataclasses import dataclass, field
from typing import Any, Callable

from simplebot_navigation import paths
from simplebot_navigation.launch.description import Arg, Group, Include, Node, Param, RosParam
from simplebot_navigation.launch.rosparam import ParamError, ParamServer, join_ns, to_ros2_overrides


class LaunchError(RuntimeError):
    """A launch file that cannot be interpreted; the message says which file and what."""


@dataclass
class NodeSpec:
    pkg: str
    type: str
    name: str            # e.g. "move_base"
    namespace: str       # e.g. "/"
    output: str
    respawn: bool
    respawn_delay: float
    required: bool
    remaps: list[tuple[str, str]] = field(default_factory=list)
    parameters: dict[str, Any] = field(default_factory=dict)  # ROS 2 overrides

    @property
    def full_name(self) -> str:
        return join_ns(self.namespace, self.name)


@dataclass
class LaunchConfig:
    file: str
    args: dict[str, str]
    params: ParamServer
    nodes: list[NodeSpec]
    arg_docs: list[Arg]


_SUBST = re.compile(r"\$\((\w+)\s*([^)]*)\)")
_TRUTH = {"true": True, "1": True, "false": False, "0": False}


class _Context:
    def __init__(self, file: str, args: dict[str, str], ns: str, remaps: list[tuple[str, str]]):
        self.file = file
        self.args = args
        self.ns = ns
        self.remaps = remaps

    def subst(self, text: Any) -> Any:
        if not isinstance(text, str):
            return text

        def one(match: re.Match) -> str:
            kind, body = match.group(1), match.group(2).strip()
            if kind == "arg":
                if body not in self.args:
                    raise LaunchError(f"{self.file}: $(arg {body}) is not a declared argument")
                return str(self.args[body])
            if kind == "find":
                try:
                    return paths.package_share(body)
                except FileNotFoundError as err:
                    raise LaunchError(f"{self.file}: {err}") from None
            if kind == "env":
                if body not in os.environ:
                    raise LaunchError(f"{self.file}: $(env {body}): environment variable not set")
                return os.environ[body]
            if kind == "optenv":
                var, _, default = body.partition(" ")
                return os.environ.get(var, default)
            if kind == "eval":
                return str(self._eval(body))
            raise LaunchError(f"{self.file}: unknown substitution $({kind} ...)")
        return _SUBST.sub(one, text)

    def _eval(self, expr: str) -> Any:
        """roslaunch's $(eval): arguments are visible by name; only literals and comparisons are allowed.

        The expression is launch-file text: whatever is wrong with it is a LaunchError naming it.
        """
        try:
            tree = ast.parse(expr, mode="eval")
        except SyntaxError as err:
            raise LaunchError(f"{self.file}: $(eval {expr}) is not a valid expression: {err.msg}") from None
        allowed = (ast.Expression, ast.Compare, ast.BoolOp, ast.UnaryOp, ast.Name, ast.Constant, ast.Load,
                   ast.Eq, ast.NotEq, ast.And, ast.Or, ast.Not, ast.In, ast.NotIn, ast.Tuple, ast.List)
        for node in ast.walk(tree):
            if not isinstance(node, allowed):
                raise LaunchError(f"{self.file}: $(eval {expr}): only comparisons of arguments are supported")
        try:
            return eval(compile(tree, self.file, "eval"), {"__builtins__": {}}, dict(self.args))  # noqa: S307
        except NameError as err:
            raise LaunchError(f"{self.file}: $(eval {expr}): {err.name!r} is not a declared argument") from None
        except Exception as err:  # noqa: BLE001 - e.g. `in` on a non-container
            raise LaunchError(f"{self.file}: $(eval {expr}): {type(err).__name__}: {err}") from None

    def enabled(self, item: Any) -> bool:
        cond_if, cond_unless = getattr(item, "if_", None), getattr(item, "unless", None)
        for cond, want in ((cond_if, True), (cond_unless, False)):
            if cond is None:
                continue
            value = self.subst(cond).strip().lower()
            if value not in _TRUTH:
                raise LaunchError(f"{self.file}: condition {cond!r} evaluated to {value!r}, expected true or false")
            if _TRUTH[value] != want:
                return False
        return True

    def flag(self, value: Any, what: str) -> bool:
        """A boolean attribute (a bool, or text such as "$(arg respawn)")."""
        if isinstance(value, bool):
            return value
        text = str(self.subst(value))
        if text.strip().lower() not in _TRUTH:
            raise LaunchError(f"{self.file}: {what} {text!r} must be true or false")
        return _TRUTH[text.strip().lower()]

    def seconds(self, value: Any, what: str) -> float:
        """A duration attribute (a number, or text that substitutes to one)."""
        text = self.subst(value)
        try:
            number = float(text)
        except (TypeError, ValueError):
            number = math.nan
        if not (math.isfinite(number) and number >= 0):
            raise LaunchError(f"{self.file}: {what} '{text}' must be a number of seconds >= 0")
        return number


def _typed(value: Any) -> Any:
    """roslaunch's <param value=...> without a type: booleans, ints and floats are recognised."""
    if not isinstance(value, str):
        return value
    if value.strip().lower() in ("true", "false"):
        return value.strip().lower() == "true"
    for convert in (int, float):
        try:
            return convert(value)
        except ValueError:
            pass
    return value


def _load_module(path: str) -> tuple[Callable[[dict[str, str]], list], list[Arg]]:
    """(the file's items for given resolved args, its Args).

    A launch file is either a ``LAUNCH`` list, or ``ARGS`` (a list of Arg) and ``generate(args)``, which
    returns the items from the resolved arguments: the way to repeat items (one robot per index, say)
    that roslaunch's static XML has no construct for.
    """
    try:
        module = runpy.run_path(path)
    except Exception as err:  # a launch file is user code: report it, do not crash with its traceback
        raise LaunchError(f"{path}: cannot be read: {type(err).__name__}: {err}") from None
    if "LAUNCH" in module:
        items = list(module["LAUNCH"])
        return (lambda _args: items), [i for i in items if isinstance(i, Arg)]
    generate, declared = module.get("generate"), module.get("ARGS", [])
    if not callable(generate):
        raise LaunchError(f"{path}: defines neither a LAUNCH list nor ARGS and generate(args)")
    if not isinstance(declared, list) or not all(isinstance(a, Arg) for a in declared):
        raise LaunchError(f"{path}: ARGS must be a list of Arg")

    def items(args: dict[str, str]) -> list:
        try:
            generated = generate(dict(args))
        except Exception as err:  # noqa: BLE001 - user code; a ValueError is the file's own message
            raise LaunchError(f"{path}: generate(): {type(err).__name__}: {err}") from None
        if not isinstance(generated, list) or any(isinstance(i, Arg) for i in generated):
            raise LaunchError(f"{path}: generate() must return a list of launch items without Arg "
                              "(arguments go in ARGS)")
        return generated
    return items, list(declared)


def declared_args(path: str) -> list[Arg]:
    """The arguments a launch file takes (only the top file's may be given on the command line)."""
    return _load_module(path)[1]


def _resolve_args(path: str, declared: list[Arg], given: dict[str, str]) -> dict[str, str]:
    names = {a.name for a in declared}
    unknown = sorted(set(given) - names)
    if unknown:
        raise LaunchError(f"{path}: unknown argument(s) {', '.join(unknown)}; "
                          f"this launch file takes: {', '.join(sorted(names)) or 'none'}")
    args: dict[str, str] = {}
    for arg in declared:
        if arg.name in given:
            value = str(given[arg.name])
        elif arg.default is not None:
            value = str(arg.default)
        else:
            raise LaunchError(f"{path}: required argument '{arg.name}' not given ({arg.doc})")
        if arg.choices and value not in arg.choices:
            raise LaunchError(f"{path}: argument {arg.name}={value!r} is not one of {', '.join(arg.choices)}")
        problem = arg.check(value) if arg.check is not None else None
        if problem:
            raise LaunchError(f"{path}: argument {arg.name}={value!r}: {problem}")
        args[arg.name] = value
    return args


def _node_spec(node: Node, ctx: _Context, namespace: str, params: ParamServer) -> NodeSpec:
    """What the runner starts for one node: its private parameters as ROS 2 overrides, its remaps and flags."""
    name = ctx.subst(node.name)
    full = join_ns(namespace, name)
    subtree = params.get(full, {})
    try:
        overrides = to_ros2_overrides(subtree if isinstance(subtree, dict) else {}, where=full + "/")
    except ParamError as err:
        raise LaunchError(str(err)) from None
    global_use_sim_time = params.get("/use_sim_time", None)
    if global_use_sim_time is not None:
        overrides.setdefault("use_sim_time", bool(global_use_sim_time))
    if ctx.subst(node.args).strip():
        raise LaunchError(f"{ctx.file}: node {full}: args={node.args!r} is not supported: nodes here take "
                          "parameters, not command-line arguments")
    respawn = ctx.flag(node.respawn, f"node {full}: respawn")
    required = ctx.flag(node.required, f"node {full}: required")
    if respawn and required:
        raise LaunchError(f"{ctx.file}: node {full}: respawn and required cannot both be set")
    return NodeSpec(pkg=ctx.subst(node.pkg), type=ctx.subst(node.type), name=name, namespace=namespace,
                    output=node.output, respawn=respawn,
                    respawn_delay=ctx.seconds(node.respawn_delay, f"node {full}: respawn_delay"),
                    required=required, remaps=ctx.remaps + [(ctx.subst(r.from_), ctx.subst(r.to)) for r in node.remaps],
                    parameters=overrides)


def load_launch(path: str, given_args: dict[str, str] | None = None) -> LaunchConfig:
    params = ParamServer()
    nodes: list[tuple[Node, _Context, str]] = []

    def process_file(file: str, given: dict[str, str], ns: str,
                     remaps: list[tuple[str, str]]) -> tuple[list[Arg], dict[str, str]]:
        items, declared = _load_module(file)
        ctx = _Context(file, _resolve_args(file, declared, given), ns, remaps)
        process_items(items(ctx.args), ctx)
        return declared, ctx.args

    def process_items(items: list, ctx: _Context) -> None:
        for item in items:
            if isinstance(item, Arg) or not ctx.enabled(item):
                continue
            if isinstance(item, Group):
                sub = _Context(ctx.file, ctx.args, join_ns(ctx.ns, ctx.subst(item.ns)),
                               ctx.remaps + [(ctx.subst(r.from_), ctx.subst(r.to)) for r in item.remaps])
                process_items(item.children, sub)
            elif isinstance(item, Include):
                target = ctx.subst(item.file)
                if not os.path.isfile(target):
                    raise LaunchError(f"{ctx.file}: included file not found: {target}")
                process_file(target, {k: ctx.subst(v) for k, v in item.args.items()},
                             join_ns(ctx.ns, ctx.subst(item.ns)), ctx.remaps)
            elif isinstance(item, Node):
                # Private params go in at the node's place in document order, as roslaunch does:
                # a later <rosparam> at file level overrides them.
                namespace = join_ns(ctx.ns, ctx.subst(item.ns))
                full = join_ns(namespace, ctx.subst(item.name))
                for param in item.params:
                    apply_param(param, ctx, full)
                nodes.append((item, ctx, namespace))
            elif isinstance(item, (RosParam, Param)):
                apply_param(item, ctx, ctx.ns)
            else:
                raise LaunchError(f"{ctx.file}: unsupported launch item {item!r}")

    def apply_param(item: RosParam | Param, ctx: _Context, ns: str) -> None:
        if not ctx.enabled(item):
            return
        try:
            if isinstance(item, Param):
                params.set(join_ns(ns, ctx.subst(item.name)), _typed(ctx.subst(item.value)))
            elif item.command == "load":
                params.load(ctx.subst(item.file), join_ns(ns, ctx.subst(item.ns)))
            else:
                raise LaunchError(f"{ctx.file}: rosparam command={item.command!r} is not supported (only load)")
        except ParamError as err:
            raise LaunchError(str(err)) from None

    top = paths.launch_file(path) if not os.path.isfile(path) else os.path.abspath(path)
    declared, args = process_file(top, dict(given_args or {}), "/", [])

    specs: list[NodeSpec] = []
    for node, ctx, namespace in nodes:
        spec = _node_spec(node, ctx, namespace, params)
        if any(other.full_name == spec.full_name for other in specs):
            raise LaunchError(f"{ctx.file}: two nodes are named {spec.full_name}")
        specs.append(spec)
    return LaunchConfig(file=top, args=args, params=params, nodes=specs, arg_docs=declared)
