#!/usr/bin/env python3
"""Writes the skeletons of the shipped toon scenes (assets/scenes/toon*.ron): wisps laid on
an offset shell of the head ellipsoid, hanging below it, tapering to pointed tips. Run from
the repository root; the scenes' other blocks are written here too, so edit this file, not
the scenes."""
import math

A, B, C = 9.6, 11.5, 7.8  # head radii (x front, y up, z side)
# Weight of every node: with the threshold 0.5 the visible radius is 0.67 r (eq 9), so the
# influence (and the ray march's work) reaches only half as far again as the surface.
W = 2.5


def shell(theta, phi, off, radii=(A, B, C)):
    a, b, c = radii
    t, p = math.radians(theta), math.radians(phi)
    return ((a + off) * math.sin(t) * math.cos(p), (b + off) * math.cos(t),
            (c + off) * math.sin(t) * math.sin(p))


def wisp(phi, thetas, drop, r0, r1, off=1.0, out=0.0, curl=0.0, radii=(A, B, C)):
    """Nodes on the shell at `thetas`, then `drop` straight below the last, tapering."""
    pts = [shell(th, phi, off if i else 0.3, radii) for i, th in enumerate(thetas)]
    last = pts[-1]
    p = math.radians(phi)
    for k, d in enumerate(drop):
        s = (k + 1) / len(drop)
        pts.append((last[0] + math.cos(p) * (out * s + curl * s * s),
                    last[1] - d, last[2] + math.sin(p) * (out * s + curl * s * s)))
    n = len(pts)
    nodes = []
    for i, q in enumerate(pts):
        s = i / (n - 1)
        r = r0 + (r1 - r0) * s ** 1.3
        nodes.append(f"Node(p: ({q[0]:.3f}, {q[1]:.3f}, {q[2]:.3f}), r: {r:.3f}, w: {W})")
    return nodes


def skel(name, nodes):
    inner = ",\n                ".join(nodes)
    return f"""        Skeleton(
            name: "{name}",
            nodes: [
                {inner},
            ],
        ),"""


def toon_wisps(radii=(A, B, C), lift=0.0):
    """The toon look's wisps on the shell of the ellipsoid `radii`, the nodes after the
    root `lift` further out."""
    out = []
    # Bangs over the forehead (the face looks along +x), pointed tips at eye level.
    for i, phi in enumerate([-42, -28, -14, 0, 14, 28, 42]):
        out.append(skel(f"bang {i}", wisp(phi, [8, 35, 58, 74], [], 2.9, 0.3, off=1.4 + lift,
                                          radii=radii)))
    # Sides and back: over the ears and down to the nape and below.
    side = [60, 78, 96, 114, 132, 150, 168, 186, 204, 222, 240, 258, 276, 294]
    for i, phi in enumerate(side):
        drop = [4.0, 4.0, 3.5] if 100 < phi < 260 else [3.5, 3.0]
        out.append(skel(f"back {i}", wisp(phi, [10, 40, 70, 98], drop, 3.0, 0.3,
                                          off=1.5 + lift, out=0.8, curl=1.2, radii=radii)))
    # A tuft at the crown (ahoge-like), standing up and curling forward.
    top = radii[1]
    out.append(skel("crown tuft", [
        f"Node(p: (-1.500, {top + 0.2:.3f}, 0.000), r: 1.100, w: {W})",
        f"Node(p: (-1.200, {top + 2.8:.3f}, 0.000), r: 0.800, w: {W})",
        f"Node(p: (0.800, {top + 4.7:.3f}, 0.000), r: 0.500, w: {W})",
        f"Node(p: (3.000, {top + 4.5:.3f}, 0.000), r: 0.250, w: {W})",
    ]))
    return out


