//! Put Figure 9's fur on any mesh and render it: `cargo run --release --example fur_on_a_mesh
//! -- MESH.obj|off|ply [OUT.png]`. Without a mesh it uses the CGAL lion head from Debian's
//! `libcgal-demo`. The mesh is fitted into a sphere of radius 1.6 and seen from the front
//! right; edit `assets/scenes/fur_fig9.ron` (or save a scene from the viewer) for more.

use anyhow::Result;
use glam::DVec3;
use kami::gpu::{Gpu, Preference};
use kami::scene::MeshSource;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let mesh = args.next();
    let out = args.next().unwrap_or_else(|| "fur_on_a_mesh.png".into());
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut scene = kami::Scene::load(root.join("assets/scenes/fur_fig9.ron"))?;
    let fur = scene.fur_mut().as_mut().expect("fur_fig9 has fur");
    fur.mesh = match mesh {
        Some(path) => MeshSource::File(path),
        None => MeshSource::CgalDemo("lion-head.off".into()),
    };
    fur.size = Some(1.6);
    fur.length = 0.12;
    fur.regions.clear();
    fur.direction = [0.0, -1.0, 0.0];
    for c in &mut fur.coats {
        c.material.width *= 0.7;
    }
    kami::systems::validate(&scene)?;
    // Frame the fitted mesh and its fur.
    let radius = 1.6 + 0.12;
    let fov = scene.camera.fov_y.to_radians();
    let eye = DVec3::new(1.0, 0.25, 1.0).normalize() * (1.1 * radius / (0.5 * fov).sin());
    scene.camera.eye = eye.to_array();
    scene.camera.target = [0.0; 3];
    let gpu = Gpu::headless(Preference::Software)?;
    let image = kami::stage::render_scene(&gpu, &scene, (800, 800))?;
    image.save(&out)?;
    println!("{out} ({})", gpu.describe());
    Ok(())
}
