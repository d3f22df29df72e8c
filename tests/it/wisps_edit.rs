//! The skeleton editor of the toon wisps (`systems::wisps::edit`), without a window:
//! picking, dragging under the cursor, undo and redo, the refusals, adding nodes, and 2000
//! random operations that must each leave a scene that passes validation.

use glam::{DMat4, DVec2, DVec3};
use kami::stage::camera::Camera;
use kami::systems::wisps::block::{Bundle, Node, Skeleton, Wisps};
use kami::systems::wisps::edit::{self, Editor, Sel, View, HISTORY, PICK_PX, TAPER};
use kami::systems::Scene;

fn toon() -> Scene {
    Scene::from_ron(include_str!("../../assets/scenes/toon.ron"), "toon.ron").unwrap()
}

/// The toon scene's camera, an 800x600 view, and a head turned 20 degrees (nodes live in
/// the head's rest frame, so the view must carry the pose).
fn toon_view(scene: &Scene) -> View {
    let cam = Camera::from_desc(&scene.camera);
    let head = DMat4::from_translation(DVec3::new(0.5, -1.0, 0.3))
        * DMat4::from_rotation_y(20f64.to_radians());
    View::from_camera(&cam, head, DVec2::new(800.0, 600.0), (DVec3::ZERO, 30.0))
}

/// A camera on +z looking at the origin, 800x600 pixels.
fn front_view() -> View {
    let cam = Camera {
        eye: DVec3::new(0.0, 0.0, 50.0),
        target: DVec3::ZERO,
        up: DVec3::Y,
        fov_y: 40f64.to_radians(),
    };
    View::from_camera(
        &cam,
        DMat4::IDENTITY,
        DVec2::new(800.0, 600.0),
        (DVec3::ZERO, 40.0),
    )
}

fn node(p: [f64; 3]) -> Node {
    Node { p, r: 1.0, w: 2.0 }
}

fn skel(ps: &[[f64; 3]]) -> Skeleton {
    Skeleton {
        name: String::new(),
        nodes: ps.iter().map(|&p| node(p)).collect(),
        outline: 1.0,
    }
}

fn wisps(skeletons: Vec<Skeleton>) -> Wisps {
    let mut w = toon().wisps().clone().unwrap();
    w.skeletons = skeletons;
    w.bundles.clear();
    w
}

fn px(view: &View, p: [f64; 3]) -> DVec2 {
    view.project(DVec3::from(p)).unwrap().truncate()
}

fn valid(scene: &Scene, w: &Wisps) -> Result<(), String> {
    let mut s = scene.clone();
    *s.wisps_mut() = Some(w.clone());
    kami::systems::validate(&s).map_err(|e| e.to_string())
}

