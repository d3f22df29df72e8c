//! The toon controls of the wisps (`wisps::block::Toon`: feathers, the halo's width, offset,
//! strength and shadow colour, the rim light, the outline taper and per-wisp outline scale):
//! the f64 reference `systems::wisps::toon` against the old hard-step shading and against
//! what each control promises; `shaders/wisps/toon.wgsl` run headless on known normals
//! against the reference (bit for bit at the defaults); GPU renders of a small scene where
//! each control changes exactly the pixels the reference says; loading, validation and the
//! `--set` keys.

use crate::common;
use crate::common::invalid;

use glam::{DMat3, DMat4, DVec3};
use kami::systems::wisps::block::{Tones, Toon};
use kami::systems::wisps::toon::{self, shade, shade_at};
use kami::systems::wisps::{curve, field, march};
use kami::Scene;

// ---------------------------------------------------------------------------------------
// The f64 reference
// ---------------------------------------------------------------------------------------

/// The shading before the toon controls (the code as it was), to hold the defaults to it.
fn old_shade(n: DVec3, l: DVec3, head_rot: DMat3, toon: &Toon) -> DVec3 {
    let (i_spec, i_diff, _, _) = field::intensities(n, l, head_rot);
    let lin = field::linear;
    let c_diff = if i_diff > toon.t_diffuse {
        lin(toon.diffuse)
    } else {
        match toon.tones {
            Tones::Two => lin(toon.shade),
            Tones::Three if i_diff > toon.t_dark => lin(toon.shade),
            Tones::Three => lin(toon.dark),
        }
    };
    let c_spec = if i_spec > toon.t_specular {
        lin(toon.specular)
    } else {
        DVec3::ZERO
    };
    (c_diff + c_spec).min(DVec3::ONE)
}

/// `n` points spread evenly over the sphere (Fibonacci), none at the poles.
fn sphere(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - (i as f64 + 0.5) / n as f64 * 2.0;
            let r = (1.0 - y * y).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), y, r * a.sin())
        })
        .collect()
}

fn heads() -> [DMat3; 2] {
    [
        DMat3::IDENTITY,
        DMat3::from_rotation_y(0.7) * DMat3::from_rotation_x(0.25),
    ]
}

/// The normal at latitude `lat` (radians) facing the light's longitude, head upright: there
/// I_lon = 1, I_diff = I_lat and I_spec = cos(lat − elevation).
fn at_lat(lat: f64, light: DVec3) -> DVec3 {
    let h = DVec3::new(light.x, 0.0, light.z).normalize();
    h * lat.cos() + DVec3::Y * lat.sin()
}

#[test]
fn defaults_shade_bit_for_bit_as_the_hard_steps() {
    let shipped = common::scene("toon").wisps().clone().unwrap().toon;
    let toons = [
        Toon::default(),
        Toon {
            tones: Tones::Two,
            ..Toon::default()
        },
        shipped,
        // Rim colour set but no width, halo shadow colour equal to none's: still the old.
        Toon {
            rim: [1.0, 0.0, 0.0],
            rim_feather: 0.3,
            ..Toon::default()
        },
    ];
    let mut n_checked = 0;
    let normals = sphere(4000);
    for toon in &toons {
        for head in heads() {
            for l in [DVec3::new(0.75, 0.5, 0.3), DVec3::new(-0.2, 0.9, 0.4)] {
                for (i, &n) in normals.iter().enumerate() {
                    let v = normals[(i * 7 + 11) % 4000];
                    let want = old_shade(n, l, head, toon);
                    assert_eq!(shade(n, l, head, toon), want, "n {n}");
                    assert_eq!(shade_at(n, l, v, head, toon), want, "n {n}, v {v}");
                    n_checked += 1;
                }
            }
        }
    }
    println!("{n_checked} normals shaded exactly as the hard steps");
}

