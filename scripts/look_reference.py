#!/usr/bin/env python3
"""The path-traced side of `kami bench look` (docs/look.md).

Kami writes the scene as Mitsuba 3 XML (curves, head, skin, camera, lights: src/bench/look.rs)
and calls this script once per row with Kami's own image. The script renders the reference
twice (seeds 0 and 1) with Mitsuba's `scalar_rgb` variant, composites it over the background
and encodes it to 8-bit sRGB with the curve Kami's resolve uses, then prints the mean FLIP of
Kami's image against seed 0, the mean FLIP of seed 1 against seed 0 (the reference's own
noise), and writes the side-by-side image Kami | Mitsuba | FLIP map. Into --maps it writes
what Kami's side needs for the figures over the hair's own pixels (src/bench/look/hair.rs):
both seeds' 8-bit images (`reference0.png`, `reference1.png`) and the two FLIP maps, one
value per pixel, as raw little-endian f32 rows (`flip.f32`: Kami against seed 0,
`noise.f32`: seed 1 against seed 0).

References are cached in --cache by a SHA-256 of everything they depend on (the XML, every
file it names, spp, seed, Mitsuba's version): a rerun renders nothing again.

Needs `pip install mitsuba flip-evaluator numpy` (scripts/look-deps.sh).

With --fibre it renders the single-fibre check Kami writes before any reference
(`write_fibre_check` in src/bench/look/mitsuba.rs: one fibre, one directional light, direct
light only) once, seed 0, cached the same way, and prints the mean radiance over the fibre's
pixels (the sum of its RGB over the sum of its alpha), which Kami compares with its f64 S.

Usage: look_reference.py --xml SCENE.xml --background R,G,B --spp N --kami KAMI.png
                         --pair OUT.png --cache DIR --maps DIR
       look_reference.py --fibre --xml FIBRE.xml --spp N --cache DIR
Prints: flip=F noise=N reference_s=S cached=0|1
        (--fibre) radiance=R,G,B
"""
import argparse
import hashlib
import pathlib
import re
import sys
import time

try:
    import numpy as np
    import mitsuba as mi
    import flip_evaluator as flip
except ImportError as e:  # the Rust side checks first; this is for direct use
    sys.exit(f"look_reference.py: {e}: run scripts/look-deps.sh "
             "(pip install mitsuba flip-evaluator numpy)")

# The LLVM variants may crash on a 2-core machine without a JIT; the scalar one runs anywhere.
mi.set_variant("scalar_rgb")


def srgb_encode(linear):
    """Linear [0, 1] to sRGB, the curve of shaders/stage/downsample.wgsl (and of an
    Rgba8UnormSrgb target)."""
    c = np.clip(linear, 0.0, 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def srgb_decode(c):
    return np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))


def inputs_hash(xml, spp, seed):
    h = hashlib.sha256()
    text = xml.read_bytes()
    h.update(text)
    for name in sorted(set(re.findall(rb'name="filename" value="([^"]+)"', text))):
        h.update(name)
        h.update((xml.parent / name.decode()).read_bytes())
    h.update(f"spp={spp} seed={seed} mitsuba={mi.__version__}".encode())
    return h.hexdigest()[:24]


def reference(xml, spp, seed, cache):
    """Linear RGBA (premultiplied: missed rays are 0) of the scene and the seconds its render
    took (the cached record's when it comes from the cache)."""
    key = inputs_hash(xml, spp, seed)
    path = cache / f"{key}.npy"
    took = cache / f"{key}.seconds"
    if path.exists() and took.exists():
        return np.load(path), float(took.read_text()), True
    t = time.time()
    scene = mi.load_file(str(xml))
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float32)
    seconds = time.time() - t
    cache.mkdir(parents=True, exist_ok=True)
    np.save(path, img)
    took.write_text(f"{seconds:.1f}\n")
    return img, seconds, False


def to_srgb8(rgba, background):
    """Composite over the background (linear) and encode as Kami's output is: 8-bit sRGB."""
    rgb, a = rgba[..., :3], np.clip(rgba[..., 3:4], 0.0, 1.0)
    lin = rgb + (1.0 - a) * srgb_decode(np.asarray(background, dtype=np.float32))
    return np.round(srgb_encode(lin) * 255.0).astype(np.uint8)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--xml", type=pathlib.Path, required=True)
    p.add_argument("--spp", type=int, required=True)
    p.add_argument("--cache", type=pathlib.Path, required=True)
    p.add_argument("--fibre", action="store_true", help="the single-fibre check")
    p.add_argument("--background", help="sRGB R,G,B in 0..1")
    p.add_argument("--kami", type=pathlib.Path)
    p.add_argument("--pair", type=pathlib.Path)
    p.add_argument("--maps", type=pathlib.Path)
    a = p.parse_args()
    if a.fibre:
        img, _, _ = reference(a.xml, a.spp, 0, a.cache)
        alpha = float(img[..., 3].sum())
        if not alpha > 0.0:
            sys.exit(f"{a.xml}: the fibre covers no pixel")
        rgb = img[..., :3].reshape(-1, 3).sum(0) / alpha
        print("radiance=" + ",".join(f"{x:.7g}" for x in rgb))
        return
    missing = [n for n in ("background", "kami", "pair", "maps") if getattr(a, n) is None]
    if missing:
        p.error("needs " + ", ".join("--" + n for n in missing) + " (or --fibre)")
    bg = [float(x) for x in a.background.split(",")]
    if len(bg) != 3:
        sys.exit(f"--background {a.background!r}: need R,G,B")

    seconds = 0.0
    cached = True
    refs = []
    for seed in (0, 1):
        img, s, c = reference(a.xml, a.spp, seed, a.cache)
        seconds += s
        cached = cached and c
        refs.append(to_srgb8(img, bg))
    kami = np.array(mi.Bitmap(str(a.kami)), dtype=np.uint8)[..., :3]
    if kami.shape != refs[0].shape:
        sys.exit(f"{a.kami}: {kami.shape[1]}x{kami.shape[0]}, but the reference is "
                 f"{refs[0].shape[1]}x{refs[0].shape[0]}")
    f = lambda img: img.astype(np.float32) / 255.0
    # The error maps themselves (one value per pixel) for the means; the magma picture apart.
    fmap, mean, _ = flip.evaluate(f(refs[0]), f(kami), "LDR", applyMagma=False)
    nmap, noise, _ = flip.evaluate(f(refs[0]), f(refs[1]), "LDR", applyMagma=False)
    magma, _, _ = flip.evaluate(f(refs[0]), f(kami), "LDR", computeMeanError=False)
    a.maps.mkdir(parents=True, exist_ok=True)
    for k, r in enumerate(refs):
        mi.Bitmap(r).write(str(a.maps / f"reference{k}.png"))
    for name, m in (("flip.f32", fmap), ("noise.f32", nmap)):
        np.asarray(m, dtype="<f4").reshape(kami.shape[:2]).tofile(a.maps / name)
    fmap8 = np.round(np.clip(np.asarray(magma), 0.0, 1.0) * 255.0).astype(np.uint8)
    gap = np.full((kami.shape[0], 4, 3), 255, dtype=np.uint8)
    pair = np.concatenate([kami, gap, refs[0], gap, fmap8], axis=1)
    a.pair.parent.mkdir(parents=True, exist_ok=True)
    mi.Bitmap(pair).write(str(a.pair))
    print(f"flip={mean:.6f} noise={noise:.6f} reference_s={seconds:.1f} cached={int(cached)}")


if __name__ == "__main__":
    main()
