#!/usr/bin/env python3
"""The key light's share of a close-up, Kami's and the path tracer's, and the path
tracer's split of it into single and multiple scattering.

In `kami bench look`'s close-ups the side and back lights do not reach the visible hair, so
the key light's own contribution is the key image minus the side one (linear RGB), for
Kami's images and for the references alike (both from the bench's cache, physical mode with
shadows: `<cache>/scene_<scene>/close/kami_<scene>_close_<light>_physical_on.png` and its
`.maps/reference0.png`). The path tracer's single scattering of the key light is rendered
here from the bench's `key.xml` without its environment, with paths of two vertices (direct
light, shadow rays and all); the rest of its key part is multiple scattering. Prints the
means over the frame (linear RGB, 8-bit images decoded) and, per 32x32 block, the luminance
of each (x 1000).

Usage: python3 scripts/look-key-split.py [--spp N] [--cache DIR] [--out FILE.md] SCENE...
(SCENE: bob, fur_polyline, strips; needs scripts/look-deps.sh and a `kami bench look` run)
"""
import argparse
import os
import re
import tempfile

import flip_evaluator as fe
import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def lin(a):
    return np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)


def load(path):
    return lin(fe.load(path).astype(np.float64))


def key_single(xml, spp):
    text = open(xml).read()
    text = re.sub(r'<emitter type="constant">.*?</emitter>', "", text, flags=re.S)
    text = re.sub(r'(<integer name="sample_count" value=")\d+(")', rf"\g<1>{spp}\2", text)
    text = re.sub(r'(<integer name="max_depth" value=")\d+(")', r"\g<1>2\2", text)
    fd, path = tempfile.mkstemp(suffix=".xml", dir=os.path.dirname(xml))
    with os.fdopen(fd, "w") as f:
        f.write(text)
    try:
        return np.array(mi.render(mi.load_file(path)))[..., :3]
    finally:
        os.remove(path)


def blocks(img):
    y = img @ np.array([0.2126, 0.7152, 0.0722])
    return [" ".join(f"{1000 * y[r:r + 32, c:c + 32].mean():4.0f}" for c in range(0, y.shape[1], 32))
            for r in range(0, y.shape[0], 32)]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenes", nargs="+")
    p.add_argument("--spp", type=int, default=32)
    p.add_argument("--cache", default="bench_out/look-cache")
    p.add_argument("--out")
    a = p.parse_args()
    out = [f"Written by `python3 scripts/look-key-split.py --spp {a.spp} --cache {a.cache} {' '.join(a.scenes)}` (Mitsuba {mi.__version__}, `scalar_rgb`).", ""]
    f3 = lambda v: ", ".join(f"{1000 * x:.1f}" for x in v)
    table = ["| scene | Kami's key part | the path tracer's key part | its single scattering | its multiple scattering |",
             "|---|---|---|---|---|"]
    detail = []
    for s in a.scenes:
        d = os.path.join(a.cache, f"scene_{s}", "close")
        k = lambda light: os.path.join(d, f"kami_{s}_close_{light}_physical_on")
        kami = load(k("key") + ".png") - load(k("side") + ".png")
        ref = load(k("key") + ".maps/reference0.png") - load(k("side") + ".maps/reference0.png")
        single = key_single(os.path.join(d, "key.xml"), a.spp)
        mean = lambda img: img.reshape(-1, 3).mean(0)
        table.append(f"| {s} | {f3(mean(kami))} | {f3(mean(ref))} | {f3(mean(single))} | {f3(mean(ref) - mean(single))} |")
        for name, img in (("Kami's key part", kami), ("the path tracer's key part", ref),
                          ("its single scattering", single)):
            detail += ["", f"{s}, {name} (luminance x 1000 per 32x32 block):", "", "```"] + blocks(img) + ["```"]
    text = "\n".join(out + ["Means over the frame, linear RGB x 1000:", ""] + table + detail) + "\n"
    print(text, end="")
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