#[test]
fn feathered_steps_blend_only_within_their_width() {
    let light = DVec3::new(0.3, 0.5, 0.8).normalize();
    let lin = field::linear;
    // (which step, set its feather, the feather)
    type Case = (&'static str, fn(&mut Toon), f64);
    let cases: [Case; 3] = [
        ("diffuse", |t| t.diffuse_feather = 0.2, 0.2),
        ("dark", |t| t.dark_feather = 0.1, 0.1),
        ("halo", |t| t.halo_feather = 0.02, 0.02),
    ];
    for (name, set, f) in cases {
        let base = Toon {
            specular: [0.3, 0.3, 0.3],
            ..Toon::default()
        };
        let mut toon = base.clone();
        set(&mut toon);
        let (mut inside, mut outside) = (0, 0);
        for i in 0..=3600 {
            let lat = (-89.9 + 0.05 * i as f64).to_radians();
            let n = at_lat(lat, light);
            let (i_spec, i_diff, _, _) = field::intensities(n, light, DMat3::IDENTITY);
            let (x, t) = match name {
                "diffuse" => (i_diff, toon.t_diffuse),
                "dark" => (i_diff, toon.t_dark),
                _ => (i_spec, toon.t_specular),
            };
            let hard = shade(n, light, DMat3::IDENTITY, &base);
            let soft = shade(n, light, DMat3::IDENTITY, &toon);
            if (x - t).abs() >= 0.5 * f {
                assert_eq!(
                    soft,
                    hard,
                    "{name}: lat {:.2}° outside the feather",
                    lat.to_degrees()
                );
                outside += 1;
                continue;
            }
            inside += 1;
            // Inside: the two neighbouring colours blended by the smoothstep of (x − t)/f.
            let u = ((x - t) / f + 0.5).clamp(0.0, 1.0);
            let w = u * u * (3.0 - 2.0 * u);
            let (below, above) = match name {
                "diffuse" => (lin(base.shade), lin(base.diffuse)),
                "dark" => (lin(base.dark), lin(base.shade)),
                _ => {
                    let tone = hard
                        - if i_spec > t {
                            lin(base.specular)
                        } else {
                            DVec3::ZERO
                        };
                    (tone, tone + lin(base.specular))
                }
            };
            let want = below * (1.0 - w) + above * w;
            assert!(
                (soft - want).abs().max_element() < 1e-12,
                "{name}: lat {:.2}°: {soft} vs {want}",
                lat.to_degrees()
            );
        }
        println!("{name} feather {f}: {inside} latitudes blended, {outside} as the hard step");
        assert!(
            inside > 10 && outside > 100,
            "{name}: {inside} inside, {outside} outside"
        );
    }
}

#[test]
fn halo_offset_moves_the_band_by_its_latitude() {
    let light = DVec3::new(0.0, 0.5, 0.8).normalize();
    for offset in [-25.0f64, 0.0, 15.0, 30.0] {
        let toon = Toon {
            halo_offset: offset,
            specular: [0.4, 0.4, 0.4],
            ..Toon::default()
        };
        let no_halo = Toon {
            halo_strength: 0.0,
            ..toon.clone()
        };
        let half = toon.t_specular.acos();
        let mut band = 0;
        for head in heads() {
            // The band is centred on the light's latitude in the head's frame, plus the offset.
            let centre = (head.transpose() * light).y.asin() + offset.to_radians();
            for i in 0..1800 {
                let lat = (-89.95 + 0.1 * i as f64).to_radians();
                let n = head * at_lat(lat, head.transpose() * light);
                let l = light;
                let in_band = shade(n, l, head, &toon) != shade(n, l, head, &no_halo);
                let (i_spec, _, _, _) = toon::intensities_shifted(n, l, head, offset.to_radians());
                assert!((i_spec - (lat - centre).cos()).abs() < 1e-9);
                if ((lat - centre).abs() - half).abs() > 1e-6 {
                    assert_eq!(
                        in_band,
                        (lat - centre).abs() < half,
                        "offset {offset}°: lat {:.2}°",
                        lat.to_degrees()
                    );
                }
                band += usize::from(in_band);
            }
        }
        println!("offset {offset}°: {band} latitudes in the band");
        assert!(band > 100);
    }
}

#[test]
fn halo_strength_scales_the_added_colour_in_the_band_only() {
    let light = DVec3::new(0.2, 0.6, 0.8).normalize();
    let base = Toon {
        specular: [0.3, 0.25, 0.2],
        ..Toon::default()
    };
    let spec = field::linear(base.specular);
    let (mut band, mut off) = (0, 0);
    for n in sphere(3000) {
        let zero = shade(
            n,
            light,
            DMat3::IDENTITY,
            &Toon {
                halo_strength: 0.0,
                ..base.clone()
            },
        );
        let (i_spec, _, _, _) = field::intensities(n, light, DMat3::IDENTITY);
        for s in [0.5, 1.0, 1.5] {
            let c = shade(
                n,
                light,
                DMat3::IDENTITY,
                &Toon {
                    halo_strength: s,
                    ..base.clone()
                },
            );
            if i_spec > base.t_specular {
                let want = (zero + spec * s).min(DVec3::ONE);
                assert!((c - want).abs().max_element() < 1e-12, "{c} vs {want}");
            } else {
                assert_eq!(c, zero);
            }
        }
        if i_spec > base.t_specular {
            band += 1;
            assert_ne!(zero, shade(n, light, DMat3::IDENTITY, &base));
        } else {
            off += 1;
        }
    }
    assert!(band > 20 && off > 1000, "{band} in the band, {off} out");
}

#[test]
fn halo_shadow_colour_shows_over_the_shade_tones_only() {
    let light = DVec3::new(0.75, 0.5, 0.3).normalize();
    let base = Toon {
        t_specular: 0.9,
        ..Toon::default()
    };
    let tinted = Toon {
        halo_shadow: Some([0.6, 0.1, 0.1]),
        ..base.clone()
    };
    let (mut changed, mut lit_band) = (0, 0);
    for n in sphere(6000) {
        let (i_spec, i_diff, _, _) = field::intensities(n, light, DMat3::IDENTITY);
        let (a, b) = (
            shade(n, light, DMat3::IDENTITY, &base),
            shade(n, light, DMat3::IDENTITY, &tinted),
        );
        let in_band = i_spec > base.t_specular;
        let lit = i_diff > base.t_diffuse;
        if in_band && !lit {
            let tone = old_shade(
                n,
                light,
                DMat3::IDENTITY,
                &Toon {
                    specular: [0.0; 3],
                    ..base.clone()
                },
            );
            assert_eq!(b, (tone + field::linear([0.6, 0.1, 0.1])).min(DVec3::ONE));
            changed += 1;
        } else {
            assert_eq!(a, b, "n {n}: lit {lit}, band {in_band}");
            lit_band += usize::from(in_band);
        }
    }
    println!("{changed} band normals over shade tones tinted, {lit_band} lit band normals kept");
    assert!(changed > 20 && lit_band > 20);
}

#[test]
fn rim_lights_the_silhouette_on_the_side_away_from_the_light() {
    let light = DVec3::new(0.75, 0.5, 0.3).normalize();
    let base = Toon::default();
    let rim = Toon {
        rim: [0.2, 0.3, 0.5],
        rim_width: 0.35,
        ..Toon::default()
    };
    let soft = Toon {
        rim_feather: 0.2,
        ..rim.clone()
    };
    let (mut lit, mut shadow, mut facing) = (0, 0, 0);
    for (i, n) in sphere(3000).into_iter().enumerate() {
        for v in [DVec3::Z, -DVec3::X, sphere(3000)[(i * 13 + 5) % 3000]] {
            let a = shade_at(n, light, v, DMat3::IDENTITY, &base);
            let b = shade_at(n, light, v, DMat3::IDENTITY, &rim);
            let c = shade_at(n, light, v, DMat3::IDENTITY, &soft);
            let (_, i_diff, _, _) = field::intensities(n, light, DMat3::IDENTITY);
            let nv = n.dot(v);
            if i_diff > base.t_diffuse {
                assert_eq!(b, a, "lit side: no rim");
                assert_eq!(c, a);
                lit += 1;
            } else if nv < rim.rim_width {
                assert_eq!(b, (a + field::linear(rim.rim)).min(DVec3::ONE));
                shadow += 1;
            } else {
                assert_eq!(b, a, "facing the eye: no rim");
                facing += 1;
            }
            // The feather: as the hard rim beyond half its width from the edge, between no
            // rim and the full rim within it.
            if i_diff <= base.t_diffuse {
                if (nv - rim.rim_width).abs() >= 0.1 {
                    assert_eq!(c, b);
                } else {
                    let full = (a + field::linear(rim.rim)).min(DVec3::ONE);
                    for k in 0..3 {
                        assert!(c[k] >= a[k] && c[k] <= full[k], "{c} not in {a}..{full}");
                    }
                }
            }
        }
    }
    println!("rim: {shadow} shadow-side silhouette, {lit} lit, {facing} facing cases");
    assert!(shadow > 100 && lit > 100 && facing > 100);
    // Seen head-on (`shade`, V = N) there is no rim.
    for n in sphere(500) {
        assert_eq!(
            shade(n, light, DMat3::IDENTITY, &rim),
            shade(n, light, DMat3::IDENTITY, &base)
        );
    }
}

#[test]
fn outline_data_thins_each_wisp_toward_its_tip() {
    let mut w = common::scene("toon").wisps().clone().unwrap();
    // Defaults: every segment at scale 1 whatever the taper point.
    let segs = toon::segment_outlines(&w);
    assert_eq!(segs.len() as u32, march::segment_count(&w));
    for o in &segs {
        for t in [0.0, 0.5, 1.0] {
            assert_eq!(toon::outline_scale(*o, t, w.toon.outline_taper), 1.0);
        }
    }
    w.skeletons[1].outline = 2.0;
    w.toon.outline_taper = 0.75;
    let segs = toon::segment_outlines(&w);
    let mut at = 0;
    for (si, sk) in w.skeletons.iter().enumerate() {
        let k = sk.nodes.len() - 1;
        let mine = &segs[at..at + k];
        at += k;
        // u runs from 0 at the root to 1 at the tip, continuous across segments, in
        // proportion to the drawn length.
        assert_eq!(mine[0][1], 0.0);
        assert_eq!(mine[k - 1][2], 1.0);
        let len: f64 = sk
            .nodes
            .windows(2)
            .map(|p| (DVec3::from(p[1].p) - DVec3::from(p[0].p)).length())
            .sum();
        let first = (DVec3::from(sk.nodes[1].p) - DVec3::from(sk.nodes[0].p)).length();
        assert!((mine[0][2] as f64 - first / len).abs() < 1e-6);
        for pair in mine.windows(2) {
            assert_eq!(pair[0][2], pair[1][1]);
            assert!(pair[1][1] > pair[0][1]);
        }
        let scale = if si == 1 { 2.0 } else { 1.0 };
        let root = toon::outline_scale(mine[0], 0.0, 0.75);
        let tip = toon::outline_scale(mine[k - 1], 1.0, 0.75);
        assert_eq!(root, scale);
        assert!((tip - scale * 0.25).abs() < 1e-12);
        // Thinner all along toward the tip.
        let mut last = f64::INFINITY;
        for o in mine {
            for t in [0.0, 0.25, 0.5, 0.75, 1.0] {
                let s = toon::outline_scale(*o, t, 0.75);
                assert!(s <= last + 1e-12);
                last = s;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Loading, validation, --set
// ---------------------------------------------------------------------------------------

const SMALL: &str = r#"Scene(
    head: Head(visible: false),
    wisps: Some(Wisps(
        skeletons: [
            Skeleton(nodes: [
                Node(p: (-9.0, 3.0, 0.0), r: 3.4, w: 2.5),
                Node(p: (0.0, 3.6, 0.0), r: 3.4, w: 2.5),
                Node(p: (9.0, 3.0, 0.0), r: 3.4, w: 2.5),
            ]),
            Skeleton(nodes: [
                Node(p: (-8.0, -6.5, 0.0), r: 3.4, w: 2.5),
                Node(p: (0.0, -3.5, 1.0), r: 3.0, w: 2.5),
                Node(p: (8.0, -5.0, 0.0), r: 2.0, w: 2.5),
            ]),
        ],
        toon: Toon(outline_width: 1.0),
    )),
    camera: CameraDesc(eye: (0.0, 0.0, 32.0), target: (0.0, 0.0, 0.0), fov_y: 36.0),
    light: Light(direction: (0.4, 0.5, 0.75)),
    render: RenderSettings(supersample: 1, msaa: 1, background: (1.0, 1.0, 1.0)),
)"#;

#[test]
fn scenes_without_the_controls_load_todays_look() {
    let s = Scene::from_ron(SMALL, "small.ron").unwrap();
    let w = s.wisps().clone().unwrap();
    let d = Toon::default();
    let t = &w.toon;
    assert_eq!(
        (
            t.diffuse_feather,
            t.dark_feather,
            t.halo_feather,
            t.rim_feather
        ),
        (0.0, 0.0, 0.0, 0.0)
    );
    assert_eq!(
        (t.halo_offset, t.halo_strength, t.halo_shadow),
        (0.0, 1.0, None)
    );
    assert_eq!((t.rim_width, t.rim, t.outline_taper), (0.0, d.rim, 0.0));
    assert!(w.skeletons.iter().all(|s| s.outline == 1.0));
    // The draw uniform of the defaults: no feathers, offset 0 (cos 1, sin 0), strength 1,
    // no halo shadow colour, no rim, no taper.
    let u = march::draw_uniform(&w, DMat4::IDENTITY, 4);
    assert_eq!(u.feather, [0.0; 4]);
    assert_eq!(u.halo, [1.0, 0.0, 1.0, 0.0]);
    assert_eq!(u.rim[3], 0.0);
    assert_eq!(u.taper, [0.0; 4]);
    // A skeleton at the default outline scale is written without it.
    let ron = ron::to_string(&w.skeletons[0]).unwrap();
    assert!(!ron.contains("outline"), "{ron}");
    let mut sk = w.skeletons[0].clone();
    sk.outline = 0.5;
    assert!(ron::to_string(&sk).unwrap().contains("outline:0.5"));
}

/// The WGSL `struct Draw` and `GpuWispDraw` have the same size.
#[test]
fn draw_uniform_matches_its_wgsl_struct() {
    let module = naga::front::wgsl::parse_str(march::MARCH).unwrap();
    let span = module
        .types
        .iter()
        .find_map(|(_, t)| match (&t.name, &t.inner) {
            (Some(n), naga::TypeInner::Struct { span, .. }) if n == "Draw" => Some(*span),
            _ => None,
        })
        .expect("struct Draw in the march module");
    assert_eq!(span as usize, std::mem::size_of::<march::GpuWispDraw>());
}

#[test]
fn bad_toon_controls_are_refused_naming_file_and_field() {
    for (set, field, allowed) in [
        ("rim_width: 1.5", "wisps.toon.rim_width", "[0, 1]"),
        ("rim_feather: -0.1", "wisps.toon.rim_feather", "[0, 1]"),
        ("rim: (0.2, 2.0, 0.1)", "wisps.toon.rim[1]", "[0, 1]"),
        (
            "diffuse_feather: NaN",
            "wisps.toon.diffuse_feather",
            "finite",
        ),
        ("dark_feather: 3.0", "wisps.toon.dark_feather", "[0, 1]"),
        ("halo_feather: inf", "wisps.toon.halo_feather", "finite"),
        ("halo_offset: 120.0", "wisps.toon.halo_offset", "[-90, 90]"),
        ("halo_strength: -1.0", "wisps.toon.halo_strength", "[0, 4]"),
        (
            "halo_shadow: Some((0.1, 0.1, -0.5))",
            "wisps.toon.halo_shadow[2]",
            "[0, 1]",
        ),
        ("outline_taper: 1.01", "wisps.toon.outline_taper", "[0, 1]"),
    ] {
        let text = SMALL.replace("outline_width: 1.0", &format!("outline_width: 1.0, {set}"));
        let (f, _, a) = invalid(&text);
        assert_eq!(f, field, "{set}");
        assert!(a.contains(allowed), "{set}: {a}");
    }
    let text = SMALL.replacen("Skeleton(nodes", "Skeleton(outline: -2.0, nodes", 1);
    let (f, v, a) = invalid(&text);
    assert_eq!(
        (f.as_str(), v.as_str()),
        ("wisps.skeletons[0].outline", "-2")
    );
    assert!(a.contains("[0, 8]"), "{a}");
}

#[test]
fn set_keys_edit_every_toon_control_or_refuse() {
    use kami::app::params::ViewerState;
    use kami::systems::{wisps::classify, Change};
    let scene = Scene::from_ron(SMALL, "small.ron").unwrap();
    let mut s = ViewerState::new(scene.clone(), String::new());
    for key in [
        "wisps.toon.diffuse_feather=0.1",
        "wisps.toon.dark_feather=0.2",
        "wisps.toon.halo_feather=0.03",
        "wisps.toon.halo_offset=-12.5",
        "wisps.toon.halo_strength=1.5",
        "wisps.toon.halo_shadow=0.5,0.2,0.1",
        "wisps.toon.rim=0.9,0.8,0.7",
        "wisps.toon.rim_width=0.4",
        "wisps.toon.rim_feather=0.15",
        "wisps.toon.outline_taper=0.6",
        "wisps.toon.t_specular=0.95",
        "wisps.toon.tones=two",
    ] {
        let before = s.scene.clone();
        s.apply_set(key).unwrap();
        assert_eq!(classify(&before, &s.scene), Change::Redraw, "{key}");
    }
    let t = &s.scene.wisps().as_ref().unwrap().toon;
    assert_eq!(
        (
            t.diffuse_feather,
            t.dark_feather,
            t.halo_feather,
            t.halo_offset
        ),
        (0.1, 0.2, 0.03, -12.5)
    );
    assert_eq!(
        (t.halo_strength, t.halo_shadow),
        (1.5, Some([0.5, 0.2, 0.1]))
    );
    assert_eq!(
        (t.rim, t.rim_width, t.rim_feather),
        ([0.9, 0.8, 0.7], 0.4, 0.15)
    );
    assert_eq!(
        (t.outline_taper, t.t_specular, t.tones),
        (0.6, 0.95, Tones::Two)
    );
    s.apply_set("wisps.toon.halo_shadow=none").unwrap();
    assert_eq!(s.scene.wisps().as_ref().unwrap().toon.halo_shadow, None);
    // Outline scales: every skeleton, then one (a rebuild: the march's per-segment data).
    let before = s.scene.clone();
    s.apply_set("wisps.outline=0.5").unwrap();
    assert_eq!(classify(&before, &s.scene), Change::Rebuild);
    s.apply_set("wisps.outline.1=2").unwrap();
    let outlines: Vec<f64> = s
        .scene
        .wisps()
        .as_ref()
        .unwrap()
        .skeletons
        .iter()
        .map(|k| k.outline)
        .collect();
    assert_eq!(outlines, vec![0.5, 2.0]);
    let before = s.scene.clone();
    for (bad, says) in [
        ("wisps.toon.rim_width=2", "wisps.toon.rim_width"),
        ("wisps.toon.halo_offset=nan", "wisps.toon.halo_offset"),
        ("wisps.toon.halo_strength=lots", "is not a number"),
        ("wisps.toon.rim=1,1", "is not r,g,b"),
        ("wisps.toon.halo_shadow=2,0,0", "wisps.toon.halo_shadow[0]"),
        ("wisps.toon.glow=1", "unknown key"),
        ("wisps.toon.tones=four", "two or three"),
        ("wisps.outline.7=1", "no skeleton"),
        ("wisps.outline=-1", "wisps.skeletons[0].outline"),
    ] {
        let e = s.apply_set(bad).unwrap_err().to_string();
        assert!(e.contains(says), "{bad}: {e}");
    }
    assert_eq!(
        s.scene, before,
        "a refused --set leaves the scene as it was"
    );
}

/// The Skeletons panel's per-wisp outline slider goes through the editor: the selected
/// node's skeleton only, clamped into the valid range, one undo step per drag.
#[test]
fn editor_sets_a_wisps_outline_scale_with_undo() {
    use kami::systems::wisps::edit::{Editor, Sel};
    let mut w = Scene::from_ron(SMALL, "small.ron")
        .unwrap()
        .wisps()
        .clone()
        .unwrap();
    let mut ed = Editor::new();
    assert!(ed.set_outline(&mut w, 2.0).is_err(), "needs a selection");
    ed.select(
        &w,
        Some(Sel {
            skeleton: 1,
            node: 2,
        }),
    )
    .unwrap();
    ed.set_outline(&mut w, 2.0).unwrap();
    ed.set_outline(&mut w, 30.0).unwrap();
    assert_eq!((w.skeletons[0].outline, w.skeletons[1].outline), (1.0, 8.0));
    assert!(ed.set_outline(&mut w, f64::NAN).is_err());
    assert_eq!(w.skeletons[1].outline, 8.0);
    assert_eq!(ed.undo_len(), 1, "one drag, one undo step");
    ed.undo(&mut w).unwrap();
    assert_eq!(w.skeletons[1].outline, 1.0);
}

// ---------------------------------------------------------------------------------------
// The WGSL against the reference, headless, on known normals
// ---------------------------------------------------------------------------------------

/// The toon function of shaders/wisps/toon.wgsl before the controls, renamed.
const OLD_TOON_WGSL: &str = r#"
fn toon_old(n_world: vec3<f32>) -> vec3<f32> {
    let rot = mat3x3<f32>(draw.head_x.xyz, draw.head_y.xyz, draw.head_z.xyz);
    let n = transpose(rot) * n_world;
    let l = transpose(rot) * normalize(frame.light_dir.xyz);
    let n_lat = n.y;
    let l_lat = l.y;
    let n_lon = length(n.xz);
    let l_lon = length(l.xz);
    let i_spec = n_lat * l_lat + n_lon * l_lon;
    let i_lat = 0.5 * (n_lat + 1.0);
    var cross_term = 0.0;
    if (n_lon > 1e-6 && l_lon > 1e-6) {
        cross_term = dot(l.xz / l_lon, n.xz / n_lon);
    }
    let i_lon = 0.5 * (cross_term + 1.0);
    let i_diff = i_lat * i_lon;
    var c = draw.shade.rgb;
    if (i_diff > draw.diffuse.w) {
        c = draw.diffuse.rgb;
    } else if (draw.specular.w > 0.5 && i_diff <= draw.shade.w) {
        c = draw.dark.rgb;
    }
    if (i_spec > draw.dark.w) {
        c += draw.specular.rgb;
    }
    return min(c, vec3<f32>(1.0));
}
"#;

/// Per element two vec4s in: (n, mode), (v, 0); mode 0 `toon_at(n, v)`, 1 `toon(n)`, 2
/// `toon_old(n)`.
const PROBE_WGSL: &str = r#"
@group(2) @binding(0) var<storage, read> probe_in: array<vec4<f32>>;
@group(2) @binding(1) var<storage, read_write> probe_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn toon_probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&probe_out)) {
        return;
    }
    let a = probe_in[2u * i];
    let b = probe_in[2u * i + 1u];
    var c: vec3<f32>;
    if (a.w == 1.0) {
        c = toon(a.xyz);
    } else if (a.w == 2.0) {
        c = toon_old(a.xyz);
    } else {
        c = toon_at(a.xyz, b.xyz);
    }
    probe_out[i] = vec4<f32>(c, 1.0);
}
"#;

struct Probe {
    gpu: &'static kami::gpu::Gpu,
    pipeline: wgpu::ComputePipeline,
}

/// What the probe shades with: the frame's view and light, the head's rotation.
#[derive(Clone, Copy)]
struct Setup {
    view_proj: DMat4,
    light: DVec3,
    head: DMat3,
}

impl Probe {
    fn new() -> Probe {
        let gpu = common::gpu();
        let source = format!("{}\n{OLD_TOON_WGSL}\n{PROBE_WGSL}", march::MARCH);
        let module = kami::gpu::shader_module(&gpu.device, "toon probe", &source).unwrap();
        let pipeline = gpu
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("toon probe"),
                layout: None,
                module: &module,
                entry_point: Some("toon_probe"),
                compilation_options: Default::default(),
                cache: None,
            });
        Probe { gpu, pipeline }
    }

    /// The GPU's colours for `(n, v, mode)` (f32, as the shader returns them).
    fn run(&self, toon: &Toon, setup: Setup, items: &[(DVec3, DVec3, u32)]) -> Vec<[f32; 4]> {
        use kami::gpu::gpu_data::GpuFrame;
        let gpu = &self.gpu;
        let d = &gpu.device;
        let mut frame: GpuFrame = bytemuck::Zeroable::zeroed();
        frame.view_proj = setup.view_proj.as_mat4().to_cols_array_2d();
        let l = setup.light.normalize();
        frame.light_dir = [l.x as f32, l.y as f32, l.z as f32, 1.0];
        let mut wisps = Scene::from_ron(SMALL, "small.ron")
            .unwrap()
            .wisps()
            .clone()
            .unwrap();
        wisps.toon = toon.clone();
        let draw = march::draw_uniform(&wisps, DMat4::from_mat3(setup.head), 4);
        let uniform = |label, bytes: &[u8]| {
            use wgpu::util::DeviceExt;
            d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        let frame_buf = uniform("probe frame", bytemuck::bytes_of(&frame));
        let draw_buf = uniform("probe draw", bytemuck::bytes_of(&draw));
        let input: Vec<[f32; 4]> = items
            .iter()
            .flat_map(|(n, v, mode)| {
                [
                    [n.x as f32, n.y as f32, n.z as f32, *mode as f32],
                    [v.x as f32, v.y as f32, v.z as f32, 0.0],
                ]
            })
            .collect();
        let empty = wgpu::BufferUsages::empty();
        let in_buf = kami::gpu::storage_buffer(d, "probe in", bytemuck::cast_slice(&input), empty);
        let out_bytes = (items.len() * 16) as u64;
        let out_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("probe out"),
            size: out_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = |i: u32, bufs: &[&wgpu::Buffer]| {
            let layout = self.pipeline.get_bind_group_layout(i);
            kami::gpu::bind::buffers(d, "toon probe", &layout, bufs)
        };
        let groups = [
            group(0, &[&frame_buf]),
            group(1, &[&draw_buf]),
            group(2, &[&in_buf, &out_buf]),
        ];
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            for (i, g) in groups.iter().enumerate() {
                pass.set_bind_group(i as u32, g, &[]);
            }
            pass.dispatch_workgroups((items.len() as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([enc.finish()]);
        kami::gpu::read_buffer::<[f32; 4]>(gpu, &out_buf, out_bytes).unwrap()
    }
}

fn setups() -> Vec<Setup> {
    let proj = glam::dcamera::rh::proj::directx::perspective(0.7, 1.0, 1.0, 100.0);
    let eye = DVec3::new(30.0, 10.0, 25.0);
    let view: DMat4 = glam::dcamera::rh::view::look_at_mat4(eye, DVec3::ZERO, DVec3::Y);
    heads()
        .into_iter()
        .zip([DVec3::new(0.6, 0.45, 0.66), DVec3::new(-0.3, 0.8, 0.5)])
        .map(|(head, light)| Setup {
            view_proj: proj * view,
            light,
            head,
        })
        .collect()
}

/// The toon controls the contract runs over: defaults, then each group of controls.
fn contract_toons() -> Vec<(&'static str, Toon)> {
    let d = Toon::default();
    vec![
        ("defaults", d.clone()),
        (
            "feathers",
            Toon {
                diffuse_feather: 0.2,
                dark_feather: 0.1,
                halo_feather: 0.05,
                ..d.clone()
            },
        ),
        (
            "halo",
            Toon {
                t_specular: 0.9,
                halo_offset: 25.0,
                halo_strength: 1.7,
                halo_shadow: Some([0.7, 0.2, 0.3]),
                halo_feather: 0.04,
                ..d.clone()
            },
        ),
        (
            "hard halo offset",
            Toon {
                halo_offset: -30.0,
                halo_shadow: Some([0.1, 0.6, 0.3]),
                ..d.clone()
            },
        ),
        (
            "rim",
            Toon {
                rim: [0.4, 0.5, 0.9],
                rim_width: 0.5,
                rim_feather: 0.2,
                ..d.clone()
            },
        ),
        (
            "hard rim",
            Toon {
                rim_width: 0.3,
                ..d.clone()
            },
        ),
        (
            "two tones, all",
            Toon {
                tones: Tones::Two,
                diffuse_feather: 0.3,
                halo_offset: 10.0,
                halo_strength: 0.5,
                halo_feather: 0.1,
                rim_width: 0.8,
                rim_feather: 0.5,
                ..d.clone()
            },
        ),
    ]
}

/// Whether f32 rounding may put `n` on the other side of a hard step than f64 does.
fn near_a_hard_step(n: DVec3, l: DVec3, v: DVec3, head: DMat3, t: &Toon) -> bool {
    let (i_spec, i_diff, _, _) = toon::intensities_shifted(n, l, head, t.halo_offset.to_radians());
    let close = |x: f64, y: f64, f: f64| f <= 0.0 && (x - y).abs() < 1e-4;
    let local = head.transpose() * n;
    local.x.hypot(local.z) < 1e-3
        || close(i_diff, t.t_diffuse, t.diffuse_feather)
        || (t.tones == Tones::Three && close(i_diff, t.t_dark, t.dark_feather))
        || close(i_spec, t.t_specular, t.halo_feather)
        || (t.rim_width > 0.0 && close(t.rim_width - n.dot(v), 0.0, t.rim_feather))
}

fn f32_round(v: DVec3) -> DVec3 {
    v.as_vec3().as_dvec3()
}

#[test]
fn gpu_toon_matches_the_f64_reference_on_known_normals() {
    let probe = Probe::new();
    let normals = sphere(3000);
    let views = sphere(3001);
    let mut worst = 0.0f64;
    let (mut compared, mut skipped) = (0, 0);
    for (name, t) in contract_toons() {
        for setup in setups() {
            let items: Vec<(DVec3, DVec3, u32)> = normals
                .iter()
                .enumerate()
                .map(|(i, n)| (*n, views[(i * 17 + 3) % views.len()], 0))
                .collect();
            let got = probe.run(&t, setup, &items);
            let l = f32_round(setup.light.normalize());
            let mut worst_here = 0.0f64;
            for ((n, v, _), g) in items.iter().zip(&got) {
                let (n, v) = (f32_round(*n), f32_round(*v));
                if near_a_hard_step(n, l, v, setup.head, &t) {
                    skipped += 1;
                    continue;
                }
                let want = shade_at(n, l, v, setup.head, &t);
                let err = (DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64) - want)
                    .abs()
                    .max_element();
                worst_here = worst_here.max(err);
                compared += 1;
            }
            assert!(
                worst_here < 2e-5,
                "{name}: GPU and f64 differ by {worst_here:.2e}"
            );
            worst = worst.max(worst_here);
        }
    }
    println!("{compared} shadings compared ({skipped} within 1e-4 of a hard step skipped), worst {worst:.2e}");
}

/// `toon(n)`, what the march calls today, is `toon_at(n, V)` with V against the camera's
/// axis (`toon::camera_forward`).
#[test]
fn gpu_toon_without_a_ray_sees_along_the_camera_axis() {
    let probe = Probe::new();
    let t = Toon {
        rim_width: 0.5,
        rim_feather: 0.2,
        ..Toon::default()
    };
    let items: Vec<(DVec3, DVec3, u32)> = sphere(2000)
        .into_iter()
        .map(|n| (n, DVec3::ZERO, 1))
        .collect();
    let mut with_rim = 0;
    for setup in setups() {
        let got = probe.run(&t, setup, &items);
        let l = f32_round(setup.light.normalize());
        let v = -toon::camera_forward(setup.view_proj);
        let eye_dir = DVec3::new(30.0, 10.0, 25.0).normalize();
        assert!(
            (v - eye_dir).length() < 1e-9,
            "camera axis {v} vs {eye_dir}"
        );
        for ((n, _, _), g) in items.iter().zip(&got) {
            let n = f32_round(*n);
            if near_a_hard_step(n, l, v, setup.head, &t) {
                continue;
            }
            let want = shade_at(n, l, v, setup.head, &t);
            let err = (DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64) - want)
                .abs()
                .max_element();
            assert!(err < 2e-5, "n {n}: {err:.2e}");
            with_rim += usize::from(want != shade(n, l, setup.head, &t));
        }
    }
    assert!(with_rim > 100, "{with_rim} normals show the rim");
}

