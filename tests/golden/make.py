"""Regenerates the golden reports of tests/test_golden.py: run ONCE, before a restructuring
(issue 21), to record what every front door printed; the test then asserts that nothing the
user sees changed. Not run by the test suite.

    python tests/golden/make.py data      # the measurement files (csv.gz), from independent
                                          # simulators (tests/independent) and bgfdi simulate
    python tests/golden/make.py reports   # every front door's output for every case
"""
from __future__ import annotations

import gzip
import io
import json
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))

from tests.golden.cases import CASES, data_file  # noqa: E402


def write_csv_gz(path: Path, cols: dict) -> None:
    import numpy as np
    names = list(cols)
    table = np.column_stack([np.asarray(cols[n], dtype=float) for n in names])
    buf = io.StringIO()
    buf.write(",".join(names) + "\n")
    np.savetxt(buf, table, delimiter=",", fmt="%.17g")
    with gzip.open(path, "wt", encoding="utf-8", compresslevel=9) as fh:
        fh.write(buf.getvalue())


def make_data() -> None:
    from tests.independent import boost, chamber
    write_csv_gz(HERE / "boost_rL.csv.gz",
                 boost.simulate(0.01, noise=0.01, seed=4, x0=(8.0, 22.0), changes={"rL": (0.005, 0.5)}))
    write_csv_gz(HERE / "chamber_wear.csv.gz", chamber.simulate(12.0, 4, pump_rate=(4.0, -0.05)))
    for name, model, scenario in (("drive_crack", "electromechanical_drive", "drive_shaft_crack.json"),
                                  ("hydraulic_clog", "hydraulic_actuator", "hydraulic_clogging.json"),
                                  ("tank_stuck_open", "two_tank_commanded", "suite_two_tank_commanded/stuck_open.json")):
        out = HERE / f"{name}.csv"
        subprocess.run([sys.executable, "-m", "fdi.app.cli", "simulate", str(ROOT / "models" / f"{model}.yaml"),
                        str(ROOT / "models" / "scenarios" / scenario), "-o", str(out), "-q"], check=True, cwd=ROOT)
        with open(out, "rb") as src, gzip.open(HERE / f"{name}.csv.gz", "wb", compresslevel=9) as dst:
            dst.write(src.read())
        out.unlink()


def make_reports(tmp: Path) -> None:
    from tests.golden.doors import DOORS
    expected = {}
    for case in CASES:
        data = data_file(case, tmp)
        import time
        expected[case.name] = {}
        for door, run in DOORS.items():
            if door in case.doors:
                t = time.perf_counter()
                expected[case.name][door] = run(case, data)
                print(f"  {door} {time.perf_counter() - t:.1f} s", flush=True)
        print(case.name, {k: len(v) for k, v in expected[case.name].items()}, flush=True)
    for doors in expected.values():          # the monitor's identification_s is wall time (test_golden.timed)
        if "monitor" in doors:
            doors["monitor"] = re.sub(r', "identification_s": [0-9.eE+-]+', "", doors["monitor"])
    (HERE / "expected.json").write_text(json.dumps(expected, indent=0, sort_keys=True) + "\n", encoding="utf-8")


if __name__ == "__main__":
    import tempfile
    if sys.argv[1] == "data":
        make_data()
    else:
        with tempfile.TemporaryDirectory() as tmp:
            make_reports(Path(tmp))
