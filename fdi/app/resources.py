"""Files that ship with bgfdi: the models and the CyCab scenarios and reference data."""
from __future__ import annotations

from importlib import resources
from pathlib import Path


def models_dir() -> Path:
    """The folder of shipped models (``models/`` in a checkout, ``fdi/models`` when installed)."""
    try:
        path = Path(str(resources.files("fdi.models")))
        if path.is_dir():
            return path
    except ModuleNotFoundError:
        pass
    return Path(__file__).resolve().parents[2] / "models"


def shipped_models() -> list[Path]:
    return sorted(models_dir().glob("*.yaml"))


def shipped_model(name: str) -> Path:
    return models_dir() / f"{name}.yaml"


def scenarios_dir() -> Path:
    return models_dir() / "scenarios"


def reference_data(name: str) -> Path:
    """A CyCab reference measurement file (``models/data/cycab``: the paper's four runs, made by an
    independent simulator; shipped with the package for the demo and the scenario-2 bench)."""
    return models_dir() / "data" / "cycab" / name
