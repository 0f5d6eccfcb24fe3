"""Registrations by name, each made once: the base of the plugin registries (move_base/plugins.py,
costmap/plugins.py)."""

from __future__ import annotations

import contextlib
from typing import Generic, Iterator, TypeVar

Spec = TypeVar("Spec")


class Registry(Generic[Spec]):
    """Specs by their key; a second registration under a key already taken is refused."""

    def __init__(self, specs=()):
        self._specs: dict[str, Spec] = {}
        for spec in specs:
            self.register(spec)

    def key(self, spec: Spec) -> str:
        raise NotImplementedError

    def conflict(self, spec: Spec) -> str | None:
        """Why ``spec`` cannot be registered, or None."""
        return f"{self.key(spec)} is registered already" if self.key(spec) in self._specs else None

    def register(self, spec: Spec) -> Spec:
        problem = self.conflict(spec)
        if problem:
            raise ValueError(problem)
        self._specs[self.key(spec)] = spec
        return spec

    def unregister(self, key: str) -> None:
        self._specs.pop(key, None)

    @contextlib.contextmanager
    def registered(self, spec: Spec) -> Iterator[Spec]:
        """Known inside the block only (for a test's own plugin)."""
        self.register(spec)
        try:
            yield spec
        finally:
            self.unregister(self.key(spec))
