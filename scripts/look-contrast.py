#!/usr/bin/env python3
"""Fine-scale contrast of Kami's and the path tracer's hair in `kami bench look`'s pairs.

For each pair PNG (Kami at x 0-255, Mitsuba at 260-515, the masks at 780-1035: grey where
both images show hair or head), takes each image's linear luminance, its log's difference
from a Gaussian blur of it (sigma 1.5 and 4 pixels: detail finer than the blur), and over
the mask shrunk by 3 pixels (no silhouette) prints the standard deviation of that detail in
each image and the correlation between the two. A smooth image has a small deviation; an
image whose detail lies where the reference's does has a correlation near 1. Last, the
hair-pixel FLIP (as `kami bench look` measures it) of Kami's image with its colour matched
to the reference's over a 4-pixel blur (each linear channel times the ratio of the two
images' blurs over the mask): what is left once every shading error broader than that is
taken away. What docs/shading.md ("Strands that differ") and docs/look.md quote.

Usage: python3 scripts/look-contrast.py [--out FILE.md] PAIR.png...
A PAIR of the form REV:PATH is read from git (`git show REV:PATH`), for a report before a
change. Needs scripts/look-deps.sh first (Mitsuba reads the PNGs).
"""
import os
import subprocess
import sys
import tempfile

import flip_evaluator as fe
import mitsuba as mi
import numpy as np

SIGMAS = (1.5, 4.0)


def blur(a, s):
    r = int(3 * s) + 1
    x = np.arange(-r, r + 1)
    g = np.exp(-x * x / (2 * s * s))
    g /= g.sum()
    pad = np.pad(a, r, mode="edge")
    a = np.apply_along_axis(lambda v: np.convolve(v, g, "valid"), 0, pad)
    return np.apply_along_axis(lambda v: np.convolve(v, g, "valid"), 1, a)


def linear(a):
    return np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)


def srgb(a):
    a = np.clip(a, 0.0, 1.0)
    return np.where(a <= 0.0031308, 12.92 * a, 1.055 * a ** (1 / 2.4) - 0.055)


def matched_flip(p, mask, s=4.0):
    kami, ref = linear(p[:, 0:256]), linear(p[:, 260:516])
    w = blur(mask.astype(np.float64), s)[..., None] + 1e-6
    bk = np.stack([blur(kami[..., c] * mask, s) for c in range(3)], -1) / w
    br = np.stack([blur(ref[..., c] * mask, s) for c in range(3)], -1) / w
    matched = srgb(kami * br / np.maximum(bk, 1e-6))
    err, _, _ = fe.evaluate(
        p[:, 260:516].astype(np.float32), matched.astype(np.float32), "LDR", applyMagma=False
    )
    return float(err[mask].mean())


def read_pair(path):
    """The pair's file, or for REV:PATH the file at that git revision."""
    if ":" not in path or os.path.exists(path):
        return mi.Bitmap(path)
    rev, name = path.split(":", 1)
    data = subprocess.run(["git", "show", f"{rev}:{name}"], capture_output=True)
    if data.returncode != 0:
        sys.exit(f"{path}: git show failed: {data.stderr.decode().strip()}")
    with tempfile.NamedTemporaryFile(suffix=".png") as f:
        f.write(data.stdout)
        f.flush()
        return mi.Bitmap(f.name)


def contrast(path):
    bmp = read_pair(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True)
    p = np.array(bmp).astype(np.float64) / 255.0
    if p.shape[1] < 1036:
        sys.exit(f"{path}: {p.shape[1]} pixels wide, not a `kami bench look` pair (1036)")
    kami = linear(p[:, 0:256]).mean(-1)
    ref = linear(p[:, 260:516]).mean(-1)
    mask = p[:, 780:1036, 0] > 0.3
    inner = np.ones_like(mask)
    for dy in (-3, 0, 3):
        for dx in (-3, 0, 3):
            inner &= np.roll(np.roll(mask, dy, 0), dx, 1)
    if inner.sum() < 100:
        sys.exit(f"{path}: only {inner.sum()} pixels inside the mask")
    row = []
    for s in SIGMAS:
        dk = np.log(kami + 1e-3) - np.log(blur(kami, s) + 1e-3)
        dr = np.log(ref + 1e-3) - np.log(blur(ref, s) + 1e-3)
        a, b = dk[inner], dr[inner]
        row += [a.std(), b.std(), np.corrcoef(a, b)[0, 1]]
    return row + [matched_flip(p, mask)]


def main():
    args = sys.argv[1:]
    out = None
    if "--out" in args:
        i = args.index("--out")
        out = args[i + 1]
        del args[i : i + 2]
    if not args:
        sys.exit(__doc__)
    head = "| pair | " + " | ".join(
        f"Kami sd {s} | reference sd {s} | correlation {s}" for s in SIGMAS
    ) + " | FLIP hair, colour matched over 4 px |"
    lines = [head, "|---|" + "---:|" * (3 * len(SIGMAS) + 1)]
    for path in args:
        row = contrast(path)
        name = os.path.basename(path)[:-4]
        lines.append(f"| {name} | " + " | ".join(f"{v:.3f}" for v in row) + " |")
        print(name.ljust(40), " ".join(f"{v:.3f}" for v in row))
    if out:
        cmd = "python3 scripts/look-contrast.py --out " + out + " " + " ".join(args)
        text = f"Written by `{cmd}`.\n\n" + "\n".join(lines) + "\n"
        with open(out, "w") as f:
            f.write(text)
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
