"""The docstring examples run as written (from the repository root, where the models are): every
module of the three packages (and each package itself) whose docstrings hold an example is
collected, so a new example is tested without being listed."""
from __future__ import annotations

import doctest
import importlib
import importlib.util
import pkgutil

import pytest

from .conftest import ROOT


def _modules_with_examples() -> list[str]:
    out = []
    for package in ("bondgraph", "fdi", "optim", "fdi.app"):      # fdi.app: a namespace package, not walked
        pkg = importlib.import_module(package)
        for name in [package] + [info.name for info in pkgutil.walk_packages(pkg.__path__, package + ".")]:
            spec = importlib.util.find_spec(name)
            if spec and spec.origin and spec.origin.endswith(".py") and ">>>" in open(spec.origin, encoding="utf-8").read():
                out.append(name)
    return sorted(out)


MODULES = _modules_with_examples()


def test_the_known_examples_are_collected():
    assert {"bondgraph", "bondgraph.units", "bondgraph.loader", "fdi.arrs", "fdi.api", "fdi.config",
            "fdi.app.two_ports", "fdi.app.evaluate"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name, monkeypatch):
    monkeypatch.chdir(ROOT)
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