/// At the defaults the WGSL shading is bit for bit the old `toon` (inline copy above).
#[test]
fn gpu_toon_defaults_are_the_old_hard_steps_bit_for_bit() {
    let probe = Probe::new();
    let shipped = common::scene("toon").wisps().clone().unwrap().toon;
    let mut items = Vec::new();
    for n in sphere(4000) {
        items.push((n, DVec3::ZERO, 1));
        items.push((n, DVec3::ZERO, 2));
    }
    for t in [
        Toon::default(),
        Toon {
            tones: Tones::Two,
            ..Toon::default()
        },
        shipped,
    ] {
        for setup in setups() {
            let got = probe.run(&t, setup, &items);
            let mut same = 0;
            for (k, pair) in got.chunks(2).enumerate() {
                let bits = |c: &[f32; 4]| c.map(f32::to_bits);
                assert_eq!(
                    bits(&pair[0]),
                    bits(&pair[1]),
                    "n {}: {:?} vs the old {:?}",
                    items[2 * k].0,
                    pair[0],
                    pair[1]
                );
                same += 1;
            }
            assert_eq!(same, 4000);
        }
    }
}

// ---------------------------------------------------------------------------------------
// GPU renders: each control changes the pixels the reference says, and no others
// ---------------------------------------------------------------------------------------

