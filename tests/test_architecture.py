"""The package's layering, read from the source with ast: who may import whom, no cycles, small files.

Layers, lowest first; a module may import its own layer and the layers below, never one above:
  geometry, paths, parameters, pluginlib, web_host  shared math, file locations, the parameter layer, the plugin
                                                    registries' base, Host checks
  costmap, planning, teb, mppi, sim, move_base,     the navigation core: plain Python, no ROS
  safety, perception, maps, localization, slam
  ros                                               the nodes and their ROS shells
  launch, scenarios, viewer, testing                what a user runs (and what tests and benches share)
Within a layer, two packages import each other one way at most (scenarios/ uses launch/, never back).

Inside ros/ the same rule holds between its folders and top-level modules (ROS_LAYERS), lowest first:
  conversions, poses, tf, qos, params, ...      what every node shares: messages, poses, frames, the node's main
  costmap                                       what nodes are built from (move_base holds two Costmap2DROS)
  move_base, amcl, simulator, tools, the nodes  the nodes
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = "simplebot_navigation"
ROOT = Path(__file__).resolve().parents[1] / PACKAGE
LAYERS = [
    {"geometry", "geometry_kernels", "paths", "parameters", "pluginlib", "kernel_cache", "web_host", "laser_scan",
     "log_throttle", ""},
    {"costmap", "planning", "teb", "mppi", "sim", "move_base", "safety", "perception", "maps", "localization",
     "slam"},
    {"ros"},
    {"launch", "scenarios", "viewer", "testing"},
]
#: inside ros/: its folders and top-level modules, lowest first
ROS_LAYERS = [
    {"conversions", "poses", "tf", "qos", "params", "publishers", "executor", "lifecycle_state", "node_main", ""},
    {"costmap"},
    {"move_base", "amcl", "simulator", "tools", "collision_monitor_node", "map_server_node", "map_saver_node",
     "slam"},
]
CORE = LAYERS[1] | {"geometry", "parameters"}
MAX_LINES = 400
MAX_FUNCTION_LINES = 80
#: upward imports tolerated for now; an entry here is a debt, not a rule
KNOWN_UPWARD: set[tuple[str, str]] = set()


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def source_files() -> list[Path]:
    return sorted(ROOT.rglob("*.py"))


MODULES = {module_name(p) for p in source_files()}


def imports_of(path: Path) -> set[str]:
    """Every module a file imports, at any depth (function-level imports count too), absolute.
    `from pkg import module` counts as importing pkg.module, `from pkg import name` as pkg."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            for alias in node.names:
                found.add(f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base)
    return found


def internal_graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports."""
    return {module_name(path): {m for m in imports_of(path) if m in MODULES and m != module_name(path)}
            for path in source_files()}


def package_of(module: str) -> str:
    return module.split(".")[1] if "." in module else ""


def level_in(layers: list[set[str]], part: str, module: str, table: str) -> int:
    """The index of the layer that holds `part` (module's package or part of ros/), named in errors."""
    for level, members in enumerate(layers):
        if part in members:
            return level
    raise AssertionError(f"{module} is in no layer: add {part!r} to {table} in {Path(__file__).name}")


def layer_of(module: str) -> int:
    return level_in(LAYERS, package_of(module), module, "LAYERS")


def test_every_package_has_a_layer():
    for name in internal_graph():
        layer_of(name)


def test_core_imports_neither_ros_nor_the_layers_above():
    offenders = []
    for path in source_files():
        name = module_name(path)
        if name.split(".")[1:2] and name.split(".")[1] in CORE:
            for target in imports_of(path):
                top = target.split(".")[0]
                if top == "rclpy" or target.startswith((f"{PACKAGE}.ros", f"{PACKAGE}.launch")):
                    offenders.append(f"{name} imports {target}")
    assert not offenders, "\n".join(offenders)


def test_no_module_imports_a_higher_layer():
    offenders = [f"{name} (layer {layer_of(name)}) imports {target} (layer {layer_of(target)})"
                 for name, targets in internal_graph().items() for target in sorted(targets)
                 if layer_of(target) > layer_of(name) and (name, target) not in KNOWN_UPWARD]
    assert not offenders, "\n".join(offenders)


def cycles_in(graph: dict[str, set[str]]) -> list[list[str]]:
    """The cycles a depth-first walk of the graph meets, each as its nodes with the first one repeated."""
    state: dict[str, int] = {}      # 1: on the current path, 2: done
    path: list[str] = []
    cycles = []

    def visit(node: str) -> None:
        state[node] = 1
        path.append(node)
        for target in sorted(graph.get(node, ())):
            if state.get(target) == 1:
                cycles.append(path[path.index(target):] + [target])
            elif target not in state:
                visit(target)
        path.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)
    return cycles