TOON_HEAD = """    head: Head(radii: (9.6, 11.5, 7.8), color: (0.98, 0.86, 0.78)),"""
TOON_LOOK = """    camera: CameraDesc(eye: (40.0, 9.0, 27.0), target: (0.0, -0.5, 0.0), fov_y: 42.0),
    light: Light(direction: (0.75, 0.5, 0.3), intensity: 1.0, ambient: 1.0),
    render: RenderSettings(size: (512, 512), supersample: 2, msaa: 1, background: (0.97, 0.95, 0.92)),"""


def write(path, header, body):
    with open(path, "w") as f:
        f.write(header + body)


def toon():
    sk = "\n".join(toon_wisps())
    return f"""Scene(
{TOON_HEAD}
    wisps: Some(Wisps(
        threshold: 0.5,
        skeletons: [
{sk}
        ],
        toon: Toon(
            tones: Three,
            diffuse: (0.42, 0.45, 0.86),
            shade: (0.27, 0.28, 0.62),
            dark: (0.17, 0.16, 0.40),
            specular: (0.50, 0.50, 0.42),
            t_diffuse: 0.45,
            t_dark: 0.2,
            t_specular: 0.97,
            outline: (0.08, 0.06, 0.16),
            outline_width: 1.5,
        ),
    )),
{TOON_LOOK}
)
"""


def toon_shake():
    sk = "\n".join(toon_wisps())
    return f"""Scene(
{TOON_HEAD}
    wisps: Some(Wisps(
        threshold: 0.5,
        skeletons: [
{sk}
        ],
        springs: Some(Springs(ring: 0.5, stiffness: 10000.0, damping: 0.6, substeps: 16)),
    )),
    // The head shakes side to side (Fig. 13): a turn of 30 degrees each way about the
    // vertical every 16 frames, then rests. Gravity is the scene's shared one (cm/s² for
    // the springs).
    dynamics: Some(Dynamics(
        gravity: (0.0, -980.0, 0.0),
        head_motion: [
            HeadKey(frame: 0.0, rotate: (0.0, 0.0, 0.0), interp: Linear),
            HeadKey(frame: 8.0, rotate: (0.0, 30.0, 0.0), interp: Linear),
            HeadKey(frame: 24.0, rotate: (0.0, -30.0, 0.0), interp: Linear),
            HeadKey(frame: 40.0, rotate: (0.0, 30.0, 0.0), interp: Linear),
            HeadKey(frame: 56.0, rotate: (0.0, -30.0, 0.0), interp: Linear),
            HeadKey(frame: 64.0, rotate: (0.0, 0.0, 0.0), interp: Linear),
        ],
    )),
{TOON_LOOK}
)
"""


def toon_divide():
    # One thick wisp made of five thin ones: together down to node 3, then fanning apart.
    nodes = []
    for k in range(5):
        spread = (k - 2) * 1.0
        pts = []
        for i in range(8):
            y = 10.0 - 3.2 * i
            fan = spread * max(0.0, i - 2.5) ** 1.25 * 0.9
            bend = 0.05 * i * i
            pts.append((bend + 0.15 * spread * 0.3, y, fan + spread * 0.35))
        rs = [1.5, 1.45, 1.4, 1.3, 1.1, 0.9, 0.65, 0.35]
        ns = [f"Node(p: ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}), r: {r:.3f})" for p, r in zip(pts, rs)]
        nodes.append(skel(f"strand {k}", ns))
    sk = "\n".join(nodes)
    return f"""Scene(
    head: Head(center: (-6.0, 14.0, 0.0), radii: (5.0, 5.0, 5.0), visible: false),
    wisps: Some(Wisps(
        threshold: 0.5,
        skeletons: [
{sk}
        ],
    )),
    camera: CameraDesc(eye: (60.0, 0.0, 0.0), target: (0.0, -2.0, 0.0), fov_y: 36.0),
    light: Light(direction: (0.7, 0.6, 0.3), intensity: 1.0, ambient: 1.0),
    render: RenderSettings(size: (384, 512), supersample: 2, msaa: 1, background: (0.97, 0.95, 0.92)),
)
"""


