"""Optimisers for fault identification. They know nothing of bond graphs: ``fdi`` hands them an
objective ``cost(real (pop, D), bits (pop, B)) -> (pop,)`` to minimise, real bounds and a bit count.

``ENGINES`` maps the names used by ``bgfdi --engine`` and ``bgfdi bench optim`` to their
``minimize`` functions; ``DEFAULT_ENGINE`` is the one with the best measured success.
"""
from __future__ import annotations

from . import ahde, ahde_joint, ahde_paper, ga, scipy_de, shade
from .core import Result, fitness

ENGINES = {
    "AHDE": ahde.minimize,
    "AHDE-joint": ahde_joint.minimize,
    "AHDE-paper": ahde_paper.minimize,
    "GA": ga.minimize,
    "AGA": ga.minimize_adaptive,
    "scipy-DE": scipy_de.minimize,
    "SHADE": shade.minimize,
}
DEFAULT_ENGINE = "AHDE"

__all__ = ["ENGINES", "DEFAULT_ENGINE", "Result", "fitness"]
