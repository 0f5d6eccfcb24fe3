"""Where the package's share files (config/, launch_py/) are: the source checkout, or <prefix>/share."""

from __future__ import annotations

import importlib.util
import os
import sys

_CHECKOUT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def package_share(package: str) -> str:
    """The directory ``$(find package)`` resolves to."""
    if package == "simplebot_navigation":
        candidates = [_CHECKOUT, os.path.join(sys.prefix, "share", package)]
        for path in candidates:
            if os.path.isdir(os.path.join(path, "config")):
                return path
        raise FileNotFoundError(f"cannot find the share directory of {package} (looked in {candidates})")
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError(f"$(find {package}): no such package")
    return list(spec.submodule_search_locations)[0]


def launch_file(name: str) -> str:
    """A launch file by short name ('navigation') or by path."""
    if os.sep in name or name.endswith(".py"):
        path = os.path.abspath(name)
    else:
        path = os.path.join(package_share("simplebot_navigation"), "launch_py", f"{name}.py")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"launch file not found: {path} (see --list)")
    return path


def launch_files() -> list[str]:
    folder = os.path.join(package_share("simplebot_navigation"), "launch_py")
    return sorted(f[:-3] for f in os.listdir(folder) if f.endswith(".py") and not f.startswith("_"))
