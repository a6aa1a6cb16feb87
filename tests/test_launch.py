"""The command's entry point (fdi.app.launch): BLAS on one thread unless the environment says
otherwise, set before numpy's import, for the console script and ``python -m fdi`` alike."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from fdi.app import launch


def test_blas_threads_default_to_one_and_a_users_setting_stands(monkeypatch):
    for name in launch.THREADS:              # set first, so that monkeypatch restores the state before
        monkeypatch.setenv(name, "x")
        monkeypatch.delenv(name)
    monkeypatch.setenv("MKL_NUM_THREADS", "4")
    launch.single_threaded_blas()
    import os
    assert os.environ["OPENBLAS_NUM_THREADS"] == "1" and os.environ["VECLIB_MAXIMUM_THREADS"] == "1"
    assert os.environ["MKL_NUM_THREADS"] == "4"


def test_both_doors_enter_through_the_launcher_before_numpy():
    text = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text(encoding="utf-8")
    scripts = text.split("[project.scripts]", 1)[1].split("\n[", 1)[0]       # (tomllib: Python 3.11 on)
    assert re.findall(r'^bgfdi\s*=\s*"([^"]+)"', scripts, re.M) == ["fdi.app.launch:main"]
    probe = ("import sys, runpy; sys.argv = ['bgfdi', '--help'];\n"
             "import fdi.app.launch as l; seen = {}\n"
             "real = l.single_threaded_blas\n"
             "def spy(): seen['numpy before'] = 'numpy' in sys.modules; real()\n"
             "l.single_threaded_blas = spy\n"
             "try: runpy.run_module('fdi', run_name='__main__')\n"
             "except SystemExit: pass\n"
             "import os; print(seen['numpy before'], os.environ['OPENBLAS_NUM_THREADS'])")
    env = {k: v for k, v in __import__("os").environ.items() if k not in launch.THREADS}
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, timeout=120)
    assert out.stdout.strip().splitlines()[-1] == "False 1", out.stderr[-500:]
