"""Checks the built site as rendered (run by `make docs` after sphinx-build): the API pages show
no empty constructor entry, no table row without its description and no paragraph set as a
bold parameter name; no page shows markup that was not rendered (MyST roles or fences as text,
TeX in a code block) or loads a script from the network.

Usage: python docs/check_pages.py [docs/_build/html]
"""

from __future__ import annotations

import re
import sys
from pathlib import Path


def text(html: str) -> str:
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", "", html)).strip()


def check_api_page(path: Path) -> list[str]:
    page = path.read_text(encoding="utf-8")
    problems = []
    if "__init__" in page:
        problems.append("an __init__ entry")
    for row in re.findall(r'<tr class="row-(?:odd|even)">(.*?)</tr>', page, re.S):
        cells = re.findall(r"<td>(.*?)</td>", row, re.S)
        if len(cells) == 2 and not text(cells[1]):
            problems.append(f"a table row without description: {text(cells[0])!r}")
    for name in re.findall(r"<dt><strong>(.*?)</strong>", page, re.S):
        plain = text(name)
        if "`" in plain or not re.fullmatch(r"\**[A-Za-z_][A-Za-z0-9_]*(, \**[A-Za-z_][A-Za-z0-9_]*)*", plain):
            problems.append(f"a parameter named {plain!r}")
    return problems


def check_page(path: Path) -> list[str]:
    body = path.read_text(encoding="utf-8")
    main = body.split('<article', 1)[-1].split('</article>', 1)[0]
    shown = text(re.sub(r"<pre>.*?</pre>", "", main, flags=re.S))
    problems = []
    if re.search(r'<script[^>]*\ssrc="(https?:)?//', body):
        problems.append("a script loaded from the network")
    if any(re.search(r"[A-Za-z]_\{", text(block)) for block in re.findall(r"<pre>(.*?)</pre>", main, re.S)):
        problems.append("TeX in a code block (write it as $...$ math)")
    for pattern, what in ((r"\{(func|class|meth|mod|ref|doc)\}`", "an unrendered MyST role"),
                          (r"```", "a literal code fence"), (r"\|---", "an unrendered table")):
        if re.search(pattern, shown):
            problems.append(what)
    return problems


def main(argv: list[str]) -> int:
    root = Path(argv[1] if len(argv) > 1 else Path(__file__).parent / "_build" / "html")
    pages = sorted(root.glob("*.html")) + sorted((root / "generated").glob("*.html"))
    if not pages:
        print(f"check_pages: no pages under {root}", file=sys.stderr)
        return 2
    failures = 0
    for page in pages:
        problems = check_page(page) + (check_api_page(page) if page.parent.name == "generated" else [])
        for problem in problems:
            print(f"{page.relative_to(root)}: {problem}", file=sys.stderr)
        failures += len(problems)
    print(f"check_pages: {len(pages)} pages, {failures} problem(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
