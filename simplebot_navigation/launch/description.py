"""The launch-file vocabulary of roslaunch XML, as plain Python data.

A launch file under ``launch_py/`` is a module with a ``LAUNCH`` list built from
these classes; the launcher interprets it with roslaunch semantics (args,
substitutions, ``<rosparam command="load" ns=...>``, remaps, includes, groups).
A file whose items depend on an argument (one group per robot) has ``ARGS`` and
``generate(args)`` instead, called with the resolved arguments.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable


@dataclass
class Arg:
    """``<arg name default doc>``; a value given on the command line wins over the default. ``check`` says
    what is wrong with a value (None: nothing), before any node starts."""
    name: str
    default: str | None = None
    doc: str = ""
    choices: tuple[str, ...] = ()
    check: Callable[[str], str | None] | None = None


@dataclass
class RosParam:
    """``<rosparam file=... command="load" ns=...>``: load a YAML file under a namespace."""
    file: str
    command: str = "load"
    ns: str = ""
    if_: str | None = None
    unless: str | None = None


@dataclass
class Param:
    """``<param name value>``."""
    name: str
    value: Any
    if_: str | None = None
    unless: str | None = None


@dataclass
class Remap:
    """``<remap from to>``: applies to the enclosing node, or to every node of a group."""
    from_: str
    to: str


@dataclass
class Node:
    """``<node pkg type name output respawn>`` with its private rosparams, params and remaps.

    As in roslaunch, a node with ``respawn`` is restarted ``respawn_delay`` seconds after it exits,
    and one that is ``required`` stops the launch when it exits; these may be substitutions
    (``respawn="$(arg respawn)"``).
    """
    pkg: str
    type: str
    name: str
    output: str = "screen"
    respawn: bool | str = False
    respawn_delay: float | str = 0.0
    required: bool | str = False
    ns: str = ""
    args: str = ""
    params: list[RosParam | Param] = field(default_factory=list)
    remaps: list[Remap] = field(default_factory=list)
    if_: str | None = None
    unless: str | None = None


@dataclass
class Include:
    """``<include file>`` with ``<arg name value>`` pairs passed to the included file."""
    file: str
    args: dict[str, str] = field(default_factory=dict)
    ns: str = ""
    if_: str | None = None
    unless: str | None = None


@dataclass
class Group:
    """``<group ns>``: remaps and params inside apply to every node of the group."""
    children: list = field(default_factory=list)
    ns: str = ""
    remaps: list[Remap] = field(default_factory=list)
    if_: str | None = None
    unless: str | None = None
