//! The skin map (`stage::shadow`, docs/shadows.md): a fur mesh's skin is an opaque caster,
//! rasterised in light space on the GPU (`deposit_triangle`) and read by `shadow_opaque`.
//! Its answer, probed on the GPU, against the f64 ray test over every posed triangle
//! (`stage::shadow::reference_skin`): on a still mesh, a moving one and a skinned one, under
//! a light from behind, with both shadow methods; and no skin map where no fur is.

use crate::common;
use glam::DVec3;
use kami::scene::ShadowMethod;
use kami::stage::shadow::{self, LightBox};
use kami::systems::fur::setup::FurSetup;

/// `name` with `hairs` hairs, shadows by `method`, lit from behind the critter as the
/// camera sees it (17 degrees up, as `kami bench look`'s back light).
fn back_lit(name: &str, hairs: u32, method: ShadowMethod) -> kami::Scene {
    let mut scene = common::scene(name);
    scene.fur_mut().as_mut().unwrap().hairs = hairs;
    scene.render.shadows.on = true;
    scene.render.shadows.method = method;
    scene.render.lod_tolerance_px = 0.0;
    let c = &scene.camera;
    let behind = (DVec3::from(c.target) - DVec3::from(c.eye)).normalize();
    let l = (behind + DVec3::Y * 0.3).normalize();
    scene.light.direction = l.to_array();
    scene
}

/// Points to probe: around the mesh (inside the light's box), on the hair, and just off
/// the skin along its normals (where the map's bias decides).
fn probe_points(setup: &FurSetup, frame: f64, b: &LightBox, bias: f64) -> Vec<DVec3> {
    let mut rng = kami::rng::Rng::new(36, 5);
    let (center, radius) = setup.bounds();
    let mut points: Vec<DVec3> = (0..240)
        .map(|_| {
            let d = DVec3::new(
                rng.uniform() - 0.5,
                rng.uniform() - 0.5,
                rng.uniform() - 0.5,
            );
            center + d.normalize_or_zero() * radius * rng.uniform()
        })
        .collect();
    let groom = kami::systems::fur::export_fur(setup, frame);
    let every = (groom.points.len() / 240).max(1);
    points.extend(
        groom
            .points
            .iter()
            .step_by(every)
            .map(|p| DVec3::from(p.map(f64::from))),
    );
    let (pos, nor) = setup.posed_mesh(frame);
    for _ in 0..240 {
        let v = ((rng.uniform() * pos.len() as f64) as usize).min(pos.len() - 1);
        points.push(pos[v] + nor[v] * bias * (2.0 + 4.0 * rng.uniform()));
    }
    points.retain(|p| {
        let c = b.coords(*p);
        c.x.abs() < b.half && c.y.abs() < b.half
    });
    points
}

/// The reference's answer at `p` when it is the same within two skin texels across the
/// light and for half and one and a half times the bias (the map answers at texel centres
/// from a depth read at them): None where it changes there.
fn clear_answer(tris: &[[DVec3; 3]], b: &LightBox, bias: f64, p: DVec3) -> Option<f64> {
    let texel = 2.0 * b.half / shadow::SKIN_TEXELS as f64;
    let want = shadow::reference_skin(tris, b.l, bias, p);
    for i in -2..=2 {
        for j in -2..=2 {
            let q = p + (b.u * i as f64 + b.v * j as f64) * texel;
            for k in [0.5, 1.5] {
                if shadow::reference_skin(tris, b.l, bias * k, q) != want {
                    return None;
                }
            }
        }
    }
    Some(want)
}

/// Draw `scene` at `frame` and compare the skin map's answer with the reference.
fn check(scene: &kami::Scene, frame: u32, what: &str) {
    let gpu = common::gpu();
    let mut stage = common::stage_one_sample(gpu, scene);
    if frame > 0 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.advance(gpu, &mut enc, frame).unwrap();
        gpu.queue.submit([enc.finish()]);
    }
    common::draw(&mut stage, (48, 48));
    let u = stage.shadow_params();
    assert_eq!(u.layered[1], 1.0, "{what}: the fur's skin made no skin map");
    let b = LightBox::of(&u);
    let bias = f64::from(u.layered[3]);
    assert!(
        (bias - shadow::skin_bias(&b)).abs() < 1e-6 * b.half,
        "{what}: bias {bias}"
    );
    let setup = FurSetup::new(scene.fur().as_ref().unwrap(), scene.seed).unwrap();
    let t = stage.frame() as f64;
    let tris = setup.posed_triangles(t);
    let points = probe_points(&setup, t, &b, bias);
    let got = stage.probe_shadows(gpu, &points).unwrap();
    let (mut clear, mut lit, mut dark, mut unclear_off) = (0, 0, 0, 0);
    for (p, g) in points.iter().zip(&got) {
        match clear_answer(&tris, &b, bias, *p) {
            Some(want) => {
                clear += 1;
                if want > 0.5 {
                    lit += 1;
                } else {
                    dark += 1;
                }
                assert!(
                    (g.opaque - want).abs() < 1e-6,
                    "{what}: shadow_opaque {} at {p}, the f64 ray test says {want}",
                    g.opaque
                );
            }
            None => {
                let want = shadow::reference_skin(&tris, b.l, bias, *p);
                if (g.opaque - want).abs() > 0.5 {
                    unclear_off += 1;
                }
            }
        }
    }
    let n = points.len();
    eprintln!(
        "{what} (closed mesh: {}): {n} points, {clear} clear ({lit} lit, {dark} in the \
         skin's shadow); {unclear_off} of the {} near an edge answer otherwise",
        setup.mesh.closed,
        n - clear
    );
    assert!(
        clear * 10 >= n * 6,
        "{what}: only {clear} of {n} points away from the map's edges"
    );
    assert!(
        lit * 10 >= clear && dark * 10 >= clear,
        "{what}: a one-sided case: {lit} lit, {dark} dark of {clear}"
    );
}

#[test]
fn the_skin_map_matches_the_f64_ray_test_on_a_still_mesh() {
    for method in [ShadowMethod::Volume, ShadowMethod::DeepOpacity] {
        let scene = back_lit("fur_polyline", 3000, method);
        check(&scene, 0, &format!("fur_polyline, {method:?}"));
    }
}

/// The mesh motion (`fur.ron`'s travelling wave) and a skinned glTF (`fur_creature.ron`)
/// move the skin the map is cast from, as they move the drawn skin.
#[test]
fn the_skin_map_follows_a_moving_and_a_skinned_mesh() {
    check(
        &back_lit("fur", 3000, ShadowMethod::Volume),
        7,
        "fur, frame 7",
    );
    check(
        &back_lit("fur_creature", 3000, ShadowMethod::DeepOpacity),
        12,
        "fur_creature, frame 12",
    );
}

/// Only a scene whose systems cast opaque gets the map (the bob has none), and shadows off
/// make none.
#[test]
fn no_skin_map_without_fur() {
    let gpu = common::gpu();
    let mut bob = common::thinned("bob", 20);
    bob.render.shadows.on = true;
    let mut stage = common::stage_one_sample(gpu, &bob);
    common::draw(&mut stage, (32, 32));
    assert_eq!(stage.shadow_params().layered[1], 0.0, "bob");
    let mut fur = back_lit("fur_polyline", 500, ShadowMethod::Volume);
    fur.render.shadows.on = false;
    let mut stage = common::stage_one_sample(gpu, &fur);
    common::draw(&mut stage, (32, 32));
    assert_eq!(stage.shadow_params().layered[1], 0.0, "fur, shadows off");
}
