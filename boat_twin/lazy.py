"""Packages that name their public API in ``__all__`` but import it on first use, so that importing one light
module of a package (a sensor model, a verb's ``--help``) does not load the compiled simulator or scipy."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, exports: Mapping[str, str]) -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package``: each public name in ``exports`` (name → module) is imported
    from its module when first asked for."""

    def attribute(name: str) -> Any:
        if name in exports:
            return getattr(importlib.import_module(exports[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return attribute
