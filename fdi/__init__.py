"""bgfdi's diagnosis package: from a bond graph model and measurements to detected, isolated,
identified faults and their remaining useful life. ``python -m fdi`` runs the command line
(``bgfdi``). ``import fdi`` stays cheap (no sympy, no numpy): the version is read on first use,
and each stage is imported where it is used.
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


def __getattr__(name: str):
    # importlib.metadata costs ~35 ms: paid by who reads the version, not by every ``import fdi``
    if name == "__version__":
        value = _version()
        globals()["__version__"] = value
        return value
    raise AttributeError(f"module 'fdi' has no attribute {name!r}")


# --- public API -------------------------------------------------------------------------------
# Reserved for the main engineer (issue 21): Monitor, diagnose, ... exported here, lazily like
# __version__ above, so that ``import fdi`` stays light.
# ----------------------------------------------------------------------------------------------