const SIZE: (u32, u32) = (96, 96);

/// What the f64 reference finds at each pixel: the surface normal and the ray direction,
/// or nothing (outline or background).
struct ReferenceHits {
    hits: Vec<Option<(DVec3, DVec3)>>,
    light: DVec3,
    forward: DVec3,
}

fn reference_hits(scene: &Scene) -> ReferenceHits {
    let gpu = common::gpu();
    let stage = kami::stage::Stage::new(
        gpu,
        scene,
        kami::stage::target::OUTPUT_FORMAT,
        kami::stage::Quality::of(scene),
    )
    .unwrap();
    let look = stage.look();
    let frame = kami::stage::frame_uniform(scene, &look, stage.bounds(), SIZE, 1);
    let vp = DMat4::from_cols_array_2d(&frame.view_proj.map(|c| c.map(|v| v as f64)));
    let inv = vp.inverse();
    let w = scene.wisps().as_ref().unwrap();
    let segs = curve::drawn_segments(w);
    let eye = look.camera.eye;
    let eps_per_t = w.toon.outline_width / frame.raster[0] as f64;
    let mut hits = Vec::new();
    for py in 0..SIZE.1 {
        for px in 0..SIZE.0 {
            let nx = (px as f64 + 0.5) / SIZE.0 as f64 * 2.0 - 1.0;
            let ny = 1.0 - (py as f64 + 0.5) / SIZE.1 as f64 * 2.0;
            let p = inv * glam::DVec4::new(nx, ny, 1.0, 1.0);
            let far = p.truncate() / p.w;
            let t1 = (far - eye).length();
            let ray = field::Ray {
                origin: eye,
                dir: (far - eye) / t1,
                t0: 0.0,
                t1,
            };
            hits.push(
                match field::march(&segs, w.threshold, &w.march, &ray, eps_per_t).0 {
                    field::Hit::Surface { normal, .. } => Some((normal, ray.dir)),
                    _ => None,
                },
            );
        }
    }
    ReferenceHits {
        hits,
        light: DVec3::from(scene.light.direction).normalize(),
        forward: toon::camera_forward(vp),
    }
}

