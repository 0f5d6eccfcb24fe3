"""The set-up commands install what the project's own files declare: README's commands and .ci/run agree with the
interface packages' build requirements, so that a fresh machine builds them without build isolation."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BUILD_REQUIREMENTS = ROOT / "interfaces" / "build-requirements.txt"


def requirement_lines(path: Path) -> set[str]:
    return {line.strip() for line in path.read_text(encoding="utf-8").splitlines()
            if line.strip() and not line.lstrip().startswith("#")}


def build_requires(pyproject: Path) -> list[str]:
    return tomllib.loads(pyproject.read_text(encoding="utf-8"))["build-system"]["requires"]


def readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return [c for c in re.findall(r"```bash\n(.*?)\n```", text, re.S) if c.startswith("python3.11 -m venv .venv")]


def test_every_interface_package_builds_with_the_shared_build_requirements():
    listed = requirement_lines(BUILD_REQUIREMENTS)
    packages = sorted(ROOT.glob("interfaces/*/pyproject.toml"))
    assert packages
    for pyproject in packages:
        missing = set(build_requires(pyproject)) - listed
        assert not missing, f"{pyproject.relative_to(ROOT)} needs {sorted(missing)}, not in {BUILD_REQUIREMENTS.name}"
    # and this project's own editable build
    for requirement in build_requires(ROOT / "pyproject.toml"):
        name = re.split(r"[<>=]", requirement)[0]
        assert any(line.split(">")[0].split("=")[0] == name for line in listed), requirement


def test_both_set_up_commands_install_every_interface_package_without_build_isolation():
    commands = readme_commands()
    assert len(commands) == 2, commands
    packages = {f"./interfaces/{p.parent.name}" for p in ROOT.glob("interfaces/*/pyproject.toml")}
    for command in commands:
        assert ".venv/bin/pip install -r interfaces/build-requirements.txt && " in command, command
        install = command.split("&& ")[2]
        assert install.startswith(".venv/bin/pip install --no-build-isolation "), install
        assert packages <= set(install.split()), sorted(packages - set(install.split()))
