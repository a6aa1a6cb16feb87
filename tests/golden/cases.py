"""The cases of tests/test_golden.py: the four reference files of the paper's CyCab, the demo,
and a model of each kind (electromechanical, hydraulic, a commanded valve's mode fault, a
switched converter with an autonomous diode, a chamber modulated by a measured position)."""
from __future__ import annotations

import gzip
import shutil
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

ALL = ("cli", "api_path", "api_text", "api_model", "fleet", "monitor")
# The API given the model as YAML text or as a Model object is the API given its path once the model
# is read: those two doors run on two cases (the paper's scenario 2 and a commanded valve's mode
# fault), every other door on every case (they took 40 s of the suite's CPU on the other seven)
MOST = ("cli", "api_path", "fleet", "monitor")


@dataclass(frozen=True)
class Case:
    name: str
    model: str                          # models/<model>.yaml
    data: str | None                    # models/data/... (plain CSV) or tests/golden/<name>.csv.gz
    thresholds: tuple[tuple[str, float], ...] = ()
    max_set: int | None = None
    doors: tuple[str, ...] = ALL


CASES = (
    Case("cycab_nominal", "cycab_steering", "models/data/cycab/nominal.csv", doors=MOST),
    Case("cycab_scenario1", "cycab_steering", "models/data/cycab/scenario1.csv", doors=MOST),
    Case("cycab_scenario2", "cycab_steering", "models/data/cycab/scenario2.csv"),
    Case("cycab_scenario3", "cycab_steering", "models/data/cycab/scenario3.csv", doors=MOST),
    Case("demo", "cycab_steering", None, doors=("demo",)),
    Case("drive_crack", "electromechanical_drive", "drive_crack.csv.gz", doors=MOST),
    Case("hydraulic_clog", "hydraulic_actuator", "hydraulic_clog.csv.gz", doors=MOST),
    Case("tank_stuck_open", "two_tank_commanded", "tank_stuck_open.csv.gz"),
    # thresholds: bgfdi calibrate on the nominal runs of tests/test_domain_converter.py and _modulated.py
    Case("boost_rL", "boost_converter", "boost_rL.csv.gz",
         (("ARR1", 1.435632704078511), ("ARR2", 1.374877588999531)), doors=MOST),
    Case("chamber_wear", "variable_volume_actuator", "chamber_wear.csv.gz",
         (("ARR1", 0.10553728534420034), ("ARR2", 1.461763469351658e-07)), max_set=1, doors=MOST),
)


def model_path(case: Case) -> str:
    return str(ROOT / "models" / f"{case.model}.yaml")


def data_file(case: Case, tmp: Path) -> str | None:
    """The case's measurement CSV (decompressed into ``tmp`` when stored gzipped)."""
    if case.data is None:
        return None
    if not case.data.endswith(".gz"):
        return str(ROOT / case.data)
    out = tmp / case.data[:-3]
    if not out.exists():
        with gzip.open(HERE / case.data, "rb") as src, open(out, "wb") as dst:
            shutil.copyfileobj(src, dst)
    return str(out)