fn srgb8(v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    255.0
        * if v <= 0.0031308 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        }
}

/// Pixels where the reference's colour under `a` and `b` differs: any difference, and by
/// more than 8 of 255 with every neighbour on the surface. V along the pixel's ray
/// (`per_ray`) or against the camera's axis.
fn reference_change(
    r: &ReferenceHits,
    a: &Toon,
    b: &Toon,
    per_ray: bool,
) -> (Vec<bool>, Vec<bool>) {
    let n = r.hits.len();
    let (mut any, mut big) = (vec![false; n], vec![false; n]);
    for (i, h) in r.hits.iter().enumerate() {
        let Some((normal, dir)) = h else { continue };
        let v = if per_ray { -*dir } else { -r.forward };
        let ca = shade_at(*normal, r.light, v, DMat3::IDENTITY, a);
        let cb = shade_at(*normal, r.light, v, DMat3::IDENTITY, b);
        any[i] = ca != cb;
        let d = (0..3)
            .map(|k| (srgb8(ca[k]) - srgb8(cb[k])).abs())
            .fold(0.0, f64::max);
        big[i] = d > 8.0 && neighbours(i).all(|j| r.hits[j].is_some());
    }
    (any, big)
}

/// The pixel and its 8 neighbours inside the image.
fn neighbours(i: usize) -> impl Iterator<Item = usize> {
    let (w, h) = (SIZE.0 as i64, SIZE.1 as i64);
    let (x, y) = (i as i64 % w, i as i64 / w);
    (-1..=1)
        .flat_map(move |dy| (-1..=1).map(move |dx| (x + dx, y + dy)))
        .filter(move |&(x, y)| x >= 0 && y >= 0 && x < w && y < h)
        .map(move |(x, y)| (y * w + x) as usize)
}

