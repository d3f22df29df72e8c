#!/usr/bin/env python3
"""Refresh the README's quoted figures from the reports the benches wrote.

Each block between `<!-- quote FILE -->` and `<!-- end quote -->` is replaced by the
paragraph or table of FILE that starts with the block's first line (a table's header, or
a paragraph's bold lead), so after regenerating a report, this copies its new lines in.
`tests/docs.rs` checks the result. Usage: scripts/quote-docs.py [README.md]
"""
import pathlib
import re
import sys

root = pathlib.Path(__file__).resolve().parent.parent
readme = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else root / "README.md"
text = readme.read_text()
pattern = re.compile(r"(<!-- quote (\S+) -->\n)(.*?)(<!-- end quote -->)", re.S)


def refresh(m):
    start, file, body, end = m.group(1), m.group(2), m.group(3), m.group(4)
    anchor = next((l for l in body.splitlines() if l.strip()), None)
    if anchor is None:
        sys.exit(f"empty quote of {file}")
    # A paragraph is found by its bold lead alone: the figures after it change.
    if anchor.startswith("**") and "**" in anchor[2:]:
        anchor = anchor[: anchor.index("**", 2) + 2]
    lines = (root / file).read_text().splitlines()
    at = next((i for i, l in enumerate(lines) if l.startswith(anchor)), None)
    if at is None:
        sys.exit(f"{file}: no line starts with {anchor!r}")
    out = []
    for l in lines[at:]:
        if not l.strip():
            break
        out.append(l.rstrip())
    return start + "\n".join(out) + "\n" + end


readme.write_text(pattern.sub(refresh, text))
print(f"refreshed {len(pattern.findall(text))} quotes in {readme}")
