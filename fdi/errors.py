"""User-facing errors shared by the CLI and the optional modules."""
from __future__ import annotations


class UsageError(Exception):
    """A bad command-line value or a missing optional dependency: one line, exit code 2."""


def need_matplotlib() -> UsageError:
    return UsageError("plots need matplotlib: pip install 'bgfdi[plot]'")