/// Pixels whose largest channel differs by more than 2 of 255.
fn image_change(a: &image::RgbaImage, b: &image::RgbaImage) -> Vec<bool> {
    a.pixels()
        .zip(b.pixels())
        .map(|(p, q)| (0..3).any(|k| (p[k] as i32 - q[k] as i32).abs() > 2))
        .collect()
}

fn render(scene: &Scene) -> image::RgbaImage {
    // Compared with the march's f64 reference: drawn by the march.
    kami::stage::render_scene(common::gpu(), &crate::wisps::marched(scene), SIZE).unwrap()
}

fn with_toon(scene: &Scene, t: &Toon) -> Scene {
    let mut s = scene.clone();
    s.wisps_mut().as_mut().unwrap().toon = t.clone();
    s
}

/// Every changed pixel of the GPU image is one the reference changes (or next to one), and
/// the GPU changes at least 90 % of the pixels the reference changes clearly. Returns the
/// GPU's changed pixels.
fn check_changes(
    name: &str,
    r: &ReferenceHits,
    base: (&Toon, &image::RgbaImage),
    new: (&Toon, &image::RgbaImage),
    per_ray_and_axis: bool,
) -> Vec<bool> {
    let got = image_change(base.1, new.1);
    let (allowed, required) = if per_ray_and_axis {
        let (a1, b1) = reference_change(r, base.0, new.0, true);
        let (a2, b2) = reference_change(r, base.0, new.0, false);
        (
            a1.iter()
                .zip(&a2)
                .map(|(x, y)| *x || *y)
                .collect::<Vec<_>>(),
            b1.iter()
                .zip(&b2)
                .map(|(x, y)| *x && *y)
                .collect::<Vec<_>>(),
        )
    } else {
        reference_change(r, base.0, new.0, true)
    };
    let stray: Vec<usize> = (0..got.len())
        .filter(|&i| got[i] && !neighbours(i).any(|j| allowed[j]))
        .collect();
    let n_req = required.iter().filter(|x| **x).count();
    let covered = (0..got.len()).filter(|&i| required[i] && got[i]).count();
    let n_got = got.iter().filter(|x| **x).count();
    println!(
        "{name}: {n_got} pixels changed, {} stray; the reference changes {n_req} clearly, \
         {covered} of them changed",
        stray.len()
    );
    assert!(
        n_req >= 15,
        "{name}: the reference changes only {n_req} pixels clearly"
    );
    assert!(
        stray.is_empty(),
        "{name}: {} pixels changed where the reference does not, the first: {:?}",
        stray.len(),
        stray
            .iter()
            .take(12)
            .map(|i| (i % SIZE.0 as usize, i / SIZE.0 as usize))
            .collect::<Vec<_>>()
    );
    assert!(
        covered as f64 >= 0.9 * n_req as f64,
        "{name}: only {covered} of the {n_req} pixels the reference changes"
    );
    got
}

