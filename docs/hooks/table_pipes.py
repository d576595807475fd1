"""mkdocs hook: a `|` written `\\|` inside a code span of a table cell (as GitHub needs it in the
README's commands table) renders as `|`, not `\\|` (Python-Markdown keeps the backslash there)."""

import re

CODE = re.compile(r"<code>(.*?)</code>", re.S)


def on_page_content(html: str, **_) -> str:
    return CODE.sub(lambda m: "<code>" + m.group(1).replace("\\|", "|") + "</code>", html)
