//! Writes `assets/meshes/creature.gltf`: a small procedural creature (a ferret- or
//! caterpillar-like body: a tube with a neck and a round head, along +x, y up) skinned to a
//! chain of spine joints, with a 2-second looping animation: a travelling side-to-side
//! wiggle, a small up-and-down ripple, a nodding head and a bobbing root. The glTF 2.0 file
//! embeds its buffer as base64 (no .bin beside it). `assets/scenes/fur_creature.ron` grows fur
//! on it.
//!
//! Regenerate with `cargo run --release --example make_creature` (optionally followed by an
//! output path).

use std::f64::consts::{PI, TAU};
use std::fmt::Write as _;

/// Rings along the body (tail to nose) and vertices around each ring.
const RINGS: usize = 44;
const AROUND: usize = 18;
/// Spine joints (a chain from the tail), then one joint per leg.
const SPINE: usize = 6;
const LEGS: usize = 4;
const JOINTS: usize = SPINE + LEGS;
/// Body length along x, from x = -LENGTH/2 (tail) to +LENGTH/2 (nose).
const LENGTH: f64 = 2.0;
/// Animation keys over the 2-second loop.
const KEYS: usize = 41;
const SECONDS: f64 = 2.0;

fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Body radius at u in [0, 1] (tail to nose): a tapering body, a neck and a round head.
fn radius(u: f64) -> f64 {
    let body = 0.21 * (4.0 * u * (1.0 - u)).max(0.0).powf(0.4) * (1.0 - smoothstep(0.68, 0.8, u));
    let neck = 0.13 * smoothstep(0.55, 0.7, u) * (1.0 - smoothstep(0.86, 0.9, u));
    let hc = 0.86;
    let hr = 0.15;
    let dx = (u - hc) * LENGTH;
    let head = (hr * hr - dx * dx).max(0.0).sqrt();
    body.max(neck).max(head)
}

/// Spine joint k's rest x.
fn joint_x(k: usize) -> f64 {
    -0.5 * LENGTH + 0.1 + k as f64 * (LENGTH - 0.2) / (SPINE - 1) as f64
}

/// Leg l's hip (rest, world), its spine joint and its phase in the trot (diagonal pairs).
fn leg(l: usize) -> ([f64; 3], usize, f64) {
    let side = if l % 2 == 0 { 1.0 } else { -1.0 };
    let (x, spine) = if l < 2 { (0.42, 4) } else { (-0.55, 1) };
    let phase = if l == 0 || l == 3 { 0.0 } else { PI };
    ([x, -0.08, 0.11 * side], spine, phase)
}

