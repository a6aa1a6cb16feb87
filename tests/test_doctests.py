"""The docstring examples run as written (from the repository root, where the models are)."""
from __future__ import annotations

import doctest
import importlib

import pytest

from .conftest import ROOT

MODULES = ["bondgraph.units", "fdi.arrs", "fdi.api"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name, monkeypatch):
    monkeypatch.chdir(ROOT)
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