def toon_wind():
    # The bangs and the side wisps in front of the ears of the toon look on springs, and the
    # back hair as strips, in one keyed gust (the scene's shared wind, which both read as an
    # acceleration). No crown tuft: standing upright, its held shape is an unstable
    # equilibrium that falls over in still air.
    w = toon_wisps()
    sk = "\n".join(w[:7] + [w[7], w[8], w[19], w[20]])
    return f"""Scene(
{TOON_HEAD}
    wisps: Some(Wisps(
        threshold: 0.5,
        skeletons: [
{sk}
        ],
        springs: Some(Springs(ring: 0.5, stiffness: 10000.0, damping: 0.6, substeps: 16)),
    )),
    strips: Some(Strips(
        layers: [
            Layer(name: "nape", count: 16, polar: 108.0, azimuth: (90.0, 270.0), length: 22.0, sticks: 8, width: (3.0, 0.8), droop: 0.97, curl: 4.0, color: (0.05, 0.05, 0.14)),
            Layer(name: "under", count: 18, polar: 82.0, azimuth: (92.0, 268.0), length: 24.0, sticks: 8, width: (3.2, 0.8), droop: 0.94, curl: 5.0, color: (0.06, 0.06, 0.17)),
            Layer(name: "middle", count: 18, polar: 55.0, azimuth: (90.0, 270.0), length: 25.0, sticks: 8, width: (3.4, 0.8), droop: 0.92, curl: 5.0, stiffness: 0.9, color: (0.07, 0.07, 0.20)),
            Layer(name: "crown", count: 14, polar: 26.0, azimuth: (100.0, 260.0), length: 26.0, sticks: 9, width: (3.6, 0.8), droop: 0.9, curl: 5.0, stiffness: 0.8, color: (0.08, 0.08, 0.23)),
        ],
        motion: Motion(stiffness: 150.0, damping: 3.0),
        look: Look(hairs: 12, tip_shade: 1.3),
    )),
    // The gust: the scene's shared keyed wind (cm/s² for the springs and the strips), from
    // the head's left (+z) to its right, rising over 8 frames, held, then dying down.
    // Gravity is the shared one too.
    dynamics: Some(Dynamics(
        gravity: (0.0, -980.0, 0.0),
        wind: [
            WindKey(frame: 0.0, force: (0.0, 0.0, 0.0), interp: Linear),
            WindKey(frame: 8.0, force: (0.0, 0.0, -700.0), interp: Linear),
            WindKey(frame: 28.0, force: (0.0, 0.0, -700.0), interp: Linear),
            WindKey(frame: 40.0, force: (0.0, 0.0, 0.0)),
        ],
    )),
    camera: CameraDesc(eye: (44.0, 6.0, 30.0), target: (-1.0, -3.0, 0.0), fov_y: 46.0),
    light: Light(direction: (0.75, 0.5, 0.3), intensity: 1.0, ambient: 1.0),
    render: RenderSettings(size: (512, 512), supersample: 2, msaa: 1, background: (0.97, 0.95, 0.92)),
)
"""


# CGAL's head.off placed as in assets/scenes/mesh_head.ron (face along +x, skull centred at
# the origin), the scalp above the face (the half-space) and the ears. Its scalp lies within about 0.8 cm of the ellipsoid MESH_RADII (smaller than
# the toon head: the crown is at y = 8.5), on whose shell the wisps are drawn; the roots are
# then moved onto the mesh's scalp when the scene is built.
MESH_RADII = (9.2, 8.6, 6.3)
MESH_HEAD = """    head: Head(
        radii: (9.2, 8.6, 6.3),
        color: (0.98, 0.86, 0.78),
        mesh: Some(HeadMesh(
            source: CgalDemo("head.off"),
            scale: 1.35,
            rotate: (0.0, 180.0, 0.0),
            translate: (0.0, -14.9, 0.0),
            scalp: [Polar(theta: (0.0, 100.0), phi: (-180.0, 180.0)), HalfSpace(normal: (-0.6, 1.0, 0.0), offset: 0.0)],
            resolution: 64,
        )),
    ),"""


