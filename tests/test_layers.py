"""Data flows one way (README, Layout): ``fdi`` uses ``bondgraph`` and ``optim``, which never import
``fdi`` or each other; the library core of ``fdi`` never imports its application corner
``fdi.app``. Read from the import statements of every module, so a new edge fails here."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from .conftest import ROOT


def _imports(path: Path, package: str) -> set[str]:
    """Absolute names of the modules ``path`` imports (relative imports resolved against ``package``)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            out.add(name)
            out |= {f"{name}.{a.name}" for a in node.names}
    return out


def _modules(folder: str):
    for path in sorted((ROOT / folder).rglob("*.py")):
        package = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
        yield path, package


FORBIDDEN = {"bondgraph": ("fdi", "optim"), "optim": ("fdi", "bondgraph")}


@pytest.mark.parametrize("folder", sorted(FORBIDDEN))
def test_bondgraph_and_optim_import_neither_fdi_nor_each_other(folder):
    for path, package in _modules(folder):
        bad = {m for m in _imports(path, package) if m.split(".")[0] in FORBIDDEN[folder]}
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}"


def test_the_fdi_core_never_imports_the_application_corner():
    for path, package in _modules("fdi"):
        if "app" in path.relative_to(ROOT).parts:
            continue
        bad = {m for m in _imports(path, package) if m == "fdi.app" or m.startswith("fdi.app.")}
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}"


def test_the_import_reader_sees_relative_imports():
    """The reader itself, on a known edge: the application imports the core relatively."""
    imports = _imports(ROOT / "fdi" / "app" / "cli.py", "fdi.app")
    assert "fdi.errors" in imports or "fdi.errors.UsageError" in imports