/// Adds a closed tube along `path` (centre, radius) to the mesh, every vertex weighted
/// fully to `joint`.
fn tube(
    path: &[([f64; 3], f64)],
    around: usize,
    joint: u8,
    pos: &mut Vec<[f64; 3]>,
    tris: &mut Vec<[u32; 3]>,
    skin: &mut (Vec<[u8; 4]>, Vec<[f64; 4]>),
) {
    let first = pos.len() as u32;
    // Rings lie across the straight line from the first centre to the last.
    let (a, b) = (path[0].0, path[path.len() - 1].0);
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let d = [d[0] / l, d[1] / l, d[2] / l];
    let u0 = if d[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let dot = u0[0] * d[0] + u0[1] * d[1] + u0[2] * d[2];
    let u = [u0[0] - dot * d[0], u0[1] - dot * d[1], u0[2] - dot * d[2]];
    let ul = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    let u = [u[0] / ul, u[1] / ul, u[2] / ul];
    let v = [
        d[1] * u[2] - d[2] * u[1],
        d[2] * u[0] - d[0] * u[2],
        d[0] * u[1] - d[1] * u[0],
    ];
    pos.push(a);
    for (c, r) in path {
        for k in 0..around {
            let (s, co) = (TAU * k as f64 / around as f64).sin_cos();
            pos.push([
                c[0] + r * (co * u[0] + s * v[0]),
                c[1] + r * (co * u[1] + s * v[1]),
                c[2] + r * (co * u[2] + s * v[2]),
            ]);
        }
    }
    pos.push(b);
    let last = pos.len() as u32 - 1;
    let ring = |i: usize, k: usize| first + 1 + (i * around + k % around) as u32;
    for k in 0..around {
        tris.push([first, ring(0, k + 1), ring(0, k)]);
        tris.push([last, ring(path.len() - 1, k), ring(path.len() - 1, k + 1)]);
    }
    for i in 0..path.len() - 1 {
        for k in 0..around {
            let (p, q, r, t) = (
                ring(i, k),
                ring(i, k + 1),
                ring(i + 1, k),
                ring(i + 1, k + 1),
            );
            tris.push([p, q, r]);
            tris.push([q, t, r]);
        }
    }
    for _ in first..=last {
        skin.0.push([joint, 0, 0, 0]);
        skin.1.push([1.0, 0.0, 0.0, 0.0]);
    }
}

fn quat_yz(ay: f64, az: f64) -> [f64; 4] {
    // q = rot_y(ay) * rot_z(az), xyzw.
    let (sy, cy) = (0.5 * ay).sin_cos();
    let (sz, cz) = (0.5 * az).sin_cos();
    // (0, sy, 0, cy) * (0, 0, sz, cz)
    [sy * sz, sy * cz, cy * sz, cy * cz]
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= c.len() {
                out.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn main() -> anyhow::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "assets/meshes/creature.gltf".into());

    // Vertices: a tail pole, rings, a nose pole.
    let mut pos: Vec<[f64; 3]> = vec![[-0.5 * LENGTH, 0.0, 0.0]];
    for i in 1..RINGS {
        let u = i as f64 / RINGS as f64;
        let r = radius(u);
        // A slightly deeper than wide body, its belly a little flatter.
        for k in 0..AROUND {
            let a = TAU * k as f64 / AROUND as f64;
            let (s, c) = a.sin_cos();
            let y = r * s * if s < 0.0 { 0.8 } else { 1.05 };
            pos.push([-0.5 * LENGTH + u * LENGTH, y, r * c]);
        }
    }
    pos.push([0.5 * LENGTH, 0.0, 0.0]);
    let last = pos.len() as u32 - 1;
    let ring = |i: usize, k: usize| (1 + (i - 1) * AROUND + k % AROUND) as u32;
    let mut tris: Vec<[u32; 3]> = Vec::new();
    for k in 0..AROUND {
        tris.push([0, ring(1, k), ring(1, k + 1)]);
        tris.push([last, ring(RINGS - 1, k + 1), ring(RINGS - 1, k)]);
    }
    for i in 1..RINGS - 1 {
        for k in 0..AROUND {
            let (a, b, c, d) = (
                ring(i, k),
                ring(i, k + 1),
                ring(i + 1, k),
                ring(i + 1, k + 1),
            );
            tris.push([a, c, b]);
            tris.push([b, c, d]);
        }
    }
    // Weights: a hat function along the spine (two joints per vertex).
    let (mut joints, mut weights) = (Vec::new(), Vec::new());
    for p in &pos {
        let f = ((p[0] - joint_x(0)) / (joint_x(1) - joint_x(0))).clamp(0.0, (SPINE - 1) as f64);
        let k = (f.floor() as usize).min(SPINE - 2);
        let t = f - k as f64;
        joints.push([k as u8, k as u8 + 1, 0, 0]);
        weights.push([1.0 - t, t, 0.0, 0.0]);
    }
    let mut skin = (joints, weights);
    // Four legs (hip inside the body down to a paw), each on its own joint.
    for l in 0..LEGS {
        let (h, _, _) = leg(l);
        let path: Vec<([f64; 3], f64)> = (0..6)
            .map(|i| {
                let t = i as f64 / 5.0;
                let r = 0.065 - 0.02 * t + if i == 5 { 0.01 } else { 0.0 };
                (
                    [h[0] + 0.03 * t, h[1] - 0.34 * t, h[2] * (1.0 + 0.2 * t)],
                    r,
                )
            })
            .collect();
        tube(&path, 10, (SPINE + l) as u8, &mut pos, &mut tris, &mut skin);
    }
    // Two ears on the head joint.
    for side in [1.0, -1.0] {
        let path = [
            ([0.66, 0.08, 0.07 * side], 0.05),
            ([0.64, 0.17, 0.09 * side], 0.035),
            ([0.62, 0.24, 0.1 * side], 0.012),
        ];
        tube(&path, 8, (SPINE - 1) as u8, &mut pos, &mut tris, &mut skin);
    }
    let (joints, weights) = skin;

    // The animation: per joint a rotation, the root a translation.
    let times: Vec<f64> = (0..KEYS)
        .map(|i| SECONDS * i as f64 / (KEYS - 1) as f64)
        .collect();
    let rotation = |k: usize, t: f64| {
        let w = TAU * t / SECONDS;
        let kf = k as f64;
        let mut ay = 0.42 * (w - 1.1 * kf).sin();
        let mut az = 0.08 * (2.0 * w - 1.3 * kf).sin();
        if k == 0 {
            ay *= 0.5;
            az = 0.0;
        }
        if k >= SPINE {
            // The legs trot: diagonal pairs swing together, forward and back about z.
            let (_, _, phase) = leg(k - SPINE);
            return quat_yz(0.0, 0.55 * (2.0 * w + phase).sin());
        }
        if k == SPINE - 1 {
            // The head nods and looks about.
            ay = 0.3 * (w - 1.1 * kf + 0.8).sin();
            az = 0.18 * (2.0 * w + PI / 3.0).sin();
        }
        quat_yz(ay, az)
    };
    let root_t = |t: f64| [joint_x(0), 0.04 * (2.0 * TAU * t / SECONDS).sin(), 0.0];

    // The buffer.
    let mut buf: Vec<u8> = Vec::new();
    let mut views: Vec<(usize, usize)> = Vec::new();
    let mut push = |buf: &mut Vec<u8>, bytes: Vec<u8>| {
        while buf.len() % 4 != 0 {
            buf.push(0);
        }
        views.push((buf.len(), bytes.len()));
        buf.extend(bytes);
    };
    let f32s = |v: &mut dyn Iterator<Item = f64>| -> Vec<u8> {
        v.flat_map(|x| (x as f32).to_le_bytes()).collect()
    };
    push(&mut buf, f32s(&mut pos.iter().flatten().copied()));
    push(&mut buf, joints.iter().flatten().copied().collect());
    push(&mut buf, f32s(&mut weights.iter().flatten().copied()));
    push(
        &mut buf,
        tris.iter()
            .flatten()
            .flat_map(|&i| (i as u16).to_le_bytes())
            .collect(),
    );
    // Inverse bind matrices: joint k's rest global is a translation to (x_k, 0, 0).
    let rest = |k: usize| {
        if k < SPINE {
            [joint_x(k), 0.0, 0.0]
        } else {
            leg(k - SPINE).0
        }
    };
    let ibm = (0..JOINTS).flat_map(|k| {
        let mut m = [0.0; 16];
        m[0] = 1.0;
        m[5] = 1.0;
        m[10] = 1.0;
        m[15] = 1.0;
        let r = rest(k);
        m[12] = -r[0];
        m[13] = -r[1];
        m[14] = -r[2];
        m
    });
    push(&mut buf, f32s(&mut ibm.into_iter()));
    push(&mut buf, f32s(&mut times.iter().copied()));
    for k in 0..JOINTS {
        push(
            &mut buf,
            f32s(&mut times.iter().flat_map(|&t| rotation(k, t))),
        );
    }
    push(&mut buf, f32s(&mut times.iter().flat_map(|&t| root_t(t))));

    let (lo, hi) = pos
        .iter()
        .fold(([f64::MAX; 3], [f64::MIN; 3]), |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
                [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
            )
        });
    let mut j = String::new();
    let w = &mut j;
    writeln!(w, "{{")?;
    writeln!(
        w,
        "  \"asset\": {{\"version\": \"2.0\", \"generator\": \"kami examples/make_creature.rs \
         (cargo run --release --example make_creature)\"}},"
    )?;
    writeln!(w, "  \"scene\": 0,")?;
    writeln!(w, "  \"scenes\": [{{\"nodes\": [0, 1]}}],")?;
    write!(
        w,
        "  \"nodes\": [\n    {{\"name\": \"creature\", \"mesh\": 0, \"skin\": 0}}"
    )?;
    for k in 0..JOINTS {
        let t = if k == 0 {
            root_t(0.0)
        } else if k < SPINE {
            [joint_x(k) - joint_x(k - 1), 0.0, 0.0]
        } else {
            let (h, parent, _) = leg(k - SPINE);
            [h[0] - joint_x(parent), h[1], h[2]]
        };
        // Node k + 1: spine joints chain, legs hang from theirs.
        let mut kids: Vec<String> = Vec::new();
        if k + 1 < SPINE {
            kids.push((k + 2).to_string());
        }
        if k < SPINE {
            kids.extend(
                (0..LEGS)
                    .filter(|&l| leg(l).1 == k)
                    .map(|l| (SPINE + l + 1).to_string()),
            );
        }
        let children = if !kids.is_empty() {
            format!(", \"children\": [{}]", kids.join(", "))
        } else {
            String::new()
        };
        write!(
            w,
            ",\n    {{\"name\": \"{}\", \"translation\": [{}, {}, {}]{children}}}",
            if k < SPINE {
                format!("spine{k}")
            } else {
                format!("leg{}", k - SPINE)
            },
            t[0] as f32,
            t[1] as f32,
            t[2] as f32
        )?;
    }
    writeln!(w, "\n  ],")?;
    writeln!(w, "  \"meshes\": [{{\"name\": \"body\", \"primitives\": [{{\"attributes\": {{\"POSITION\": 0, \"JOINTS_0\": 1, \"WEIGHTS_0\": 2}}, \"indices\": 3}}]}}],")?;
    writeln!(
        w,
        "  \"skins\": [{{\"inverseBindMatrices\": 4, \"joints\": [{}]}}],",
        (1..=JOINTS)
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )?;
    // Accessors: 0 positions, 1 joints, 2 weights, 3 indices, 4 IBMs, 5 times, 6.. rotations,
    // then the root translation.
    let n = pos.len();
    let mut acc = vec![
        format!("{{\"bufferView\": 0, \"componentType\": 5126, \"count\": {n}, \"type\": \"VEC3\", \"min\": [{}, {}, {}], \"max\": [{}, {}, {}]}}",
            lo[0] as f32, lo[1] as f32, lo[2] as f32, hi[0] as f32, hi[1] as f32, hi[2] as f32),
        format!("{{\"bufferView\": 1, \"componentType\": 5121, \"count\": {n}, \"type\": \"VEC4\"}}"),
        format!("{{\"bufferView\": 2, \"componentType\": 5126, \"count\": {n}, \"type\": \"VEC4\"}}"),
        format!("{{\"bufferView\": 3, \"componentType\": 5123, \"count\": {}, \"type\": \"SCALAR\"}}", tris.len() * 3),
        format!("{{\"bufferView\": 4, \"componentType\": 5126, \"count\": {JOINTS}, \"type\": \"MAT4\"}}"),
        format!("{{\"bufferView\": 5, \"componentType\": 5126, \"count\": {KEYS}, \"type\": \"SCALAR\", \"min\": [0], \"max\": [{SECONDS}]}}"),
    ];
    for k in 0..JOINTS {
        acc.push(format!("{{\"bufferView\": {}, \"componentType\": 5126, \"count\": {KEYS}, \"type\": \"VEC4\"}}", 6 + k));
    }
    acc.push(format!(
        "{{\"bufferView\": {}, \"componentType\": 5126, \"count\": {KEYS}, \"type\": \"VEC3\"}}",
        6 + JOINTS
    ));
    writeln!(w, "  \"accessors\": [\n    {}\n  ],", acc.join(",\n    "))?;
    let bv: Vec<String> = views
        .iter()
        .map(|(o, l)| format!("{{\"buffer\": 0, \"byteOffset\": {o}, \"byteLength\": {l}}}"))
        .collect();
    writeln!(w, "  \"bufferViews\": [\n    {}\n  ],", bv.join(",\n    "))?;
    let mut channels = Vec::new();
    let mut samplers = Vec::new();
    for k in 0..JOINTS {
        channels.push(format!(
            "{{\"sampler\": {k}, \"target\": {{\"node\": {}, \"path\": \"rotation\"}}}}",
            k + 1
        ));
        samplers.push(format!(
            "{{\"input\": 5, \"output\": {}, \"interpolation\": \"LINEAR\"}}",
            6 + k
        ));
    }
    channels.push(format!(
        "{{\"sampler\": {JOINTS}, \"target\": {{\"node\": 1, \"path\": \"translation\"}}}}"
    ));
    samplers.push(format!(
        "{{\"input\": 5, \"output\": {}, \"interpolation\": \"LINEAR\"}}",
        6 + JOINTS
    ));
    writeln!(
        w,
        "  \"animations\": [{{\"name\": \"wiggle\", \"channels\": [\n    {}\n  ], \"samplers\": [\n    {}\n  ]}}],",
        channels.join(",\n    "),
        samplers.join(",\n    ")
    )?;
    writeln!(
        w,
        "  \"buffers\": [{{\"byteLength\": {}, \"uri\": \"data:application/octet-stream;base64,{}\"}}]",
        buf.len(),
        base64(&buf)
    )?;
    writeln!(w, "}}")?;
    if let Some(dir) = std::path::Path::new(&out).parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(&out, j)?;
    println!(
        "wrote {out}: {} vertices, {} triangles, {JOINTS} joints, {KEYS} keys over {SECONDS} s",
        pos.len(),
        tris.len()
    );
    Ok(())
}
