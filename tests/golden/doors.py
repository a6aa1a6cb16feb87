"""Every front door of a diagnosis, each returning the text a user sees: the CLI's JSON, the API's
``to_json`` for a model given as a path, as YAML text and as a Model object, a fleet's report and
the streaming monitor's JSON-lines events (the last one the summary report)."""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

from .cases import Case, model_path


def _cli(argv: list[str]) -> str:
    from fdi.app.cli import main
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(argv)
    assert code in (0, None), (argv, code)
    return out.getvalue()


def _flags(case: Case) -> list[str]:
    flags = [f"--threshold={k}={v!r}" for k, v in case.thresholds]
    return flags + (["--max-set", str(case.max_set)] if case.max_set else [])


def _options(case: Case) -> dict:
    out: dict = {"workers": 1}
    if case.thresholds:
        out["thresholds"] = dict(case.thresholds)
    if case.max_set:
        out["max_set"] = case.max_set
    return out


def cli(case: Case, data: str) -> str:
    return _cli(["diagnose", model_path(case), data, "--json", "-q"] + _flags(case))


def demo(case: Case, data: None) -> str:
    return _cli(["demo", "--json", "-q"])


def api_path(case: Case, data: str) -> str:
    from fdi.api import diagnose
    return diagnose(model_path(case), data, **_options(case)).to_json()


def api_text(case: Case, data: str) -> str:
    from fdi.api import diagnose
    return diagnose(Path(model_path(case)).read_text(encoding="utf-8"), data, **_options(case)).to_json()


def api_model(case: Case, data: str) -> str:
    from bondgraph.loader import load_model
    from fdi.api import diagnose
    return diagnose(load_model(model_path(case)), data, **_options(case)).to_json()


def fleet(case: Case, data: str) -> str:
    from fdi.app.fleet import diagnose_many
    from fdi.options import Options
    (report,) = diagnose_many(model_path(case), [data], Options(**_options(case)))
    report["file"] = Path(report["file"]).name            # the data's folder is a temporary one
    return json.dumps(report, indent=1, default=float) + "\n"


def monitor(case: Case, data: str) -> str:
    return _cli(["monitor", model_path(case), data, "-q"] + _flags(case))


DOORS = {"cli": cli, "demo": demo, "api_path": api_path, "api_text": api_text, "api_model": api_model,
         "fleet": fleet, "monitor": monitor}