def toon_mesh_head():
    sk = "\n".join(toon_wisps(MESH_RADII, lift=0.6))
    return f"""Scene(
{MESH_HEAD}
    wisps: Some(Wisps(
        threshold: 0.5,
        skeletons: [
{sk}
        ],
        springs: Some(Springs(ring: 0.5, stiffness: 10000.0, damping: 0.6, substeps: 16)),
    )),
    // A turn of 25 degrees each way about the vertical, then a gust into the face.
    dynamics: Some(Dynamics(
        gravity: (0.0, -980.0, 0.0),
        head_motion: [
            HeadKey(frame: 0.0, rotate: (0.0, 0.0, 0.0), interp: Linear),
            HeadKey(frame: 8.0, rotate: (0.0, 25.0, 0.0), interp: Linear),
            HeadKey(frame: 24.0, rotate: (0.0, -25.0, 0.0), interp: Linear),
            HeadKey(frame: 32.0, rotate: (0.0, 0.0, 0.0), interp: Linear),
        ],
        wind: [
            WindKey(frame: 0.0, force: (0.0, 0.0, 0.0)),
            WindKey(frame: 32.0, force: (0.0, 0.0, 0.0), interp: Linear),
            WindKey(frame: 40.0, force: (-1500.0, -300.0, 0.0), interp: Linear),
            WindKey(frame: 56.0, force: (0.0, 0.0, 0.0)),
        ],
    )),
{TOON_LOOK}
)
"""


HEAD = {
    "toon": "// Sakai's default look: an anime head with twenty-two toon wisps (bangs, sides and\n"
    "// back, a crown tuft), three-tone toon shading in the head's frame with the angel halo\n"
    "// (the horizontal specular band), silhouette outlines. Written by scripts/wisp-scenes.py.\n",
    "toon_shake": "// Fig. 13: the toon wisps on mass springs (RK4), the head shaking side to side; the\n"
    "// natural lengths are solved so the drawn shape holds under gravity. Written by\n"
    "// scripts/wisp-scenes.py.\n",
    "toon_wind": "// Toon wisps and strips in one gust: the bangs and side wisps of the toon look on mass\n"
    "// springs, the back hair as Kazama's strips, both blown by the scene's shared keyed\n"
    "// wind and pulled by its shared gravity (docs/wisps.md, \"Wisps in the shared forces and on a\n"
    "// mesh head\"). Look at frames 0, 12 and 30. Written by scripts/wisp-scenes.py.\n",
    "toon_mesh_head": "// The toon wisps on a mesh head (CGAL's head.off, placed as in mesh_head.ron): every root\n"
    "// is moved onto the mesh's scalp, and the springs collide with its signed distance field\n"
    "// while the head turns and a gust blows. Look at frames 0, 16 and 44. Written by\n"
    "// scripts/wisp-scenes.py.\n",
    "toon_divide": "// Fig. 12: one thick wisp dividing into thin ones. Five thin skeletons run together\n"
    "// from the root and fan apart below; the blobby sum makes them one wisp where they meet.\n"
    "// Written by scripts/wisp-scenes.py.\n",
}

if __name__ == "__main__":
    write("assets/scenes/toon.ron", HEAD["toon"], toon())
    write("assets/scenes/toon_shake.ron", HEAD["toon_shake"], toon_shake())
    write("assets/scenes/toon_divide.ron", HEAD["toon_divide"], toon_divide())
    write("assets/scenes/toon_wind.ron", HEAD["toon_wind"], toon_wind())
    write("assets/scenes/toon_mesh_head.ron", HEAD["toon_mesh_head"], toon_mesh_head())
