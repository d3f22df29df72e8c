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
/// Spine joints (a chain from the tail).
const JOINTS: usize = 6;
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
    -0.5 * LENGTH + 0.1 + k as f64 * (LENGTH - 0.2) / (JOINTS - 1) as f64
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
        let f = ((p[0] - joint_x(0)) / (joint_x(1) - joint_x(0))).clamp(0.0, (JOINTS - 1) as f64);
        let k = (f.floor() as usize).min(JOINTS - 2);
        let t = f - k as f64;
        joints.push([k as u8, k as u8 + 1, 0, 0]);
        weights.push([1.0 - t, t, 0.0, 0.0]);
    }

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
        if k == JOINTS - 1 {
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
    let ibm = (0..JOINTS).flat_map(|k| {
        let mut m = [0.0; 16];
        m[0] = 1.0;
        m[5] = 1.0;
        m[10] = 1.0;
        m[15] = 1.0;
        m[12] = -joint_x(k);
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
        } else {
            [joint_x(k) - joint_x(k - 1), 0.0, 0.0]
        };
        let children = if k + 1 < JOINTS {
            format!(", \"children\": [{}]", k + 2)
        } else {
            String::new()
        };
        write!(
            w,
            ",\n    {{\"name\": \"spine{k}\", \"translation\": [{}, {}, {}]{children}}}",
            t[0] as f32, t[1] as f32, t[2] as f32
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
