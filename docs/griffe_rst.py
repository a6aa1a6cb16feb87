"""A griffe extension for the API reference: bgfdi's docstrings are prose in reStructuredText
habits, which Markdown reads differently. At load time, before mkdocstrings renders them:

- a doctest block (``>>>`` lines up to the next blank line) becomes a fenced Python block, where
  Markdown would read ``>>>`` as nested quotes and ``[[...]]`` output as a link;
- a Sphinx role (``:func:`name```, ``:class:`~mod.Name```, ...) becomes an optional cross-reference:
  a link where the name is documented, the name in code where it is not (never a build warning);
- a list right under a line of text gets the blank line Markdown needs to see it as a list;
- a ``*`` between two word characters (``e = R*f``) is a product, not the start of emphasis.

The source is untouched: doctest still runs the examples as written. mkdocs.yml loads this file
in the python handler's ``extensions``; it needs griffe >= 1 (``griffe.Extension``, ``on_instance``).
"""
from __future__ import annotations

import html
import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(func|class|meth|mod|attr|data|obj|exc|const):`(~?)([^`<>]+)`")
PACKAGES = ("bondgraph", "fdi", "optim")
FENCE = re.compile(r"^\s*(```|~~~)")


def doctest_fences(text: str) -> str:
    """Wrap each doctest block (from a ``>>>`` line to the next blank line) in a fence."""
    lines = text.split("\n")
    out: list[str] = []
    i, fenced = 0, False
    while i < len(lines):
        line = lines[i]
        if FENCE.match(line):
            fenced = not fenced
        if fenced or not line.lstrip().startswith(">>>"):
            out.append(line)
            i += 1
            continue
        j = i
        while j < len(lines) and lines[j].strip():
            j += 1
        block = lines[i:j]
        indent = min(len(b) - len(b.lstrip()) for b in block)
        if out and out[-1].strip():
            out.append("")
        out += ["```python", *(b[indent:] for b in block), "```"]
        i = j
    return "\n".join(out)


LIST_ITEM = re.compile(r"\s*(?:[-*+]|\d+[.)])\s")
CODE_SPAN = re.compile(r"(`+)(?:.|\n)*?\1")
PRODUCT = re.compile(r"(?<=\w)\*(?=\w)")


def prose(text: str) -> str:
    """Outside fences: a blank line before a list that follows text, products' asterisks escaped."""
    lines = text.split("\n")
    out: list[str] = []
    fenced = False
    for line in lines:
        if FENCE.match(line):
            fenced = not fenced
        elif not fenced:
            prev = out[-1] if out else ""
            if (LIST_ITEM.match(line) and prev.strip() and not LIST_ITEM.match(prev)
                    and len(prev) - len(prev.lstrip()) <= len(line) - len(line.lstrip())
                    and not prev.startswith((" ", "\t"))):
                out.append("")
            line = "".join(PRODUCT.sub(r"\\*", p) if i % 2 == 0 else p for i, p in enumerate(_spans(line)))
        out.append(line)
    return "\n".join(out)


def _spans(line: str) -> list[str]:
    """A line cut into text and code spans, alternately (text first)."""
    pieces, last = [], 0
    for m in CODE_SPAN.finditer(line):
        pieces += [line[last:m.start()], m.group(0)]
        last = m.end()
    return pieces + [line[last:]]


def _target(obj: griffe.Object, role: str, name: str) -> str:
    if name.split(".")[0] in PACKAGES:
        return name
    if role in ("meth", "attr"):
        owner = obj if obj.is_class else obj.parent
        if owner is not None and owner.is_class:
            return f"{owner.path}.{name}"
    return f"{obj.module.path}.{name}"


def roles(text: str, obj: griffe.Object) -> str:
    """Replace the Sphinx roles outside fences with optional autorefs."""
    parts = re.split(r"(^```.*?^```)", text, flags=re.S | re.M)

    def one(m: re.Match) -> str:
        role, tilde, name = m.groups()
        name = name.strip()
        title = name.rsplit(".", 1)[-1] if tilde else name
        ident = html.escape(_target(obj, role, name), quote=True)
        return f'<autoref identifier="{ident}" optional><code>{html.escape(title)}</code></autoref>'

    return "".join(p if p.startswith("```") else ROLE.sub(one, p) for p in parts)


class RestructuredProse(griffe.Extension):
    """Doctest blocks fenced, Sphinx roles linked, lists and products kept, in every docstring."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        doc = obj.docstring
        if doc is None:
            return
        doc.value = roles(prose(doctest_fences(doc.value)), obj)
