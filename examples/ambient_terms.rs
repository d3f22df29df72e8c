//! Kami's physical ambient colour, term by term, for the first hair material of each scene
//! given (docs/shading.md, "The ambient colour"): `cargo run --release --example
//! ambient_terms -- --out docs/ambient_terms.md assets/scenes/bob.ron ...`. Beside
//! `scripts/look-depths.py`, which splits the path tracer's light the same way.

use anyhow::{bail, Context, Result};
use kami::systems::hair_bsdf::{DualScattering, Physical, AMBIENT_RADIANCE, D_B, SKY_SEEN};
use std::fmt::Write as _;

fn rgb(v: [f64; 3]) -> String {
    format!("{:.4}, {:.4}, {:.4}", v[0], v[1], v[2])
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let mut out = None;
    let mut scenes = Vec::new();
    while let Some(a) = args.next() {
        if a == "--out" {
            out = Some(args.next().context("--out needs a file")?);
        } else {
            scenes.push(a);
        }
    }
    if scenes.is_empty() {
        bail!("usage: ambient_terms [--out FILE.md] SCENE.ron...");
    }
    let mut md = String::from("### Kami's physical ambient colour, term by term\n\n");
    writeln!(
        md,
        "Written by `cargo run --release --example ambient_terms -- {}{}`.\n",
        out.as_ref()
            .map(|o| format!("--out {o} "))
            .unwrap_or_default(),
        scenes.join(" ")
    )?;
    md.push_str(
        "Per scene, its first hair material, per unit of the light's `ambient` (linear RGB, the \
         environment's radiance 0.3 included). *single*: 0.3 SKY_SEEN a_b, the open sky \
         backscattered once; *multiple*: 0.3 a_b a_f / (1 - a_f^2), the volume's light; \
         *Zinke's multiple*: 0.3 d_b A_b, the form for light from one direction, which the \
         ambient used before; *ambient*: what the shaders get.\n\n",
    );
    md.push_str("| scene | a_f | a_b | single | multiple | Zinke's multiple | ambient |\n");
    md.push_str("|---|---|---|---|---|---|---|\n");
    for path in &scenes {
        let scene = kami::Scene::load(path)?;
        let mut mats: Vec<([f32; 3], Physical)> = Vec::new();
        mats.extend(
            scene
                .groups()
                .iter()
                .map(|g| (g.material.color, g.material.physical)),
        );
        for f in scene.fur().iter() {
            mats.extend(
                f.coats
                    .iter()
                    .map(|c| (c.material.diffuse, c.material.physical)),
            );
        }
        if let Some(s) = scene.strips() {
            mats.extend(s.layers.iter().map(|l| (l.color, s.look.physical)));
        }
        let Some((color, physical)) = mats.first() else {
            bail!("{path}: no hair material");
        };
        let d = DualScattering::new(&physical.hair(*color).bsdf());
        let single = d.a_b.map(|x| AMBIENT_RADIANCE * SKY_SEEN * x);
        let multiple = d.even_multiple().map(|x| AMBIENT_RADIANCE * x);
        let zinke = d.big_a_b.map(|x| AMBIENT_RADIANCE * D_B * x);
        writeln!(
            md,
            "| `{path}` | {} | {} | {} | {} | {} | {} |",
            rgb(d.a_f),
            rgb(d.a_b),
            rgb(single),
            rgb(multiple),
            rgb(zinke),
            rgb(d.ambient())
        )?;
    }
    match out {
        Some(o) => {
            std::fs::write(&o, &md).with_context(|| format!("writing {o}"))?;
            println!("wrote {o}");
        }
        None => print!("{md}"),
    }
    Ok(())
}
