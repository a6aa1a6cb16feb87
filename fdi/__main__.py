"""``python -m fdi``: the ``bgfdi`` command line, the same entry point as the console script
(:mod:`fdi.app.launch`: the process's settings before numpy's import, then the CLI)."""
from __future__ import annotations

from fdi.app.launch import main

if __name__ == "__main__":
    raise SystemExit(main())
