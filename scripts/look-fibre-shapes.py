#!/usr/bin/env python3
"""One fibre, Mitsuba's `hair` BSDF on a `linearcurve` and on a `bsplinecurve`.

Mitsuba 3's `hair` BSDF reads the fibre's axis from its shading frame's second axis
(`sin theta = w.y`). `bsplinecurve` sets that axis to the curve's tangent; `linearcurve`
sets the first one to it, so on a `linearcurve` the BSDF scatters as if the fibre ran
around its own circumference. This script shows it on the single fibre `kami bench look`
checks before any reference (`write_fibre_check` in src/bench/look/mitsuba.rs): a straight
fibre along x of Mitsuba's default brown hair, an orthographic camera on +z, one
directional light of unit irradiance from each of the bench's four directions
(`FIBRE_LIGHTS`), direct light only. It prints the mean radiance over the fibre's pixels
(the sum of RGB over the sum of alpha) for both shapes and their ratio. The bench compares
the `bsplinecurve` one with Kami's f64 S (its report's *Single fibre*); docs/look.md, "The
reference's fibres lay crosswise", quotes this table.

Usage: python3 scripts/look-fibre-shapes.py [--spp N] [--out FILE.md]
(needs scripts/look-deps.sh first)
"""
import argparse
import os
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

# As src/bench/look/mitsuba.rs writes them.
LIGHTS = [(0.0, 0.0, 1.0), (0.0, 1.0, 1.0), (0.5, 0.5, 1.0), (0.0, 0.3, -1.0)]
RADIUS = 0.01
POINTS = [(-5.0, 0.0, 0.0), (0.5, 0.0, 0.0), (5.0, 0.0, 0.0)]


def curve_file(shape, path):
    with open(path, "w") as f:
        for k, p in enumerate(POINTS):
            times = 1 if shape == "linearcurve" else (3 if k in (0, len(POINTS) - 1) else 2)
            for _ in range(times):
                f.write(f"{p[0]} {p[1]} {p[2]} {RADIUS}\n")


def mean_radiance(shape, towards, spp, path):
    t = np.array(towards, float)
    t /= np.linalg.norm(t)
    half = 2.0 * RADIUS
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2, "hide_emitters": True},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0.3, 0, 1], target=[0.3, 0, 0], up=[0, 1, 0])
            @ mi.ScalarTransform4f().scale([half, half, 1.0]),
            "film": {"type": "hdrfilm", "width": 32, "height": 32, "pixel_format": "rgba",
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "light": {"type": "directional", "direction": (-t).tolist(),
                  "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
        "fibre": {"type": shape, "filename": path,
                  "bsdf": {"type": "hair", "eumelanin": 1.3, "pheomelanin": 0.2,
                           "longitudinal_roughness": 0.3, "azimuthal_roughness": 0.3,
                           "scale_tilt": 2.0, "int_ior": 1.55, "ext_ior": 1.0}},
    })
    img = np.array(mi.render(scene))
    return img[..., :3].reshape(-1, 3).sum(0) / img[..., 3].sum()


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--out")
    a = p.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for towards in LIGHTS:
            got = {}
            for shape in ("linearcurve", "bsplinecurve"):
                path = os.path.join(d, f"{shape}.txt")
                curve_file(shape, path)
                got[shape] = mean_radiance(shape, towards, a.spp, path)
            rows.append((towards, got["linearcurve"], got["bsplinecurve"]))
    f3 = lambda v, d=5: ", ".join(f"{x:.{d}f}" for x in v)
    md = [
        f"Written by `python3 scripts/look-fibre-shapes.py --spp {a.spp}` (Mitsuba {mi.__version__}, `scalar_rgb`).",
        "",
        "| towards the light | `linearcurve` | `bsplinecurve` | linear / bspline |",
        "|---|---|---|---|",
    ]
    for towards, lin, bsp in rows:
        md.append(f"| {towards} | {f3(lin)} | {f3(bsp)} | {f3(lin / bsp, 2)} |")
    text = "\n".join(md) + "\n"
    print(text, end="")
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
