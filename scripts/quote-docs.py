#!/usr/bin/env python3
"""Refresh the quoted figures in the README and the pages under docs/ from the reports the
benches and scripts wrote.

Each block between `<!-- quote FILE -->` and `<!-- end quote -->` is replaced by as many
paragraphs (runs of non-blank lines) of FILE as the block holds, starting at the line that
begins with the block's first line (a table's header, or a paragraph's bold lead), so after
regenerating a report, this copies its new lines in. A block whose lines sit in a code fence
keeps the fence. `tests/it/docs.rs` checks the result.

Usage: scripts/quote-docs.py [PAGE.md ...]   (default: README.md and every docs/**/*.md)
"""
import pathlib
import re
import sys

root = pathlib.Path(__file__).resolve().parent.parent
# Markers open a line, as tests/it/docs.rs reads them (a marker quoted inside `code` is not one).
pattern = re.compile(r"^([ \t]*<!-- quote (\S+) -->\n)(.*?)([ \t]*<!-- end quote -->)", re.S | re.M)


def paragraphs(lines):
    """How many runs of non-blank lines `lines` holds."""
    n, inside = 0, False
    for l in lines:
        if l.strip() and not inside:
            n += 1
        inside = bool(l.strip())
    return n


def refresh(page, m):
    start, file, body, end = m.group(1), m.group(2), m.group(3), m.group(4)
    lines = body.splitlines()
    fence = None
    if lines and lines[0].lstrip().startswith("```"):
        fence = lines[0]
        lines = [l for l in lines[1:] if not l.lstrip().startswith("```")]
    anchor = next((l for l in lines if l.strip()), None)
    if anchor is None:
        sys.exit(f"{page}: empty quote of {file}")
    # A paragraph is found by its bold lead alone: the figures after it change.
    if anchor.startswith("**") and "**" in anchor[2:]:
        anchor = anchor[: anchor.index("**", 2) + 2]
    source = (root / file).read_text().splitlines()
    at = next((i for i, l in enumerate(source) if l.startswith(anchor)), None)
    if at is None:
        sys.exit(f"{page}: {file}: no line starts with {anchor!r}")
    want, out = paragraphs(lines), []
    for l in source[at:]:
        if not l.strip():
            if paragraphs(out) == want:
                break
            if out and out[-1] != "":
                out.append("")
            continue
        out.append(l.rstrip())
    while out and out[-1] == "":
        out.pop()
    if fence is not None:
        out = [fence] + out + ["```"]
    return start + "\n".join(out) + "\n" + end


pages = [pathlib.Path(p) for p in sys.argv[1:]] or [root / "README.md"] + sorted(
    (root / "docs").rglob("*.md")
)
for page in pages:
    text = page.read_text()
    n = len(pattern.findall(text))
    if n == 0:
        continue
    page.write_text(pattern.sub(lambda m: refresh(page, m), text))
    print(f"refreshed {n} quotes in {page}")
