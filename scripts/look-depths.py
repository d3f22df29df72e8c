#!/usr/bin/env python3
"""Split the path tracer's light on the hair into single and multiple scattering.

Renders one of `kami bench look`'s reference scenes (an XML it wrote beside its cache,
`<cache>/scene_<scene>/<view>/<light>.xml`) with Mitsuba's `path` integrator three times,
with paths of at most 2, 3 and 24 vertices, and prints the mean linear RGB over the pixels
the hair or head fully covers (alpha above 0.99). Under a light that does not reach the
visible hair (a close-up's side or back light), depth 2 is the environment's single
scattering and 24 minus 2 its multiple scattering: what docs/shading.md ("The ambient
colour") compares Kami's ambient terms with.

Usage: python3 scripts/look-depths.py [--spp N] [--out FILE.md] XML...
(needs scripts/look-deps.sh first). With --out, also a Markdown table, one row per XML.
"""
import os
import re
import sys
import tempfile

import mitsuba as mi
import numpy as np


def means(xml, spp):
    text = open(xml).read()
    if 'name="max_depth"' not in text or 'name="sample_count"' not in text:
        sys.exit(f"{xml}: not a `kami bench look` reference (no max_depth or sample_count)")
    text = re.sub(r'(<integer name="sample_count" value=")\d+(")', rf"\g<1>{spp}\2", text)
    out = {}
    for depth in (2, 3, 24):
        t = re.sub(r'(<integer name="max_depth" value=")\d+(")', rf"\g<1>{depth}\2", text)
        # Written beside the original: its files are named relative to it.
        fd, path = tempfile.mkstemp(suffix=".xml", dir=os.path.dirname(xml))
        with os.fdopen(fd, "w") as f:
            f.write(t)
        try:
            img = np.array(mi.render(mi.load_file(path)))
        finally:
            os.remove(path)
        mask = img[..., 3] > 0.99
        if not mask.any():
            sys.exit(f"{xml}: no pixel is covered")
        out[depth] = img[..., :3][mask].mean(0)
        print(f"{xml} depth {depth:2}: {np.round(out[depth], 4)}", flush=True)
    return out


def main():
    args = sys.argv[1:]
    spp, out = 32, None
    xmls = []
    i = 0
    while i < len(args):
        if args[i] == "--spp":
            spp = int(args[i + 1])
            i += 2
        elif args[i] == "--out":
            out = args[i + 1]
            i += 2
        elif args[i].startswith("-"):
            sys.exit(__doc__)
        else:
            xmls.append(args[i])
            i += 1
    if not xmls:
        sys.exit(__doc__)
    mi.set_variant("scalar_rgb")
    rows = []
    for x in xmls:
        xml = os.path.abspath(x)
        if not os.path.isfile(xml):
            sys.exit(f"{xml}: no such file (run `kami bench look` first; it writes the XMLs)")
        m = means(xml, spp)
        name = "/".join(xml.split(os.sep)[-3:])
        rows.append((name, m[2], m[24] - m[2], m[24]))
    if out:
        fmt = lambda v: ", ".join(f"{c:.4f}" for c in v)
        with open(out, "w") as f:
            f.write("### The path tracer's light on the hair: single and multiple scattering\n\n")
            f.write(f"Written by `python3 scripts/look-depths.py --spp {spp} --out {out} "
                    f"{' '.join(xmls)}` with Mitsuba {mi.__version__} (`scalar_rgb`).\n\n")
            f.write("Mean linear RGB over the pixels the hair or head fully covers (alpha above "
                    "0.99). *single*: paths of at most 2 vertices (the light and the "
                    "environment scattered once); *multiple*: all paths (24) minus single.\n\n")
            f.write("| reference | single | multiple | all |\n|---|---|---|---|\n")
            for name, s1, mu, a in rows:
                f.write(f"| `{name}` | {fmt(s1)} | {fmt(mu)} | {fmt(a)} |\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
