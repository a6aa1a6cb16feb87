"""Jobs in worker processes, results in the jobs' order (the benches' runs, a fleet's files)."""
from __future__ import annotations

from typing import Callable, Sequence, TypeVar

T = TypeVar("T")


def map_in_order(fn: Callable[..., T], jobs: Sequence, workers: int = 1,
                 progress: Callable[[int, int], None] | None = None,
                 initializer: Callable[..., None] | None = None, initargs: tuple = ()) -> list[T]:
    """``[fn(job) for job in jobs]``, in at most ``workers`` processes (``fn`` and the jobs must
    pickle); ``progress(done, total)`` is told as jobs finish, in whatever order they do.
    ``initializer(*initargs)`` runs once in each process (in this one when there is no pool): what
    every job needs (a compiled model) travels once per worker, not once per job.

    >>> map_in_order(abs, [-2, 3, -1])
    [2, 3, 1]
    """
    out: list[T] = []
    if workers <= 1 or len(jobs) <= 1:
        if initializer is not None:
            initializer(*initargs)
        for job in jobs:
            out.append(fn(job))
            if progress:
                progress(len(out), len(jobs))
        return out
    from concurrent.futures import ProcessPoolExecutor, as_completed
    with ProcessPoolExecutor(min(workers, len(jobs)), initializer=initializer, initargs=initargs) as pool:
        futures = [pool.submit(fn, job) for job in jobs]
        for done, _ in enumerate(as_completed(futures), 1):
            if progress:
                progress(done, len(jobs))
        return [f.result() for f in futures]