#[test]
fn each_control_changes_the_image_where_the_reference_says() {
    let scene = Scene::from_ron(SMALL, "small.ron").unwrap();
    let r = reference_hits(&scene);
    let d = scene.wisps().as_ref().unwrap().toon.clone();
    let base_img = render(&scene);
    let variants: Vec<(&str, Toon)> = vec![
        (
            "lit/shade feather",
            Toon {
                diffuse_feather: 0.3,
                ..d.clone()
            },
        ),
        (
            "shade/dark feather",
            Toon {
                dark_feather: 0.25,
                ..d.clone()
            },
        ),
        (
            "halo feather",
            Toon {
                halo_feather: 0.06,
                specular: [0.8, 0.8, 0.6],
                ..d.clone()
            },
        ),
        (
            "halo strength",
            Toon {
                halo_strength: 0.3,
                ..d.clone()
            },
        ),
        (
            "halo width",
            Toon {
                t_specular: 0.9,
                ..d.clone()
            },
        ),
    ];
    for (name, t) in &variants {
        let img = render(&with_toon(&scene, t));
        check_changes(name, &r, (&d, &base_img), (t, &img), false);
    }
    // The halo offset moves the band: up (toward the crown) for a positive offset, down for
    // a negative one; on screen, the pixels that gain the band lie above (below) those that
    // lose it.
    let lum = |p: &image::Rgba<u8>| p[0] as i32 + p[1] as i32 + p[2] as i32;
    for offset in [20.0, -20.0] {
        let moved = Toon {
            halo_offset: offset,
            ..d.clone()
        };
        let img = render(&with_toon(&scene, &moved));
        let name = format!("halo offset {offset}°");
        let got = check_changes(&name, &r, (&d, &base_img), (&moved, &img), false);
        let (mut gain, mut lose) = ((0.0, 0), (0.0, 0));
        for (i, c) in got.iter().enumerate() {
            if !c {
                continue;
            }
            let (x, y) = (i as u32 % SIZE.0, i as u32 / SIZE.0);
            let acc = if lum(img.get_pixel(x, y)) > lum(base_img.get_pixel(x, y)) {
                &mut gain
            } else {
                &mut lose
            };
            acc.0 += y as f64;
            acc.1 += 1;
        }
        let (gy, ly) = (gain.0 / gain.1.max(1) as f64, lose.0 / lose.1.max(1) as f64);
        println!(
            "{name}: {} pixels gain the band (mean row {gy:.1}), {} lose it ({ly:.1})",
            gain.1, lose.1
        );
        assert!(gain.1 > 10 && lose.1 > 10, "{name}: the band did not move");
        assert!(
            (gy - ly) * offset.signum() < -1.0,
            "{name}: the band moved the wrong way"
        );
    }
    // The halo's colour over the shade tones (the band reaches them with t_diffuse 0.8).
    let shady = Toon {
        t_diffuse: 0.8,
        t_specular: 0.9,
        ..d.clone()
    };
    let shady_img = render(&with_toon(&scene, &shady));
    let tinted = Toon {
        halo_shadow: Some([0.9, 0.2, 0.2]),
        ..shady.clone()
    };
    let img = render(&with_toon(&scene, &tinted));
    check_changes(
        "halo shadow colour",
        &r,
        (&shady, &shady_img),
        (&tinted, &img),
        false,
    );
    // The rim: on the shadow side near the silhouette only (V per ray or along the
    // camera's axis: the march passes no ray to the shading yet).
    let rim = Toon {
        rim: [0.9, 0.9, 0.2],
        rim_width: 0.6,
        ..d.clone()
    };
    let rim_img = render(&with_toon(&scene, &rim));
    let got = check_changes("rim", &r, (&d, &base_img), (&rim, &rim_img), true);
    // Independently of the reference: every rim pixel is within 6 pixels of the silhouette
    // (a pixel off the surface) and was not lit.
    let lit = field::linear(d.diffuse);
    let lit8 = [0, 1, 2].map(|k| srgb8(lit[k]).round() as i32);
    for (i, c) in got.iter().enumerate() {
        if !c {
            continue;
        }
        let (x, y) = ((i % SIZE.0 as usize) as i64, (i / SIZE.0 as usize) as i64);
        let near = (-6..=6).any(|dy| {
            (-6..=6).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                u >= 0
                    && v >= 0
                    && u < SIZE.0 as i64
                    && v < SIZE.1 as i64
                    && r.hits[(v * SIZE.0 as i64 + u) as usize].is_none()
            })
        });
        assert!(near, "rim at ({x}, {y}) far from the silhouette");
        let p = base_img.get_pixel(x as u32, y as u32);
        assert!(
            (0..3).any(|k| (p[k] as i32 - lit8[k]).abs() > 3),
            "rim at ({x}, {y}) on a lit pixel"
        );
    }
    let soft = Toon {
        rim_feather: 0.3,
        ..rim.clone()
    };
    let img = render(&with_toon(&scene, &soft));
    check_changes("rim feather", &r, (&rim, &rim_img), (&soft, &img), true);
}

