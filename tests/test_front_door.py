"""The front door: ``python -m fdi`` is the ``bgfdi`` command line, ``fdi.__version__`` is the
version pyproject.toml declares (installed or not), and ``import fdi`` / ``import bondgraph`` stay
cheap: neither pulls in sympy or numpy until a name that needs them is used."""
from __future__ import annotations

import importlib.metadata
import subprocess
import sys

import pytest

from .conftest import ROOT

tomllib = pytest.importorskip("tomllib")        # Python >= 3.11; the reference reader of pyproject.toml

DECLARED = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]


def _python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60,
                          env={"PYTHONPATH": str(ROOT), "PATH": ""})


def test_python_m_fdi_is_the_command_line():
    out = subprocess.run([sys.executable, "-m", "fdi", "--version"], cwd=ROOT, capture_output=True, text=True,
                         timeout=60, env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert out.returncode == 0 and out.stdout.strip() == f"bgfdi {DECLARED}"
    bad = subprocess.run([sys.executable, "-m", "fdi", "no-such-command"], cwd=ROOT, capture_output=True,
                         text=True, timeout=60, env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert bad.returncode == 2 and "invalid choice" in bad.stderr and "Traceback" not in bad.stderr


def test_version_is_pyprojects_installed_or_not(monkeypatch):
    import fdi

    assert fdi.__version__ == DECLARED

    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)
    monkeypatch.setattr(importlib.metadata, "version", missing)
    assert fdi._version() == DECLARED              # read from the source tree's pyproject.toml


@pytest.mark.parametrize("package", ["fdi", "bondgraph"])
def test_importing_a_package_is_cheap(package):
    out = _python(f"import sys, {package}; print(sorted(m for m in ('sympy', 'numpy', 'scipy') if m in sys.modules))")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_every_name_fdi_exports_resolves_to_its_module():
    import importlib

    import fdi
    for name, module in fdi.EXPORTS.items():
        assert getattr(fdi, name) is getattr(importlib.import_module(module), name)
    assert set(fdi.EXPORTS) <= set(dir(fdi))