#[test]
fn picking_takes_the_nearest_node_within_the_radius_and_the_front_one_on_ties() {
    let v = front_view();
    let w = wisps(vec![
        skel(&[[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [10.0, 0.0, 0.0]]),
        skel(&[[0.0, 8.0, 0.0], [0.0, 12.0, 0.0]]),
    ]);
    let sel = |s, n| {
        Some(Sel {
            skeleton: s,
            node: n,
        })
    };
    // Each node under a cursor 5 px away from it.
    for (si, sk) in w.skeletons.iter().enumerate() {
        for (ni, n) in sk.nodes.iter().enumerate() {
            let c = px(&v, n.p) + DVec2::new(3.0, -4.0);
            assert_eq!(edit::pick(&w.skeletons, &v, c, PICK_PX), sel(si, ni));
        }
    }
    // Nothing beyond the pick radius.
    let a = px(&v, [5.0, 0.0, 0.0]);
    let up = DVec2::new(0.0, -1.0);
    assert_eq!(
        edit::pick(&w.skeletons, &v, a + 9.9 * up, PICK_PX),
        sel(0, 1)
    );
    assert_eq!(edit::pick(&w.skeletons, &v, a + 10.1 * up, PICK_PX), None);
    assert_eq!(
        edit::pick(&w.skeletons, &v, DVec2::new(5.0, 5.0), PICK_PX),
        None
    );
    // Between two nodes the nearer one on screen, even if it is the farther in depth.
    let eye = DVec3::new(0.0, 0.0, 50.0);
    let near = [2.0, -10.0, 10.0];
    // Behind, drawn 0.3 units (about 6 px) to the right of the near one.
    let far = (eye + 1.8 * (DVec3::new(2.3, -10.0, 10.0) - eye)).to_array();
    let w2 = wisps(vec![
        skel(&[near, [2.0, -20.0, 10.0]]),
        skel(&[far, [-2.0, -20.0, -10.0]]),
    ]);
    let (pn, pf) = (px(&v, near), px(&v, far));
    assert!((pn - pf).length() < PICK_PX, "test setup: both in reach");
    let c = pf + 0.3 * (pn - pf);
    assert_eq!(edit::pick(&w2.skeletons, &v, c, PICK_PX), sel(1, 0));
    // Nodes on one ray from the eye (one drawn over the other): the nearest in depth wins,
    // whichever comes first in the list.
    let front = DVec3::new(3.0, 2.0, 5.0);
    let back = eye + 1.8 * (front - eye);
    let on_ray = |first: DVec3, second: DVec3| {
        wisps(vec![
            skel(&[first.to_array(), (first + DVec3::Y * 30.0).to_array()]),
            skel(&[second.to_array(), (second + DVec3::Y * 30.0).to_array()]),
        ])
    };
    let c = px(&v, front.to_array()) + DVec2::new(1.0, 1.0);
    assert_eq!(
        edit::pick(&on_ray(front, back).skeletons, &v, c, PICK_PX),
        sel(0, 0)
    );
    assert_eq!(
        edit::pick(&on_ray(back, front).skeletons, &v, c, PICK_PX),
        sel(1, 0)
    );
    // The editor's select_at selects the hit and keeps the selection on a miss.
    let mut ed = Editor::new();
    assert_eq!(ed.select_at(&w, &v, a), sel(0, 1));
    assert_eq!(ed.select_at(&w, &v, DVec2::new(5.0, 5.0)), None);
    assert_eq!(ed.selection, sel(0, 1));
}

#[test]
fn dragging_keeps_the_node_under_the_cursor_in_a_plane_parallel_to_the_screen() {
    let scene = toon();
    let v = toon_view(&scene);
    let cam = Camera::from_desc(&scene.camera);
    let head = DMat4::from_translation(DVec3::new(0.5, -1.0, 0.3))
        * DMat4::from_rotation_y(20f64.to_radians());
    let fwd = (cam.target - cam.eye).normalize();
    let mut w = scene.wisps().clone().unwrap();
    let mut ed = Editor::new();
    for (s, n) in [(0, 2), (5, 3), (16, 1)] {
        let p0 = DVec3::from(w.skeletons[s].nodes[n].p);
        // Grab it a little off centre: it keeps that offset (it does not jump).
        let grab = px(&v, p0.to_array()) + DVec2::new(2.5, -1.5);
        let hit = ed.select_at(&w, &v, grab).expect("the node is picked");
        // The toon scene's nodes overlap on screen: whichever is picked is dragged.
        let p0 = DVec3::from(w.skeletons[hit.skeleton].nodes[hit.node].p);
        let offset = grab - px(&v, p0.to_array());
        ed.begin_drag(&w, &v, grab).unwrap();
        let depth0 = (head.transform_point3(p0) - cam.eye).dot(fwd);
        for k in 1..=12 {
            let t = k as f64;
            let cursor = grab + DVec2::new(7.0 * t, -4.0 * t + 0.3 * t * t);
            ed.drag_to(&mut w, &v, cursor).unwrap();
            let p = DVec3::from(w.skeletons[hit.skeleton].nodes[hit.node].p);
            let err = (px(&v, p.to_array()) + offset - cursor).length();
            assert!(err < 1e-6, "node {hit:?} is {err:e} px off the cursor");
            let depth = (head.transform_point3(p) - cam.eye).dot(fwd);
            assert!(
                (depth - depth0).abs() < 1e-9 * depth0,
                "the node left its plane: depth {depth0} -> {depth}"
            );
        }
        ed.end_drag();
        assert!(valid(&scene, &w).is_ok());
    }
}

#[test]
fn one_drag_or_one_slider_drag_is_one_undo_step() {
    let scene = toon();
    let v = toon_view(&scene);
    let original = scene.wisps().clone().unwrap();
    let mut w = original.clone();
    let mut ed = Editor::new();
    let p = w.skeletons[3].nodes[3].p;
    let hit = ed.select_at(&w, &v, px(&v, p)).unwrap();
    ed.begin_drag(&w, &v, px(&v, p)).unwrap();
    for k in 1..=30 {
        ed.drag_to(&mut w, &v, px(&v, p) + DVec2::new(k as f64, 0.5 * k as f64))
            .unwrap();
    }
    ed.end_drag();
    assert_eq!(ed.undo_len(), 1, "30 moves of one drag are one entry");
    let dragged = w.clone();
    assert_ne!(dragged, original);
    // A click without a move adds nothing.
    ed.begin_drag(&w, &v, px(&v, p)).unwrap();
    ed.end_drag();
    assert_eq!(ed.undo_len(), 1);
    // A slider drag (many values, then the gesture ends) is one entry; the next is another.
    for k in 1..=10 {
        ed.set_radius(&mut w, 1.0 + 0.1 * k as f64).unwrap();
    }
    ed.end_gesture();
    assert_eq!(ed.undo_len(), 2);
    ed.set_radius(&mut w, 0.7).unwrap();
    assert_eq!(ed.undo_len(), 3);
    // Another property of the same node is another entry, even without end_gesture.
    ed.set_weight(&mut w, 3.0).unwrap();
    assert_eq!(ed.undo_len(), 4);
    for _ in 0..3 {
        ed.undo(&mut w).unwrap();
    }
    assert_eq!(w, dragged);
    assert_eq!(ed.selection, Some(hit));
    ed.undo(&mut w).unwrap();
    assert_eq!(w, original, "undo puts the whole drag back");
    assert!(ed.undo(&mut w).is_err());
}

/// One editor action.
type Step = Box<dyn Fn(&mut Editor, &mut Wisps) -> edit::Outcome>;

#[test]
fn undo_and_redo_restore_the_exact_skeleton_lists() {
    let scene = toon();
    let v = toon_view(&scene);
    let mut w = scene.wisps().clone().unwrap();
    w.bundles = vec![Bundle {
        wisps: vec![1, 2, 3],
        release_from: 4,
    }];
    let mut ed = Editor::new();
    let mut states = vec![w.clone()];
    let mut sels = vec![None];
    let sel = |s, n| {
        Some(Sel {
            skeleton: s,
            node: n,
        })
    };
    ed.select(&w, sel(2, 3)).unwrap();
    sels[0] = ed.selection;
    let steps: Vec<Step> = vec![
        Box::new(|e, w| e.add_after(w)),
        Box::new(|e, w| e.set_radius(w, 0.123)),
        Box::new(|e, w| {
            e.end_gesture();
            e.set_weight(w, 7.5)
        }),
        Box::new(|e, w| e.insert_between(w)),
        Box::new(|e, w| e.delete_node(w)),
        Box::new(|e, w| e.add_skeleton(w, DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO)),
        Box::new(|e, w| e.set_position(w, [1.0, 2.0, 3.0])),
        Box::new(|e, w| {
            e.select(
                w,
                Some(Sel {
                    skeleton: 1,
                    node: 0,
                }),
            )?;
            e.delete_skeleton(w)
        }),
        Box::new(move |e, w| {
            e.select(
                w,
                Some(Sel {
                    skeleton: 4,
                    node: 3,
                }),
            )?;
            e.add_at(w, &v, DVec2::new(400.0, 300.0))
        }),
        Box::new(|e, w| {
            e.select(
                w,
                Some(Sel {
                    skeleton: 0,
                    node: 1,
                }),
            )?;
            e.delete_node(w)
        }),
    ];
    for (i, step) in steps.iter().enumerate() {
        let msg = step(&mut ed, &mut w).unwrap_or_else(|e| panic!("step {i}: {e}"));
        assert!(!msg.is_empty());
        assert_ne!(&w, states.last().unwrap(), "step {i} changed nothing");
        assert!(valid(&scene, &w).is_ok(), "step {i}");
        states.push(w.clone());
        sels.push(ed.selection);
    }
    assert_eq!(ed.undo_len(), steps.len());
    // The skeleton delete took skeleton 1 out of the bundle and renumbered the rest.
    assert_eq!(w.bundles[0].wisps, vec![1, 2]);
    for k in (0..steps.len()).rev() {
        ed.undo(&mut w).unwrap();
        assert_eq!(w, states[k], "undo to state {k}");
    }
    assert!(ed.undo(&mut w).is_err(), "nothing left to undo");
    assert_eq!(ed.selection, sels[0]);
    for (k, state) in states.iter().enumerate().skip(1) {
        ed.redo(&mut w).unwrap();
        assert_eq!(&w, state, "redo to state {k}");
        assert_eq!(ed.selected(&w), ed.selection, "a valid selection");
    }
    assert_eq!(ed.selection, *sels.last().unwrap());
    assert!(ed.redo(&mut w).is_err());
    // A new action after an undo drops the redo branch.
    ed.undo(&mut w).unwrap();
    assert_eq!(ed.redo_len(), 1);
    ed.select(&w, sel(0, 0)).unwrap();
    ed.set_weight(&mut w, 0.5).unwrap();
    assert_eq!(ed.redo_len(), 0);
    // The history is bounded: the oldest entries go.
    let mut ed = Editor::new();
    let mut w = scene.wisps().clone().unwrap();
    ed.select(&w, sel(0, 0)).unwrap();
    let mut after = Vec::new();
    for k in 0..HISTORY + 50 {
        ed.set_radius(&mut w, 1.0 + k as f64 * 0.01).unwrap();
        ed.end_gesture();
        after.push(w.clone());
    }
    assert_eq!(ed.undo_len(), HISTORY);
    for _ in 0..HISTORY {
        ed.undo(&mut w).unwrap();
    }
    assert_eq!(w, after[49]);
    assert!(ed.undo(&mut w).is_err());
}

#[test]
fn deleting_is_refused_below_two_nodes_and_for_the_last_skeleton() {
    let scene = toon();
    let mut w = wisps(vec![skel(&[[0.0, 0.0, 0.0], [0.0, -3.0, 0.0]])]);
    let mut ed = Editor::new();
    ed.select(
        &w,
        Some(Sel {
            skeleton: 0,
            node: 1,
        }),
    )
    .unwrap();
    let before = w.clone();
    let e = ed.delete_node(&mut w).unwrap_err();
    assert!(e.contains("at least 2"), "{e}");
    assert_eq!(ed.last, Some(Err(e)));
    let e = ed.delete_skeleton(&mut w).unwrap_err();
    assert!(e.contains("last skeleton"), "{e}");
    assert_eq!(w, before);
    assert_eq!(ed.undo_len(), 0, "a refusal is no history entry");
    // Three nodes going out and back: deleting the middle one would join two equal nodes.
    let mut w = wisps(vec![skel(&[
        [0.0, 0.0, 0.0],
        [0.0, -3.0, 0.0],
        [0.0, 0.0, 0.0],
    ])]);
    ed.select(
        &w,
        Some(Sel {
            skeleton: 0,
            node: 1,
        }),
    )
    .unwrap();
    let e = ed.delete_node(&mut w).unwrap_err();
    assert!(e.contains("equal"), "{e}");
    assert!(valid(&scene, &w).is_ok());
    // Nothing selected: refused, with a reason.
    let mut ed = Editor::new();
    assert!(ed.delete_node(&mut w).unwrap_err().contains("select"));
}

#[test]
fn adding_nodes_extrapolates_along_the_chain_and_tapers() {
    let scene = toon();
    let v = toon_view(&scene);
    let mut w = scene.wisps().clone().unwrap();
    let mut ed = Editor::new();
    let tip = w.skeletons[0].nodes.len() - 1;
    ed.select(
        &w,
        Some(Sel {
            skeleton: 0,
            node: tip,
        }),
    )
    .unwrap();
    let (a, b) = (w.skeletons[0].nodes[tip - 1], w.skeletons[0].nodes[tip]);
    ed.add_after(&mut w).unwrap();
    let n = w.skeletons[0].nodes[tip + 1];
    let want = 2.0 * DVec3::from(b.p) - DVec3::from(a.p);
    assert!(
        (DVec3::from(n.p) - want).length() < 1e-12,
        "{:?} vs {want}",
        n.p
    );
    assert_eq!(n.r, b.r * TAPER);
    assert_eq!(n.w, b.w);
    assert_eq!(
        ed.selection,
        Some(Sel {
            skeleton: 0,
            node: tip + 1
        })
    );
    // Again from the new tip: the same step once more.
    ed.add_after(&mut w).unwrap();
    let m = w.skeletons[0].nodes[tip + 2];
    assert!((DVec3::from(m.p) - (2.0 * want - DVec3::from(b.p))).length() < 1e-9);
    assert!(m.r < n.r);
    // Inside the chain: halfway to the next node, means of r and w.
    ed.select(
        &w,
        Some(Sel {
            skeleton: 1,
            node: 0,
        }),
    )
    .unwrap();
    let (x, y) = (w.skeletons[1].nodes[0], w.skeletons[1].nodes[1]);
    ed.add_after(&mut w).unwrap();
    let mid = w.skeletons[1].nodes[1];
    assert_eq!(
        mid.p,
        (0.5 * (DVec3::from(x.p) + DVec3::from(y.p))).to_array()
    );
    assert_eq!(mid.r, 0.5 * (x.r + y.r));
    // At the cursor: on the selected node's depth, under the cursor, after it.
    ed.select(
        &w,
        Some(Sel {
            skeleton: 2,
            node: 3,
        }),
    )
    .unwrap();
    let depth = v.project(DVec3::from(w.skeletons[2].nodes[3].p)).unwrap().z;
    let cursor = DVec2::new(321.25, 287.5);
    ed.add_at(&mut w, &v, cursor).unwrap();
    let q = v.project(DVec3::from(w.skeletons[2].nodes[4].p)).unwrap();
    assert!((q.truncate() - cursor).length() < 1e-6 && (q.z - depth).abs() < 1e-9);
    // At the selected node itself: refused (it would sit on it).
    let here = px(&v, w.skeletons[2].nodes[4].p);
    let e = ed.add_at(&mut w, &v, here).unwrap_err();
    assert!(e.contains("sit on"), "{e}");
    // Full skeletons refuse.
    let mut full = wisps(vec![skel(
        &(0..64).map(|k| [0.0, -(k as f64), 0.0]).collect::<Vec<_>>(),
    )]);
    ed.select(
        &full,
        Some(Sel {
            skeleton: 0,
            node: 63,
        }),
    )
    .unwrap();
    assert!(ed.add_after(&mut full).unwrap_err().contains("64"));
    assert!(valid(&scene, &w).is_ok());
}

/// xorshift64*: small and deterministic.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Mostly ordinary values, sometimes hostile ones.
    fn value(&mut self) -> f64 {
        match self.below(12) {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => -self.unit() * 5.0,
            3 => 0.0,
            4 => 1e9,
            5 => 1e-12,
            _ => self.unit() * 6.0,
        }
    }
}

