//! Kami's own furry model, generated so the default fur scene needs no download: a
//! four-legged critter (body, head, snout, ears, legs, tail) as one triangle mesh built from
//! ellipsoids. The parts overlap without being welded — a non-manifold mesh, as real scans
//! often are — and the ellipsoids' poles give small triangles, which the root dispersal must
//! not leave bald.

use crate::scene::mesh::Mesh;
use glam::{DMat3, DVec3};

struct Part {
    center: DVec3,
    radii: DVec3,
    /// Rotation about z (degrees), for the tail and legs.
    tilt: f64,
    rings: u32,
    sectors: u32,
}

fn parts() -> Vec<Part> {
    let p = |c: [f64; 3], r: [f64; 3], tilt: f64, rings: u32, sectors: u32| Part {
        center: DVec3::from(c),
        radii: DVec3::from(r),
        tilt,
        rings,
        sectors,
    };
    let mut v = vec![
        p([0.0, 0.0, 0.0], [1.6, 0.95, 0.95], 0.0, 24, 48), // body
        p([1.85, 0.55, 0.0], [0.7, 0.65, 0.65], 0.0, 20, 40), // head
        p([2.45, 0.42, 0.0], [0.32, 0.24, 0.28], 0.0, 12, 24), // snout
        p([-1.9, 0.45, 0.0], [0.75, 0.2, 0.2], 35.0, 12, 24), // tail
    ];
    for z in [-0.38, 0.38] {
        v.push(p([1.85, 1.2, z], [0.14, 0.3, 0.18], 0.0, 10, 20)); // ears
    }
    for x in [-0.95, 0.95] {
        for z in [-0.55, 0.55] {
            v.push(p([x, -0.95, z], [0.26, 0.62, 0.26], 0.0, 12, 24)); // legs
        }
    }
    v
}

/// The critter mesh, about 4.5 units long, facing +x, standing on y = -1.57.
pub fn critter() -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for part in parts() {
        let rot = DMat3::from_rotation_z(part.tilt.to_radians());
        let base = positions.len() as u32;
        for r in 0..=part.rings {
            let theta = std::f64::consts::PI * r as f64 / part.rings as f64;
            for s in 0..=part.sectors {
                let phi = std::f64::consts::TAU * s as f64 / part.sectors as f64;
                let unit = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                positions.push(part.center + rot * (unit * part.radii));
            }
        }
        let row = part.sectors + 1;
        for r in 0..part.rings {
            for s in 0..part.sectors {
                let a = base + r * row + s;
                let b = a + row;
                triangles.push([a, a + 1, b]);
                triangles.push([a + 1, b + 1, b]);
            }
        }
    }
    // The pole rows produce zero-area triangles (two vertices coincide): kept, they get no
    // hair. Normals are area-weighted, so the seams get sensible ones.
    Mesh::new(positions, triangles, None, "critter").expect("the critter is a valid mesh")
}
