"""Optimisers for fault identification. They know nothing of bond graphs: ``fdi`` hands them a
problem (``optim.core.Problem``: a cost ``problem(real (pop, D), bits (pop, B)) -> (pop,)`` to
minimise, ``bounds()``, and optional hooks such as ``n_bits``, ``onehot``, ``structure``, ``init``)
and ``minimize`` runs an engine on it, as ``scipy.optimize.differential_evolution`` runs DE.

``ENGINES`` maps the names used by ``bgfdi --engine`` and ``bgfdi bench optim`` to their
``Engine`` (solver class and options class); ``DEFAULT_ENGINE`` is the one with the best measured
success. An example is in ``optim.core``.
"""
from __future__ import annotations

from . import ahde, ahde_joint, ahde_paper, ga, scipy_de, shade
from .ahde import AHDEOptions
from .ahde_joint import JointOptions
from .ahde_paper import PaperOptions
from .core import Engine, Options, Posed, Problem, Result, Stopping, fitness, pose
from .ga import AGAOptions, GAOptions
from .scipy_de import ScipyDEOptions
from .shade import SHADEOptions

ENGINES: dict[str, Engine] = {e.name: e for e in (ahde.ENGINE, ahde_joint.ENGINE, ahde_paper.ENGINE, ga.ENGINE,
                                                  ga.ADAPTIVE, scipy_de.ENGINE, shade.ENGINE)}
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


__all__ = ["ENGINES", "DEFAULT_ENGINE", "Engine", "Options", "Stopping", "AHDEOptions", "JointOptions", "PaperOptions",
           "GAOptions", "AGAOptions", "SHADEOptions", "ScipyDEOptions", "Posed", "Problem", "Result", "fitness",
           "minimize", "pose"]
