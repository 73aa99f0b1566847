"""Heavy optional-at-import dependencies, loaded on first use.

``ca = lazy_import("casadi")`` binds a stand-in that imports CasADi the first time one of its
attributes is read (``ca.MX``), so ``import armlab.dynamics`` (which needs the
:class:`~armlab.trajectory.Trajectory` type, not the optimisers) never pays for it. The module is
not put in ``sys.modules`` until it is really imported.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

__all__ = ["lazy_import"]


class _LazyModule:
    """Stand-in for a module: imports it on the first attribute access, then caches each
    attribute read on itself (later reads cost a normal attribute lookup)."""

    def __init__(self, name: str) -> None:
        self.__dict__["_lazy_name"] = name

    def _lazy_module(self) -> ModuleType:
        return importlib.import_module(self.__dict__["_lazy_name"])

    def __getattr__(self, attr: str) -> Any:
        value = getattr(self._lazy_module(), attr)
        self.__dict__[attr] = value
        return value

    def __repr__(self) -> str:
        return f"<lazy module {self.__dict__['_lazy_name']!r}>"


def lazy_import(name: str) -> Any:
    """A stand-in for ``import name`` that imports the module on first attribute access."""
    return _LazyModule(name)
