"""mkdocs hooks (mkdocs.yml ``hooks``): the pages' Markdown as the site's Markdown reads it.

docs/tutorial.md names the file each example block is written to in the fence's info string
(```yaml file=rc.yaml, read by tests/test_tutorial.py); Python-Markdown's fenced_code takes
only a language there and would print such a block as a paragraph. The site keeps the language.
"""
from __future__ import annotations

import re

INFO = re.compile(r"^(?P<fence> {0,3}(?:`{3,}|~{3,}))(?P<lang>[\w#.+-]+)[ \t]+(?:\w+=\S+[ \t]*)+$", re.M)


def on_page_markdown(markdown: str, **kwargs) -> str:
    return INFO.sub(r"\g<fence>\g<lang>", markdown)
