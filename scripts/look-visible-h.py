#!/usr/bin/env python3
"""Which part of each fibre the path tracer sees, and what that does to single scattering.

A rasteriser's hair shading (Kami's physical mode) uses the far field: the BSDF averaged
over the whole width of the fibre, offsets h from -1 to 1. In a dense layer of hair seen
at an angle, each fibre hides part of the next one, like shingles: the camera sees a strip
along one edge of most fibres, and the lobes there are not the lobes' mean.

For a `kami bench look` reference scene (an XML it wrote beside its cache, its files
beside it) and blocks of pixels, this script traces camera rays with Mitsuba, and at every
first hit on hair evaluates the `hair` BSDF towards the scene's directional light twice:
as the path tracer does, at the hit's own offset h; and averaged over 32 offsets spread
evenly over the fibre's width at the same hit (both directions turned about the fibre's
axis, which keeps their longitudinal angles and the azimuth between them: the far field a
rasteriser shades with, which `kami bench look`'s single-fibre check ties to Kami's f64 S).
It prints, per block, the share of hits in each quarter of h's range (Mitsuba's sign), and the two means
(direct light only, no shadow rays) times the light's irradiance. --thin N keeps every
N-th curve of each curve file (a sparser groom, in a scratch copy).

Usage: python3 scripts/look-visible-h.py [--rays N] [--thin N] [--out FILE.md] XML X,Y ...
(X,Y: a 32x32 block's top-left pixel; needs scripts/look-deps.sh first)
"""
import argparse
import os
import re
import shutil
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

OFFSETS = 32


def rotate_y(w, a):
    """w (local: y is the fibre's axis) turned by a about y."""
    c, s = np.cos(a), np.sin(a)
    return mi.Vector3f(c * w[0] + s * w[2], w[1], -s * w[0] + c * w[2])


def gamma(w):
    """Mitsuba `hair`'s gamma of a local direction (its `gamma()`)."""
    proj = np.hypot(w[0], w[2])
    g = np.arccos(np.clip(w[2] / proj, -1.0, 1.0)) if proj > 0 else 0.0
    return g if w[0] < 0 else -g


def block(scene, sensor, size, x0, y0, to_light, irradiance, rays, rng):
    ctx = mi.BSDFContext()
    hs, near, far = [], [], []
    for _ in range(rays):
        u = (x0 + 32.0 * rng.random()) / size[0]
        v = (y0 + 32.0 * rng.random()) / size[1]
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(u, v), mi.Point2f(0.5, 0.5))
        si = scene.ray_intersect(ray)
        if not si.is_valid() or si.shape.is_mesh():
            continue
        bsdf = si.bsdf()
        wo = si.to_local(mi.Vector3f(*to_light))
        wi = si.wi
        hs.append(np.sin(gamma(wi)))
        near.append(np.array(bsdf.eval(ctx, si, wo)))
        # The same pair of directions, turned about the fibre so that h sweeps the width
        # (sin gamma uniform: gamma = asin(h)).
        acc = np.zeros(3)
        g0 = gamma(wi)
        for k in range(OFFSETS):
            h = -1.0 + (2.0 * k + 1.0) / OFFSETS
            a = np.arcsin(h) - g0
            s2 = mi.SurfaceInteraction3f(si)
            s2.wi = rotate_y(wi, -a)
            if abs(np.sin(gamma(s2.wi)) - h) > 1e-3:
                s2.wi = rotate_y(wi, a)
                acc += np.array(bsdf.eval(ctx, s2, rotate_y(wo, a)))
            else:
                acc += np.array(bsdf.eval(ctx, s2, rotate_y(wo, -a)))
        far.append(acc / OFFSETS)
    if not hs:
        return None
    hist = np.histogram(hs, bins=4, range=(-1.0, 1.0))[0] / len(hs)
    e = np.asarray(irradiance)
    return len(hs), hist, np.mean(near, axis=0) * e, np.mean(far, axis=0) * e


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("xml")
    p.add_argument("blocks", nargs="+")
    p.add_argument("--rays", type=int, default=1500)
    p.add_argument("--thin", type=int, default=1)
    p.add_argument("--out")
    a = p.parse_args()
    xml = a.xml
    scratch = None
    if a.thin > 1:
        scratch = tempfile.mkdtemp()
        src = os.path.dirname(os.path.abspath(xml))
        text = open(xml).read()
        for name in set(re.findall(r'name="filename" value="([^"]+)"', text)):
            if name.endswith(".txt"):
                curves = open(os.path.join(src, name)).read().split("\n\n")
                with open(os.path.join(scratch, name), "w") as f:
                    f.write("\n\n".join(curves[:: a.thin]))
            else:
                shutil.copy(os.path.join(src, name), scratch)
        xml = os.path.join(scratch, os.path.basename(a.xml))
        shutil.copy(a.xml, xml)
    text = open(xml).read()
    m = re.search(r'<emitter type="directional">.*?name="direction" value="([^"]+)".*?name="irradiance" value="([^"]+)"', text, re.S)
    to_light = -np.array([float(x) for x in m.group(1).split(",")])
    to_light /= np.linalg.norm(to_light)
    irradiance = [float(x) for x in m.group(2).split(",")]
    scene = mi.load_file(xml)
    sensor = scene.sensors()[0]
    size = sensor.film().size()
    rng = np.random.default_rng(1)
    f3 = lambda v: ", ".join(f"{x:.4f}" for x in v)
    lines = [
        f"Written by `python3 scripts/look-visible-h.py --rays {a.rays} --thin {a.thin} {a.xml} {' '.join(a.blocks)}` (Mitsuba {mi.__version__}, `scalar_rgb`).",
        "",
        "| block | hits | share of hits by h: -1 to -0.5, -0.5 to 0, 0 to 0.5, 0.5 to 1 | at the hit's h | over the width (far field) | hit / far, red |",
        "|---|---:|---|---|---|---:|",
    ]
    for b in a.blocks:
        x0, y0 = (int(s) for s in b.split(","))
        r = block(scene, sensor, size, x0, y0, to_light, irradiance, a.rays, rng)
        if r is None:
            lines.append(f"| {b} | 0 | | | | |")
            continue
        n, hist, near, far = r
        lines.append(f"| {b} | {n} | {', '.join(f'{x:.2f}' for x in hist)} | {f3(near)} | {f3(far)} | {near[0] / max(far[0], 1e-12):.2f} |")
    out = "\n".join(lines) + "\n"
    print(out, end="")
    if a.out:
        with open(a.out, "w") as f:
            f.write(out)
    if scratch:
        shutil.rmtree(scratch)


if __name__ == "__main__":
    main()
