"""``python -m fdi``: the ``bgfdi`` command line, the same ``main`` as the console script."""
from __future__ import annotations

from fdi.app.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
