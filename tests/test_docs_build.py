"""The documentation: every relative link of README.md and docs/*.md resolves, and the site with its
API reference builds under ``mkdocs build --strict`` (skipped where the ``docs`` extra is missing)."""
from __future__ import annotations

import importlib.util
import re
import subprocess
import sys

import pytest

from .conftest import ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("**/*.md"))]
FENCE = re.compile(r"^ {0,3}(```|~~~).*?^ {0,3}\1", re.S | re.M)
CODE = re.compile(r"(`+).+?\1", re.S)
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REFERENCE = re.compile(r"^ {0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)", re.M)


def relative_links(text: str) -> list[str]:
    """The link targets of a Markdown text that name a file of the repository (no scheme, no
    bare anchor), outside code."""
    text = CODE.sub("", FENCE.sub("", text))
    targets = LINK.findall(text) + REFERENCE.findall(text)
    return [t for t in targets if not re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:|#", t)]


def test_relative_links_resolve():
    broken = []
    for page in PAGES:
        for target in relative_links(page.read_text(encoding="utf-8")):
            path = target.split("#", 1)[0].split("?", 1)[0]
            if not (page.parent / path).exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_link_finder():
    text = ("[a](docs/a.md) [b](https://x.org) [c](#top) `[d](no.md)` ![e](img/e.png \"t\")\n"
            "```\n[f](no.md)\n```\n[g]: ../g.md\n")
    assert relative_links(text) == ["docs/a.md", "img/e.png", "../g.md"]


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None
                    or importlib.util.find_spec("mkdocstrings_handlers") is None,
                    reason="the docs extra is not installed (pip install -e '.[docs]')")
def test_mkdocs_build_strict(tmp_path):
    out = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict",
                          "-f", str(ROOT / "mkdocs.yml"), "-d", str(tmp_path / "site")],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    for page in ("index.html", "api/bondgraph/index.html", "api/fdi/index.html", "api/optim/index.html"):
        assert (tmp_path / "site" / page).is_file(), page
    api = (tmp_path / "site" / "api" / "fdi" / "index.html").read_text(encoding="utf-8")
    assert 'id="fdi.api.diagnose"' in api and 'id="fdi.api.Diagnosis"' in api


@pytest.mark.skipif(importlib.util.find_spec("griffe") is None, reason="the docs extra is not installed")
def test_docstring_rewrites():
    spec = importlib.util.spec_from_file_location("griffe_rst", ROOT / "docs" / "griffe_rst.py")
    ext = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ext)
    text = "Example:\n    >>> f(1)\n    [[1]]\n\nAfter."
    assert ext.doctest_fences(text) == "Example:\n\n```python\n>>> f(1)\n[[1]]\n```\n\nAfter."
    assert ext.prose("Laws:\n- e = R*f, ``a*b``\n- *this*") == "Laws:\n\n- e = R\\*f, ``a*b``\n- *this*"
    assert ext.prose("```\nx = a*b\n```") == "```\nx = a*b\n```"
    import griffe
    module = griffe.Module("pkg")
    cls = griffe.Class("Thing", parent=module)
    linked = ext.roles(":func:`f` :meth:`go` :class:`~fdi.api.Diagnosis`", cls)
    assert linked == ('<autoref identifier="pkg.f" optional><code>f</code></autoref> '
                      '<autoref identifier="pkg.Thing.go" optional><code>go</code></autoref> '
                      '<autoref identifier="fdi.api.Diagnosis" optional><code>Diagnosis</code></autoref>')
