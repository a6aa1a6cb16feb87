"""Optimisers for fault identification. They know nothing of bond graphs: ``fdi`` hands them a
problem (``optim.core.Problem``: a cost ``problem(real (pop, D), bits (pop, B)) -> (pop,)`` to
minimise, ``bounds()``, and optional hooks such as ``n_bits``, ``onehot``, ``structure``, ``init``)
and ``minimize`` runs an engine on it, as ``scipy.optimize.differential_evolution`` runs DE.

``ENGINES`` maps the names used by ``bgfdi --engine`` and ``bgfdi bench optim`` to their
``Engine`` (solver class and options class); ``DEFAULT_ENGINE`` is the one with the best measured
success. An example is in ``optim.core``.
"""
from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping

from .core import Engine, Options, Posed, Problem, Result, Stopping, fitness, pose

# name -> (module, attribute): an engine's module is imported when the engine is first asked for (a
# diagnosis with the default engine does not pay the other five modules' import, 12 ms)
_WHERE = {"AHDE": ("ahde", "ENGINE"), "AHDE-joint": ("ahde_joint", "ENGINE"), "AHDE-paper": ("ahde_paper", "ENGINE"),
          "GA": ("ga", "ENGINE"), "AGA": ("ga", "ADAPTIVE"), "scipy-DE": ("scipy_de", "ENGINE"),
          "SHADE": ("shade", "ENGINE")}
_OPTIONS = {"AHDEOptions": "ahde", "JointOptions": "ahde_joint", "PaperOptions": "ahde_paper", "GAOptions": "ga",
            "AGAOptions": "ga", "SHADEOptions": "shade", "ScipyDEOptions": "scipy_de"}
_MODULES = frozenset(m for m, _ in _WHERE.values())


class _Engines(Mapping):
    """The engines by name, in a fixed order; each module imported at its engine's first use."""

    def __getitem__(self, name: str) -> Engine:
        module, attr = _WHERE[name]
        return getattr(importlib.import_module(f"{__name__}.{module}"), attr)

    def __iter__(self) -> Iterator[str]:
        return iter(_WHERE)

    def __len__(self) -> int:
        return len(_WHERE)

    def __contains__(self, name: object) -> bool:      # a name's check imports nothing
        return name in _WHERE

    def __repr__(self) -> str:
        return f"ENGINES({', '.join(_WHERE)})"


ENGINES: Mapping[str, Engine] = _Engines()
DEFAULT_ENGINE = "AHDE"


def minimize(problem: Problem | Posed, engine: str = DEFAULT_ENGINE, options: Options | None = None,
             **overrides) -> Result:
    """Minimise ``problem`` with the engine named ``engine``; ``options`` is that engine's options
    dataclass (its defaults when None) and ``overrides`` replace single fields of it (``seed=3``).
    An unknown engine is a ValueError, an option the engine does not have a TypeError, each one
    line naming it and the valid ones."""
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; valid: {', '.join(ENGINES)}")
    return ENGINES[engine].minimize(problem, options, **overrides)


def __getattr__(name: str):
    """The engines' options classes (``optim.AHDEOptions``) and modules (``optim.ga``), imported at first use."""
    if name in _OPTIONS:
        return getattr(importlib.import_module(f"{__name__}.{_OPTIONS[name]}"), name)
    if name in _MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_OPTIONS) | _MODULES)


__all__ = ["ENGINES", "DEFAULT_ENGINE", "Engine", "Options", "Stopping", "AHDEOptions", "JointOptions", "PaperOptions",
           "GAOptions", "AGAOptions", "SHADEOptions", "ScipyDEOptions", "Posed", "Problem", "Result", "fitness",
           "minimize", "pose"]