#[test]
fn two_thousand_random_operations_always_leave_a_valid_scene() {
    let scene = toon();
    let views = [toon_view(&scene), front_view()];
    let mut w = scene.wisps().clone().unwrap();
    w.bundles = vec![
        Bundle {
            wisps: vec![0, 1, 2],
            release_from: 3,
        },
        Bundle {
            wisps: vec![7, 8],
            release_from: 4,
        },
    ];
    assert!(valid(&scene, &w).is_ok());
    let mut ed = Editor::new();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut ok = [0usize; 16];
    let mut refused = [0usize; 16];
    for step in 0..2000 {
        let v = views[rng.below(2)];
        // Cursors mostly near nodes, sometimes anywhere (also off the view).
        let cursor = if rng.below(3) > 0 && !w.skeletons.is_empty() {
            let sk = &w.skeletons[rng.below(w.skeletons.len())];
            let n = &sk.nodes[rng.below(sk.nodes.len())];
            v.project(DVec3::from(n.p))
                .map(|q| q.truncate())
                .unwrap_or(DVec2::ZERO)
                + DVec2::new(rng.unit() * 16.0 - 8.0, rng.unit() * 16.0 - 8.0)
        } else {
            DVec2::new(rng.unit() * 1200.0 - 200.0, rng.unit() * 900.0 - 150.0)
        };
        let op = rng.below(16);
        let out: edit::Outcome = match op {
            0 => ed
                .select_at(&w, &v, cursor)
                .map(|s| format!("{s:?}"))
                .ok_or_else(|| "miss".to_string()),
            1 => {
                let s = rng.below(w.skeletons.len() + 1);
                let n = rng.below(66);
                ed.select(
                    &w,
                    Some(Sel {
                        skeleton: s,
                        node: n,
                    }),
                )
            }
            2 => {
                // A whole drag: press, a few moves, release.
                let r = ed.begin_drag(&w, &v, cursor);
                if r.is_ok() {
                    for _ in 0..rng.below(6) {
                        let to = cursor
                            + DVec2::new(rng.unit() * 300.0 - 150.0, rng.unit() * 300.0 - 150.0);
                        let _ = ed.drag_to(&mut w, &v, to);
                    }
                    // Sometimes straight back onto a neighbour's spot on screen.
                    if rng.below(4) == 0 {
                        if let Some(s) = ed.selected(&w) {
                            let nb = if s.node > 0 { s.node - 1 } else { 1 };
                            let q = w.skeletons[s.skeleton].nodes[nb].p;
                            if let Some(q) = v.project(DVec3::from(q)) {
                                let _ = ed.drag_to(&mut w, &v, q.truncate());
                            }
                        }
                    }
                }
                ed.end_drag();
                r
            }
            3 => ed.set_radius(&mut w, rng.value()),
            4 => ed.set_weight(&mut w, rng.value()),
            5 => ed.scale_radius(&mut w, rng.value()),
            6 => {
                let p = [rng.value() * 4.0 - 10.0, rng.value(), rng.value() * 1e6];
                ed.set_position(&mut w, p)
            }
            7 => ed.add_after(&mut w),
            8 => ed.add_at(&mut w, &v, cursor),
            9 => ed.insert_between(&mut w),
            10 => ed.delete_node(&mut w),
            11 => {
                let shift = DVec3::new(rng.value(), rng.value() - 3.0, rng.unit() * 4.0);
                ed.add_skeleton(&mut w, shift, DVec3::new(0.0, 11.5, 0.0))
            }
            12 => ed.delete_skeleton(&mut w),
            13 | 14 => ed.undo(&mut w),
            _ => {
                if rng.below(2) == 0 {
                    ed.end_gesture();
                }
                ed.redo(&mut w)
            }
        };
        match &out {
            Ok(m) => {
                assert!(!m.is_empty());
                ok[op] += 1;
            }
            Err(e) => {
                assert!(!e.is_empty(), "a refusal says why");
                refused[op] += 1;
            }
        }
        if let Err(e) = valid(&scene, &w) {
            panic!("step {step}, operation {op} ({out:?}) left an invalid scene: {e}");
        }
        let all_finite = w
            .skeletons
            .iter()
            .flat_map(|s| &s.nodes)
            .all(|n| n.p.iter().all(|c| c.is_finite()) && n.r.is_finite() && n.w.is_finite());
        assert!(all_finite, "step {step}");
        if let Some(s) = ed.selection {
            assert!(
                s.skeleton < w.skeletons.len() && s.node < w.skeletons[s.skeleton].nodes.len(),
                "step {step}: selection {s:?} points nowhere"
            );
        }
    }
    // The sequence did exercise every operation both ways where both can happen.
    for op in 0..16 {
        assert!(ok[op] > 0, "operation {op} never succeeded: {ok:?}");
    }
    for op in [3, 6, 7, 8, 10, 12, 13] {
        assert!(
            refused[op] > 0,
            "operation {op} was never refused: {refused:?}"
        );
    }
    // Undo everything that is left: still valid at every step.
    while ed.undo(&mut w).is_ok() {
        assert!(valid(&scene, &w).is_ok());
    }
}
