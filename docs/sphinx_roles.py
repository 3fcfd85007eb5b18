"""MkDocs hook: the docstrings' Sphinx cross-reference roles (``:func:`name```) shown as code.

mkdocstrings renders the docstrings as Markdown, where a role's backticks become ``<code>`` and
the role's name would stay in the text (":func:" before the name). This hook drops the role and,
as Sphinx does for a ``~`` target, keeps the last component of such a name.
"""

from __future__ import annotations

import re

ROLES = "mod|func|class|meth|attr|data|obj|exc|const|ref|doc|py:[a-z]+"
_ROLE = re.compile(rf":(?:{ROLES}):<code>(~?)([^<]*)</code>")


def plain(html: str) -> str:
    """``html`` with every ``:role:<code>target</code>`` as ``<code>target</code>``."""
    return _ROLE.sub(lambda m: f"<code>{m[2].rsplit('.', 1)[-1] if m[1] else m[2]}</code>", html)


def on_page_content(html, page, config, files):
    return plain(html)