/// The f64 reference image (`field::render_reference`, V along each ray) and the GPU agree
/// with the view-independent controls on, as `tests/it/wisps.rs` checks the defaults.
#[test]
fn ray_march_with_toon_controls_matches_the_f64_reference_image() {
    let mut scene = Scene::from_ron(SMALL, "small.ron").unwrap();
    let t = Toon {
        diffuse_feather: 0.25,
        dark_feather: 0.15,
        halo_feather: 0.05,
        halo_offset: 12.0,
        halo_strength: 1.4,
        halo_shadow: Some([0.9, 0.15, 0.2]),
        t_specular: 0.9,
        // The band crosses the shade tones too.
        t_diffuse: 0.75,
        ..Toon::default()
    };
    scene.wisps_mut().as_mut().unwrap().toon = t;
    let img = render(&scene);
    let gpu = common::gpu();
    let stage = kami::stage::Stage::new(
        gpu,
        &scene,
        kami::stage::target::OUTPUT_FORMAT,
        kami::stage::Quality::of(&scene),
    )
    .unwrap();
    let look = stage.look();
    let frame = kami::stage::frame_uniform(&scene, &look, stage.bounds(), SIZE, 1);
    let vp = DMat4::from_cols_array_2d(&frame.view_proj.map(|c| c.map(|v| v as f64)));
    let w = scene.wisps().as_ref().unwrap();
    let segs = curve::drawn_segments(w);
    let bg = field::linear(scene.render.background);
    let (colours, _) = field::render_reference(
        &segs,
        w.threshold,
        &w.march,
        &w.toon,
        DVec3::from(scene.light.direction),
        DMat3::IDENTITY,
        look.camera.eye,
        vp.inverse(),
        frame.raster[0] as f64,
        SIZE,
        bg,
    );
    let (mut over, mut over4, mut shaded) = (0, 0, 0);
    for (i, c) in colours.iter().enumerate() {
        let p = img.get_pixel(i as u32 % SIZE.0, i as u32 / SIZE.0);
        let worst = (0..3)
            .map(|k| (p[k] as f64 - srgb8(c[k]).round()).abs())
            .fold(0.0, f64::max);
        over += usize::from(worst > 24.0);
        over4 += usize::from(worst > 4.0);
        shaded += usize::from((*c - bg).length() > 1e-3);
    }
    let n = (SIZE.0 * SIZE.1) as f64;
    println!("{over} of {n} pixels over 24, {over4} over 4, {shaded} wisp pixels in the reference");
    assert!(shaded > 1000);
    // Edge pixels (a sample on either side of the surface, the shell or a hard step) may
    // differ: at most 0.2 % by more than 24, 1 % by more than 4.
    assert!(
        (over as f64) < 0.002 * n,
        "{over} pixels differ by more than 24"
    );
    assert!(
        (over4 as f64) < 0.01 * n,
        "{over4} pixels differ by more than 4"
    );
}
