"""bgfdi's diagnosis package: from a bond graph model and measurements to detected, isolated,
identified faults and their remaining useful life. ``python -m fdi`` runs the command line
(``bgfdi``). ``import fdi`` stays cheap (no sympy, no numpy): the version is read on first use,
and each name below is imported when first used.

- :class:`Monitor` (``fdi.monitor``): a model compiled once; ``Monitor(model).diagnose(data)``;
- :func:`diagnose` (``fdi.api``): the same in one call, for a path, YAML text or Model;
- :func:`load` / :func:`load_text` (``fdi.config``): a model file's bond graph and monitor settings;
- :class:`Options` (engine, seed, workers, overrides), :class:`MonitorConfig` (the file's settings);
- :class:`Diagnosis` and its stages (``fdi.results``); :func:`select_arrs` (``fdi.arrs``): the ARRs;
  :func:`fault_signature_matrix`, :func:`mode_change_signature_matrix` (``fdi.signatures``);
  :func:`read_csv`, :class:`Measurements` (``fdi.data``). Simulation is ``bondgraph.simulate``.

>>> import fdi
>>> m = fdi.Monitor("models/three_tank.yaml")
>>> [a.name for a in m.arrs] == list(m.names)
True
"""
from __future__ import annotations

DISTRIBUTION = "bgfdi"


def _version() -> str:
    """The installed distribution's version; the source tree's pyproject.toml where bgfdi runs
    uninstalled (a checkout on ``PYTHONPATH``); ``0+unknown`` when neither says."""
    import re
    from importlib.metadata import PackageNotFoundError, version
    from pathlib import Path

    try:
        return version(DISTRIBUTION)
    except PackageNotFoundError:
        pass
    try:
        text = (Path(__file__).resolve().parent.parent / "pyproject.toml").read_text(encoding="utf-8")
    except OSError:
        return "0+unknown"
    project = re.search(r"^\[project\]\s*$(.*?)(?=^\[|\Z)", text, re.M | re.S)
    found = project and re.search(r"""^version\s*=\s*["']([^"']+)["']""", project.group(1), re.M)
    return found.group(1) if found else "0+unknown"


EXPORTS = {
    "Monitor": "fdi.monitor", "diagnose": "fdi.api", "measurements": "fdi.api", "load": "fdi.config",
    "load_text": "fdi.config", "MonitorConfig": "fdi.config", "Options": "fdi.options",
    "Diagnosis": "fdi.results", "Fault": "fdi.results", "Detection": "fdi.results", "Isolation": "fdi.results",
    "Estimate": "fdi.results", "Episode": "fdi.results", "Prognosis": "fdi.results", "ModeFault": "fdi.results",
    "select_arrs": "fdi.arrs", "fault_signature_matrix": "fdi.signatures",
    "mode_change_signature_matrix": "fdi.signatures", "read_csv": "fdi.data", "Measurements": "fdi.data",
}
__all__ = ["__version__", *EXPORTS]


def __getattr__(name: str):
    # importlib.metadata costs ~35 ms: paid by who reads the version, not by every ``import fdi``
    if name == "__version__":
        value = _version()
        globals()["__version__"] = value
        return value
    if name in EXPORTS:
        import importlib
        value = getattr(importlib.import_module(EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'fdi' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
