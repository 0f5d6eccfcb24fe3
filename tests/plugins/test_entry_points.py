"""The shipped plugins register by entry points (pyproject.toml), each from its own module: every entry point
gives a spec its registry lists, every implementation named as text resolves, a broken entry point is refused
with one clear line, and the registries' core imports none of the plugins."""

import importlib
import subprocess
import sys
import tomllib
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path

import pytest

from simplebot_navigation import pluginlib
from simplebot_navigation.costmap.plugins import LAYERS
from simplebot_navigation.move_base.plugins import GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS, PluginRegistry
from tests.test_architecture import ROOT, imports_of

PYPROJECT = ROOT.parent / "pyproject.toml"
PLUGIN_REGISTRIES = (GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS)
REGISTRIES = {registry.group: registry for registry in (*PLUGIN_REGISTRIES, LAYERS)}


def declared() -> dict[str, dict[str, str]]:
    """pyproject.toml's entry points of the registries' groups: {group: {name: value}}."""
    groups = tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))["project"]["entry-points"]
    return {group: groups.get(group, {}) for group in REGISTRIES}


def test_every_registry_has_entry_points_and_the_installed_ones_are_pyprojects():
    for group, points in declared().items():
        assert points, f"pyproject.toml declares no entry point of {group}"
        installed = {point.name: point.value for point in entry_points(group=group)}
        assert installed == points, (f"{group}: the installed entry points differ from pyproject.toml's; "
                                     "re-run pip install -e . (an editable install keeps them from install time)")


def test_every_entry_point_gives_a_spec_its_registry_lists():
    for group, points in declared().items():
        registry = REGISTRIES[group]
        for value in points.values():
            spec = EntryPoint("", value, group).load()
            assert isinstance(spec, registry.spec_type), value
            assert registry.spec(registry.key(spec)) is spec, value


@pytest.mark.parametrize("registry", PLUGIN_REGISTRIES, ids=lambda r: r.parameter)
def test_every_implementation_named_as_text_imports_and_has_its_attribute(registry):
    named = [registry.spec(t) for t in registry.types if isinstance(registry.spec(t).implementation, str)]
    assert named or registry is RECOVERY_BEHAVIORS      # the recoveries give their factories themselves
    for spec in named:
        module, _, attribute = spec.implementation.partition(":")
        found = importlib.import_module(module)
        for part in attribute.split("."):
            assert hasattr(found, part), f"{spec.type}: {spec.implementation} has no {part!r}"
            found = getattr(found, part)
        assert callable(found), spec.implementation
    for plugin_type in registry.types:
        assert callable(registry.spec(plugin_type).load()), plugin_type


def broken_registry(monkeypatch, value: str) -> PluginRegistry:
    group = "simplebot_navigation.example_planners"
    monkeypatch.setattr(pluginlib, "entry_points", lambda group: [EntryPoint("Broken", value, group)])
    return PluginRegistry("base_local_planner", group)


@pytest.mark.parametrize("value, why", [
    ("tests.plugins.no_such_module:SPEC", "ModuleNotFoundError: No module named 'tests.plugins.no_such_module'"),
    ("tests.plugins.keep_out_layer:NO_SUCH_SPEC", "AttributeError: "),
    ("tests.plugins.keep_out_layer:SPEC", "it names a LayerSpec, not a PluginSpec"),
])
def test_a_broken_entry_point_is_refused_naming_it_and_its_group(monkeypatch, value, why):
    registry = broken_registry(monkeypatch, value)
    for _ in range(2):                   # asked again, it says the same: nothing was half registered
        with pytest.raises(pluginlib.EntryPointError) as caught:
            registry.spec("example/Anything")
        message = str(caught.value)
        assert message.startswith(f"entry point Broken = {value!r} in group simplebot_navigation.example_planners: ")
        assert why in message
        error = caught.value                 # one line, not the plugin's traceback chained to ours
        assert error.__cause__ is None and (error.__context__ is None or error.__suppress_context__)


def test_a_group_without_entry_points_says_the_package_is_not_installed(monkeypatch):
    monkeypatch.setattr(pluginlib, "entry_points", lambda group: [])
    with pytest.raises(pluginlib.EntryPointError, match="no entry points in group "
                       "simplebot_navigation.example_planners: the package that declares them is not installed"):
        PluginRegistry("base_local_planner", "simplebot_navigation.example_planners").types


def test_the_registries_core_imports_no_plugin():
    plugin_modules = tuple(f"simplebot_navigation.{m}" for m in (
        "teb", "planning", "move_base.recovery", "costmap.static_layer", "costmap.obstacle_layer",
        "costmap.inflation_layer", "costmap.observation"))
    for core in (ROOT / "move_base" / "plugins.py", ROOT / "costmap" / "plugins.py", ROOT / "pluginlib.py"):
        found = [m for m in imports_of(core) if m.startswith(plugin_modules)]
        assert not found, f"{core.relative_to(ROOT.parent)} imports {found}"


def test_reading_every_registration_imports_no_ros():
    code = ("import sys\n"
            "from simplebot_navigation.costmap.plugins import LAYERS\n"
            "from simplebot_navigation.move_base.plugins import GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS\n"
            "assert LAYERS.specs and all(r.types for r in (GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS))\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rclpy'))\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                            cwd=Path(__file__).resolve().parents[2])
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"
