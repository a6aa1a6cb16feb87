"""Optional plots (``pip install bgfdi[plot]``): matplotlib is imported only here, only when asked."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .cli_errors import need_matplotlib


def _plt():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        return plt
    except ImportError:
        raise need_matplotlib() from None


def plot_signals(columns: dict[str, np.ndarray], path: str | Path) -> None:
    """Every data column against time, one panel each."""
    plt = _plt()
    names = [c for c in columns if c != "t"]
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 1.8 * len(names)), sharex=True)
    for ax, name in zip(np.atleast_1d(axes), names):
        ax.plot(columns["t"], columns[name], lw=0.8)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[-1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