def test_no_import_cycles():
    cycles = cycles_in(internal_graph())
    assert not cycles, "\n".join(" -> ".join(cycle) for cycle in cycles)


def test_packages_of_a_layer_do_not_depend_on_each_other_both_ways():
    examples: dict[tuple[str, str], str] = {}        # (package, package it imports) -> one such import
    for name, targets in sorted(internal_graph().items()):
        for target in sorted(targets):
            edge = (package_of(name), package_of(target))
            if edge[0] != edge[1] and layer_of(name) == layer_of(target):
                examples.setdefault(edge, f"{name} imports {target}")
    graph: dict[str, set[str]] = {}
    for source, target in examples:
        graph.setdefault(source, set()).add(target)
    cycles = cycles_in(graph)
    assert not cycles, "\n".join(" -> ".join(cycle) + ": " + "; ".join(examples[edge] for edge in zip(cycle, cycle[1:]))
                                  for cycle in cycles)


def ros_part(module: str) -> str | None:
    """The folder or top-level module of ros/ a module belongs to (None: outside ros/)."""
    parts = module.split(".")
    return parts[2] if len(parts) > 2 and parts[1] == "ros" else ("" if module == f"{PACKAGE}.ros" else None)


def ros_layer_of(module: str) -> int:
    return level_in(ROS_LAYERS, ros_part(module), module, "ROS_LAYERS")


def ros_graph() -> dict[str, set[str]]:
    """The imports between ros/'s modules."""
    return {name: {t for t in targets if ros_part(t) is not None}
            for name, targets in internal_graph().items() if ros_part(name) is not None}


def test_inside_ros_no_module_imports_a_higher_layer():
    offenders = [f"{name} (ros layer {ros_layer_of(name)}) imports {target} (ros layer {ros_layer_of(target)})"
                 for name, targets in ros_graph().items() for target in sorted(targets)
                 if ros_layer_of(target) > ros_layer_of(name)]
    assert not offenders, "\n".join(offenders)


def test_inside_ros_the_parts_of_a_layer_do_not_depend_on_each_other_both_ways():
    graph: dict[str, set[str]] = {}
    for name, targets in ros_graph().items():
        for target in targets:
            if ros_part(name) != ros_part(target) and ros_layer_of(name) == ros_layer_of(target):
                graph.setdefault(ros_part(name), set()).add(ros_part(target))
    cycles = cycles_in(graph)
    assert not cycles, "\n".join(" -> ".join(cycle) for cycle in cycles)


@pytest.mark.parametrize("path", source_files() + sorted(ROOT.rglob("*.js")), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_file_over_the_line_limit(path):
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_LINES, f"{path.relative_to(ROOT.parent)} has {lines} lines; split it by responsibility"


def _compiled(function: ast.FunctionDef) -> bool:
    """A numba kernel: plain loops are its point, so its length is not held against it."""
    return any("jit" in ast.unparse(decorator) for decorator in function.decorator_list)


@pytest.mark.parametrize("path", source_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_function_over_the_line_limit(path):
    long = [f"{node.name} ({node.end_lineno - node.lineno + 1} lines, line {node.lineno})"
            for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _compiled(node)
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert not long, f"{path.relative_to(ROOT.parent)}: {', '.join(long)}; split by what each part does"


@pytest.mark.parametrize("path", source_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_are_absolute(path):
    relative = [node.lineno for node in ast.walk(ast.parse(path.read_text()))
                if isinstance(node, ast.ImportFrom) and node.level > 0]
    assert not relative, f"{path.relative_to(ROOT.parent)}: relative imports at lines {relative}; write them absolute"


#: the parts move_base's node is assembled from that own no ROS interface: they get what they use, never the node
#: (the costmaps, the planner plugins and obstacle tracking own subscriptions and publishers, so they get it)
MOVE_BASE_HELPERS = ("goal_arbiter", "cycle_poses", "move_base_goal", "move_base_front_door", "move_base_supervision",
                     "move_base_parameters", "move_base_stats", "move_base_services", "move_base_recoveries",
                     "nav2_front_door")


@pytest.mark.parametrize("helper", MOVE_BASE_HELPERS)
def test_no_helper_of_move_base_takes_the_node(helper):
    tree = ast.parse((ROOT / "ros" / "move_base" / f"{helper}.py").read_text())
    functions = [f for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))]
    taking = [f"{f.name} (line {f.lineno})" for f in functions
              if any(a.arg == "node" for a in f.args.args + f.args.kwonlyargs)]
    reaching = [f"line {n.lineno}" for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr == "node"]
    assert not taking and not reaching, f"{helper}: takes the node in {taking}, reaches for it at {reaching}"
