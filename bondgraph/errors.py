"""The one error type for bad model input: it always says where (file, key, line) and what to change.

>>> str(ModelError("must be more than 0, got -1", file="m.yaml", where="parameters.R.value", line=3))
'm.yaml:3: parameters.R.value: must be more than 0, got -1'
>>> from bondgraph.loader import load_model_text
>>> load_model_text("elements: {r: {type: R, parameter: R}}\\n", "m.yaml")
Traceback (most recent call last):
...
bondgraph.errors.ModelError: m.yaml:1: elements.r.parameter: undefined parameter 'R'; add it under parameters
"""
from __future__ import annotations


class ModelError(Exception):
    """A user mistake in a model file, printed as one line by the CLI (exit code 2)."""

    def __init__(self, message: str, *, file: str | None = None, where: str | None = None,
                 line: int | None = None) -> None:
        self.message = message
        self.file = file
        self.where = where
        self.line = line
        super().__init__(str(self))

    def __str__(self) -> str:
        loc = self.file or "<model>"
        if self.line is not None:
            loc += f":{self.line}"
        if self.where:
            loc += f": {self.where}"
        return f"{loc}: {self.message}"


class CausalityError(Exception):
    """Causality could not be assigned as required; lists every conflict by junction and bond."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("; ".join(problems))
