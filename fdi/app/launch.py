"""The ``bgfdi`` command's entry point (the console script and ``python -m fdi``): what the process
must settle before numpy is imported, then :func:`fdi.app.cli.main`.

BLAS on one thread, unless the environment says otherwise: bgfdi's matrices are small and its
parallelism is processes (``--workers``, ``--jobs``, a dask cluster). OpenBLAS's idle threads spin
before they sleep: ``import numpy`` alone took 0.27-0.29 s of CPU on 2 cores, 0.13-0.15 s with one
thread, and a whole ``bgfdi diagnose`` of CyCab scenario 2 used 0.12 s more CPU than wall time
(the same wall time): CPU the other processes of a pool or a fleet on the same cores did not get."""
from __future__ import annotations

import os

# numpy's and scipy's BLAS: OpenBLAS (pip's wheels; conda's OpenMP builds read OMP_NUM_THREADS), MKL,
# Apple's Accelerate (numpy's arm64 wheels on macOS)
THREADS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")


def single_threaded_blas() -> None:
    """Each BLAS's thread count 1 where the environment does not set it (before numpy's import:
    read once, when the library loads)."""
    for name in THREADS:
        os.environ.setdefault(name, "1")


def main(argv: list[str] | None = None) -> int:
    single_threaded_blas()
    from .cli import main as cli_main
    return cli_main(argv)
