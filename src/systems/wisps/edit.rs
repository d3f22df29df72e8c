//! The skeleton editor (Sakai, section 6 and Fig. 9): picking, dragging and editing the
//! nodes of the wisps' skeletons, with undo and redo. Pure logic on `Wisps` and a `View`
//! (a model-view-projection matrix and a viewport in pixels), no window: the viewer's
//! Skeletons panel and its mouse mode call it, and `tests/it/wisps_edit.rs` drives it directly.
//!
//! Every operation returns `Ok(message)` or `Err(reason)` and never panics. An edit is first
//! made on a copy, then checked by the wisps' validator (`block::validate`, through
//! `check`); a refused edit leaves the wisps and the history as they were. So whatever the
//! sequence of operations, the skeletons stay valid: 2 to 64 nodes, finite positions,
//! radius and weight in (0, 1e6], neighbouring nodes distinct.
//!
//! History: each action is one undo entry holding the skeletons, the bundles and the
//! selection from before it (at most `HISTORY` entries, the oldest dropped first). Edits of
//! one property of one node in a row — the moves of a drag, the values of a slider drag, the
//! clicks of a mouse wheel — merge into one entry until `end_gesture` (or `end_drag`, or
//! any other action) closes it.

use crate::systems::scene::Scene;
use crate::systems::wisps::block::{Node, Skeleton, Wisps};
use glam::{DVec2, DVec3};
use std::collections::VecDeque;

/// Most undo entries kept.
pub const HISTORY: usize = 200;
/// Pick radius around a node's projected centre, pixels.
pub const PICK_PX: f64 = 10.0;
/// Nodes closer to the cursor than the best by at most this many pixels count as a tie,
/// and the one nearest the eye wins (nodes drawn on top of one another).
pub const TIE_PX: f64 = 1.0;
/// Most nodes per skeleton and most skeletons: the scene check's limits (`block.rs`).
pub use super::block::{MAX_WISPS as MAX_SKELETONS, MAX_WISP_NODES as MAX_NODES};
/// Radius and weight are clamped into [MIN_VALUE, MAX_VALUE]: the scene check's upper bound
/// (`scene::validate::BIG`), and a floor above its 0 so a drag cannot shrink a node to
/// nothing.
pub const MIN_VALUE: f64 = 1e-3;
pub const MAX_VALUE: f64 = crate::scene::validate::BIG;
/// Node coordinates stay within ±LIMIT.
pub const LIMIT: f64 = 1e6;
/// A node added past the tip has the tip's radius times this.
pub const TAPER: f64 = 0.75;

/// What an operation says: what it did, or why it refused.
pub type Outcome = std::result::Result<String, String>;

/// A selected node: indices into `Wisps::skeletons` and the skeleton's `nodes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Sel {
    pub skeleton: usize,
    pub node: usize,
}

/// Where the nodes land on screen (`gpu::view::ScreenView`, shared with the other kinds'
/// mouse tools): node positions are in the head's rest frame.
pub use crate::gpu::view::ScreenView as View;

fn pos(n: &Node) -> DVec3 {
    DVec3::from(n.p)
}

/// The node whose projection is nearest `cursor` (pixels), among those within `radius_px`;
/// nodes within `TIE_PX` of the nearest distance count as tied and the one nearest the eye
/// wins. None when no node is that close (or all are behind the eye).
pub fn pick(skeletons: &[Skeleton], view: &View, cursor: DVec2, radius_px: f64) -> Option<Sel> {
    let mut hits: Vec<(f64, f64, Sel)> = Vec::new();
    for (si, sk) in skeletons.iter().enumerate() {
        for (ni, n) in sk.nodes.iter().enumerate() {
            let Some(s) = view.project(pos(n)) else {
                continue;
            };
            let d = (s.truncate() - cursor).length();
            if d <= radius_px {
                hits.push((
                    d,
                    s.z,
                    Sel {
                        skeleton: si,
                        node: ni,
                    },
                ));
            }
        }
    }
    let best = hits.iter().map(|h| h.0).fold(f64::INFINITY, f64::min);
    hits.into_iter()
        .filter(|h| h.0 <= best + TIE_PX)
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.total_cmp(&b.0)))
        .map(|h| h.2)
}

/// The wisps' validator's verdict on `w` (in an otherwise default scene).
pub fn check(w: &Wisps) -> std::result::Result<(), String> {
    let mut probe = Scene::default();
    *probe.wisps_mut() = Some(w.clone());
    super::block::validate(&probe).map_err(|e| e.to_string())
}

/// Why node `i` of `sk` cannot stay as it is: not finite, out of range, or on a neighbour
/// (the validator's rule: closer than 1e-6 of the smaller radius).
fn node_problem(sk: &Skeleton, i: usize) -> Option<String> {
    let n = sk.nodes.get(i)?;
    if n.p.iter().any(|c| !c.is_finite() || c.abs() > LIMIT) {
        return Some(format!(
            "node {i} would leave the allowed space (coordinates within ±{LIMIT:e})"
        ));
    }
    if !(n.r > 0.0 && n.r <= MAX_VALUE && n.w > 0.0 && n.w <= MAX_VALUE) {
        return Some(format!(
            "node {i}: radius and weight must be in (0, {MAX_VALUE:e}]"
        ));
    }
    let near = |j: usize| {
        let m = &sk.nodes[j];
        (pos(n) - pos(m)).length() <= 1e-6 * n.r.min(m.r).max(1e-9)
    };
    if i > 0 && near(i - 1) {
        return Some(format!(
            "node {i} would sit on node {}: neighbouring nodes must differ",
            i - 1
        ));
    }
    if i + 1 < sk.nodes.len() && near(i + 1) {
        return Some(format!(
            "node {i} would sit on node {}: neighbouring nodes must differ",
            i + 1
        ));
    }
    None
}

fn clamp_value(v: f64, what: &str) -> std::result::Result<f64, String> {
    if v.is_nan() {
        return Err(format!("{what} must be a number"));
    }
    Ok(v.clamp(MIN_VALUE, MAX_VALUE))
}

fn label(w: &Wisps, s: usize) -> String {
    match w.skeletons.get(s) {
        Some(sk) if !sk.name.is_empty() => format!("{s} ({})", sk.name),
        _ => s.to_string(),
    }
}

/// The state before an action: what undo puts back.
#[derive(Clone, Debug, PartialEq)]
struct Snapshot {
    skeletons: Vec<Skeleton>,
    bundles: Vec<crate::systems::wisps::block::Bundle>,
    selection: Option<Sel>,
    /// What the action did (for the Undo/Redo messages).
    what: String,
}

impl Snapshot {
    fn of(w: &Wisps, selection: Option<Sel>, what: String) -> Snapshot {
        Snapshot {
            skeletons: w.skeletons.clone(),
            bundles: w.bundles.clone(),
            selection,
            what,
        }
    }
}

/// Edits that merge while repeated: one property of one node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Merge {
    Move(Sel),
    Position(Sel),
    Radius(Sel),
    Weight(Sel),
    /// A skeleton's outline scale.
    Outline(usize),
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Drag {
    sel: Sel,
    /// Cursor minus the node's projection when the drag began: the node keeps this offset
    /// to the cursor (it does not jump to it).
    offset: DVec2,
}

/// The skeleton editor's state: the selection and the history.
#[derive(Clone, Debug, Default)]
pub struct Editor {
    /// The selected node, if any (always a valid index after an operation).
    pub selection: Option<Sel>,
    /// The last operation's outcome (the panel shows it).
    pub last: Option<Outcome>,
    undo: VecDeque<Snapshot>,
    redo: Vec<Snapshot>,
    merge: Option<Merge>,
    drag: Option<Drag>,
}

impl Editor {
    pub fn new() -> Editor {
        Editor::default()
    }

    /// Undo entries held.
    pub fn undo_len(&self) -> usize {
        self.undo.len()
    }

    pub fn redo_len(&self) -> usize {
        self.redo.len()
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    pub fn dragging(&self) -> bool {
        self.drag.is_some()
    }

    /// The selection if it names a node of `w`.
    pub fn selected(&self, w: &Wisps) -> Option<Sel> {
        self.selection.filter(|s| {
            w.skeletons
                .get(s.skeleton)
                .is_some_and(|sk| s.node < sk.nodes.len())
        })
    }

    fn need(&self, w: &Wisps) -> std::result::Result<Sel, String> {
        self.selected(w)
            .ok_or_else(|| "select a node first (click one, or pick it in the list)".to_string())
    }

    fn say(&mut self, out: Outcome) -> Outcome {
        self.last = Some(out.clone());
        out
    }

    /// Close the open gesture: the next edit starts a new undo entry.
    pub fn end_gesture(&mut self) {
        self.merge = None;
    }

    /// Make an edit on a copy, check it, then keep it as one history entry (or as part of
    /// the open gesture's entry when `merge` continues it).
    fn act(
        &mut self,
        w: &mut Wisps,
        merge: Option<Merge>,
        f: impl FnOnce(&mut Wisps, &mut Option<Sel>) -> Outcome,
    ) -> Outcome {
        let out = self.try_act(w, merge, f);
        self.say(out)
    }

    fn try_act(
        &mut self,
        w: &mut Wisps,
        merge: Option<Merge>,
        f: impl FnOnce(&mut Wisps, &mut Option<Sel>) -> Outcome,
    ) -> Outcome {
        let before = self.selected(w);
        let mut cand = w.clone();
        let mut sel = before;
        let msg = f(&mut cand, &mut sel)?;
        check(&cand)?;
        let sel = sel.filter(|s| {
            cand.skeletons
                .get(s.skeleton)
                .is_some_and(|sk| s.node < sk.nodes.len())
        });
        if cand.skeletons != w.skeletons || cand.bundles != w.bundles {
            if merge.is_none() || merge != self.merge {
                self.push_undo(Snapshot::of(w, before, msg.clone()));
                self.redo.clear();
            }
            w.skeletons = cand.skeletons;
            w.bundles = cand.bundles;
        }
        self.merge = merge;
        self.selection = sel;
        Ok(msg)
    }

    fn push_undo(&mut self, s: Snapshot) {
        self.undo.push_back(s);
        while self.undo.len() > HISTORY {
            self.undo.pop_front();
        }
    }

    /// Select a node by index (None clears the selection).
    pub fn select(&mut self, w: &Wisps, sel: Option<Sel>) -> Outcome {
        let out = match sel {
            None => {
                self.selection = None;
                Ok("selection cleared".into())
            }
            Some(s) => match w.skeletons.get(s.skeleton) {
                Some(sk) if s.node < sk.nodes.len() => {
                    self.selection = Some(s);
                    Ok(format!(
                        "node {} of skeleton {}",
                        s.node,
                        label(w, s.skeleton)
                    ))
                }
                _ => Err(format!(
                    "there is no node {} in skeleton {}",
                    s.node, s.skeleton
                )),
            },
        };
        self.merge = None;
        self.say(out)
    }

    /// Select the node under `cursor` (within `PICK_PX`, see `pick`). A miss keeps the
    /// selection and returns None.
    pub fn select_at(&mut self, w: &Wisps, view: &View, cursor: DVec2) -> Option<Sel> {
        let hit = pick(&w.skeletons, view, cursor, PICK_PX)?;
        let _ = self.select(w, Some(hit));
        Some(hit)
    }

    /// Start dragging the selected node with the cursor at `cursor`.
    pub fn begin_drag(&mut self, w: &Wisps, view: &View, cursor: DVec2) -> Outcome {
        let out = (|| {
            let sel = self.need(w)?;
            let p = pos(&w.skeletons[sel.skeleton].nodes[sel.node]);
            let s = view
                .project(p)
                .ok_or("the selected node is behind the eye: it cannot be dragged")?;
            self.merge = None;
            self.drag = Some(Drag {
                sel,
                offset: cursor - s.truncate(),
            });
            Ok(format!("dragging node {}", sel.node))
        })();
        self.say(out)
    }

    /// Move the dragged node so it stays under the cursor: in the plane through it parallel
    /// to the screen (its depth in `view` is kept). All moves of one drag are one undo
    /// entry; a move onto a neighbour or out of range is refused (the node stays).
    pub fn drag_to(&mut self, w: &mut Wisps, view: &View, cursor: DVec2) -> Outcome {
        let Some(d) = self.drag else {
            return self.say(Err("no drag in progress".into()));
        };
        if self.selected(w) != Some(d.sel) {
            self.drag = None;
            return self.say(Err("the dragged node is gone".into()));
        }
        self.act(w, Some(Merge::Move(d.sel)), |w, _| {
            let sk = &mut w.skeletons[d.sel.skeleton];
            let p = pos(&sk.nodes[d.sel.node]);
            let s = view.project(p).ok_or("the node is behind the eye")?;
            let to = view
                .unproject(cursor - d.offset, s.z)
                .ok_or("the cursor does not map to a point in the scene")?;
            sk.nodes[d.sel.node].p = to.to_array();
            if let Some(e) = node_problem(sk, d.sel.node) {
                return Err(e);
            }
            Ok(format!(
                "moved node {} of skeleton {}",
                d.sel.node, d.sel.skeleton
            ))
        })
    }

    /// End the drag (the next edit is a new undo entry).
    pub fn end_drag(&mut self) {
        self.drag = None;
        self.merge = None;
    }

    fn set_node(
        &mut self,
        w: &mut Wisps,
        merge: fn(Sel) -> Merge,
        what: &'static str,
        f: impl FnOnce(&mut Node) -> std::result::Result<(), String>,
    ) -> Outcome {
        let sel = match self.need(w) {
            Ok(s) => s,
            Err(e) => return self.say(Err(e)),
        };
        self.act(w, Some(merge(sel)), |w, _| {
            let sk = &mut w.skeletons[sel.skeleton];
            f(&mut sk.nodes[sel.node])?;
            if let Some(e) = node_problem(sk, sel.node) {
                return Err(e);
            }
            Ok(format!("set the {what} of node {}", sel.node))
        })
    }

    /// Set the selected node's radius of influence (clamped into [MIN_VALUE, MAX_VALUE]).
    pub fn set_radius(&mut self, w: &mut Wisps, r: f64) -> Outcome {
        self.set_node(w, Merge::Radius, "radius", |n| {
            n.r = clamp_value(r, "the radius")?;
            Ok(())
        })
    }

    /// Set the selected node's weight (clamped into [MIN_VALUE, MAX_VALUE]).
    pub fn set_weight(&mut self, w: &mut Wisps, v: f64) -> Outcome {
        self.set_node(w, Merge::Weight, "weight", |n| {
            n.w = clamp_value(v, "the weight")?;
            Ok(())
        })
    }

    /// Set the selected node's skeleton's outline scale (`Skeleton::outline`, clamped into
    /// [0, 8]).
    pub fn set_outline(&mut self, w: &mut Wisps, scale: f64) -> Outcome {
        let sel = match self.need(w) {
            Ok(s) => s,
            Err(e) => return self.say(Err(e)),
        };
        self.act(w, Some(Merge::Outline(sel.skeleton)), |w, _| {
            if !scale.is_finite() {
                return Err("the outline scale must be a finite number".into());
            }
            w.skeletons[sel.skeleton].outline = scale.clamp(0.0, 8.0);
            Ok(format!("set the outline of skeleton {}", sel.skeleton))
        })
    }

    /// Multiply the selected node's radius by `factor` (the mouse wheel).
    pub fn scale_radius(&mut self, w: &mut Wisps, factor: f64) -> Outcome {
        match self.selected(w) {
            Some(s) => {
                let r = w.skeletons[s.skeleton].nodes[s.node].r * factor;
                self.set_radius(w, r)
            }
            None => self.set_radius(w, 1.0),
        }
    }

    /// Multiply the selected node's weight by `factor` (Shift + mouse wheel).
    pub fn scale_weight(&mut self, w: &mut Wisps, factor: f64) -> Outcome {
        match self.selected(w) {
            Some(s) => {
                let v = w.skeletons[s.skeleton].nodes[s.node].w * factor;
                self.set_weight(w, v)
            }
            None => self.set_weight(w, 1.0),
        }
    }

    /// Place the selected node at `p` (the panel's position fields).
    pub fn set_position(&mut self, w: &mut Wisps, p: [f64; 3]) -> Outcome {
        self.set_node(w, Merge::Position, "position", |n| {
            n.p = p;
            Ok(())
        })
    }

    fn insert(
        w: &mut Wisps,
        sel: &mut Option<Sel>,
        s: usize,
        at: usize,
        node: Node,
    ) -> std::result::Result<(), String> {
        let sk = &mut w.skeletons[s];
        if sk.nodes.len() >= MAX_NODES {
            return Err(format!(
                "skeleton {s} has {MAX_NODES} nodes, the most a skeleton may have"
            ));
        }
        sk.nodes.insert(at, node);
        if let Some(e) = node_problem(sk, at) {
            return Err(e);
        }
        *sel = Some(Sel {
            skeleton: s,
            node: at,
        });
        Ok(())
    }

    /// Add a node after the selected one: past the tip, extrapolated along the last segment
    /// (same length and direction) with the radius tapered by `TAPER`; inside the chain,
    /// halfway to the next node (as `insert_between`). The new node is selected.
    pub fn add_after(&mut self, w: &mut Wisps) -> Outcome {
        let sel = match self.need(w) {
            Ok(s) => s,
            Err(e) => return self.say(Err(e)),
        };
        let tip = sel.node + 1 == w.skeletons[sel.skeleton].nodes.len();
        if !tip {
            return self.insert_between(w);
        }
        self.act(w, None, |w, out| {
            let nodes = &w.skeletons[sel.skeleton].nodes;
            let last = nodes[sel.node];
            let p = match sel.node.checked_sub(1).map(|i| nodes[i]) {
                Some(prev) => 2.0 * pos(&last) - pos(&prev),
                None => pos(&last) + DVec3::new(0.0, -2.0 * last.r, 0.0),
            };
            let node = Node {
                p: p.to_array(),
                r: (last.r * TAPER).max(MIN_VALUE),
                w: last.w,
            };
            Self::insert(w, out, sel.skeleton, sel.node + 1, node)?;
            Ok(format!(
                "added node {} to skeleton {}",
                sel.node + 1,
                label(w, sel.skeleton)
            ))
        })
    }

    /// Add a node after the selected one at the cursor, at the selected node's depth
    /// (the double click). Past the tip its radius is the tip's tapered; inside the chain
    /// radius and weight are the neighbours' means.
    pub fn add_at(&mut self, w: &mut Wisps, view: &View, cursor: DVec2) -> Outcome {
        let sel = match self.need(w) {
            Ok(s) => s,
            Err(e) => return self.say(Err(e)),
        };
        self.act(w, None, |w, out| {
            let nodes = &w.skeletons[sel.skeleton].nodes;
            let here = nodes[sel.node];
            let s = view
                .project(pos(&here))
                .ok_or("the selected node is behind the eye")?;
            let p = view
                .unproject(cursor, s.z)
                .ok_or("the cursor does not map to a point in the scene")?;
            let (r, wt) = match nodes.get(sel.node + 1) {
                Some(next) => (0.5 * (here.r + next.r), 0.5 * (here.w + next.w)),
                None => ((here.r * TAPER).max(MIN_VALUE), here.w),
            };
            let node = Node {
                p: p.to_array(),
                r,
                w: wt,
            };
            Self::insert(w, out, sel.skeleton, sel.node + 1, node)?;
            Ok(format!(
                "added node {} to skeleton {} at the cursor",
                sel.node + 1,
                label(w, sel.skeleton)
            ))
        })
    }

    /// Insert a node halfway between the selected node and the next one (the previous one
    /// when the tip is selected); radius and weight are the two nodes' means.
    pub fn insert_between(&mut self, w: &mut Wisps) -> Outcome {
        let sel = match self.need(w) {
            Ok(s) => s,
            Err(e) => return self.say(Err(e)),
        };
        self.act(w, None, |w, out| {
            let nodes = &w.skeletons[sel.skeleton].nodes;
            let a = if sel.node + 1 < nodes.len() {
                sel.node
            } else {
                sel.node.checked_sub(1).ok_or("the skeleton has one node")?
            };
            let (x, y) = (nodes[a], nodes[a + 1]);
            let node = Node {
                p: (0.5 * (pos(&x) + pos(&y))).to_array(),
                r: 0.5 * (x.r + y.r),
                w: 0.5 * (x.w + y.w),
            };
            Self::insert(w, out, sel.skeleton, a + 1, node)?;
            Ok(format!(
                "inserted node {} between nodes {a} and {} of skeleton {}",
                a + 1,
                a + 1,
                label(w, sel.skeleton)
            ))
        })
    }

    /// Delete the selected node (refused when the skeleton would keep fewer than 2 nodes, or
    /// when its neighbours would then coincide). The previous node is selected. Bundles'
    /// `release_from` is clamped to the new node count.
    pub fn delete_node(&mut self, w: &mut Wisps) -> Outcome {
        let sel = match self.need(w) {
            Ok(s) => s,
            Err(e) => return self.say(Err(e)),
        };
        self.act(w, None, |w, out| {
            let sk = &mut w.skeletons[sel.skeleton];
            if sk.nodes.len() <= 2 {
                return Err(format!(
                    "skeleton {} has {} nodes: a skeleton needs at least 2 (delete the skeleton instead)",
                    sel.skeleton,
                    sk.nodes.len()
                ));
            }
            sk.nodes.remove(sel.node);
            let keep = sel.node.saturating_sub(1);
            if sel.node > 0 && sel.node < sk.nodes.len() {
                if let Some(e) = node_problem(sk, sel.node) {
                    return Err(format!("deleting it would join two equal nodes ({e})"));
                }
            }
            let n = sk.nodes.len();
            for b in &mut w.bundles {
                if b.wisps.contains(&sel.skeleton) {
                    b.release_from = b.release_from.min(n);
                }
            }
            *out = Some(Sel {
                skeleton: sel.skeleton,
                node: keep,
            });
            Ok(format!(
                "deleted node {} of skeleton {}",
                sel.node,
                label(w, sel.skeleton)
            ))
        })
    }

    /// Add a skeleton: a copy of the selected node's skeleton moved by `shift`, or, with
    /// nothing selected, a default four-node wisp hanging down from `at`. The new
    /// skeleton's node is selected.
    pub fn add_skeleton(&mut self, w: &mut Wisps, shift: DVec3, at: DVec3) -> Outcome {
        let sel = self.selected(w);
        self.act(w, None, |w, out| {
            if w.skeletons.len() >= MAX_SKELETONS {
                return Err(format!(
                    "the scene has {MAX_SKELETONS} skeletons, the most allowed"
                ));
            }
            let (sk, node, what) = match sel {
                Some(s) => {
                    if !shift.is_finite() {
                        return Err("the shift must be finite".into());
                    }
                    let mut sk = w.skeletons[s.skeleton].clone();
                    for n in &mut sk.nodes {
                        n.p = (pos(n) + shift).to_array();
                    }
                    sk.name = if sk.name.is_empty() {
                        format!("copy of {}", s.skeleton)
                    } else {
                        format!("{} copy", sk.name)
                    };
                    (
                        sk,
                        s.node,
                        format!("copied skeleton {}", label(w, s.skeleton)),
                    )
                }
                None => {
                    if !at.is_finite() {
                        return Err("the place must be finite".into());
                    }
                    let nodes = [2.0, 1.6, 1.1, 0.5]
                        .iter()
                        .enumerate()
                        .map(|(k, &r)| Node {
                            p: (at - DVec3::new(0.0, 3.0 * k as f64, 0.0)).to_array(),
                            r,
                            w: 2.5,
                        })
                        .collect();
                    let sk = Skeleton {
                        name: format!("wisp {}", w.skeletons.len()),
                        nodes,
                        outline: 1.0,
                    };
                    (sk, 0, "added a default skeleton".to_string())
                }
            };
            if let Some(e) = (0..sk.nodes.len()).find_map(|i| node_problem(&sk, i)) {
                return Err(format!("the new skeleton: {e}"));
            }
            w.skeletons.push(sk);
            let s = w.skeletons.len() - 1;
            *out = Some(Sel { skeleton: s, node });
            Ok(format!("{what} as skeleton {s}"))
        })
    }

    /// Delete the selected node's skeleton (not the last one). Bundles drop it (and are
    /// dropped when fewer than 2 wisps remain in them); later skeletons move down by one.
    pub fn delete_skeleton(&mut self, w: &mut Wisps) -> Outcome {
        let sel = match self.need(w) {
            Ok(s) => s,
            Err(e) => return self.say(Err(e)),
        };
        self.act(w, None, |w, out| {
            if w.skeletons.len() <= 1 {
                return Err("this is the last skeleton: wisps need at least one".into());
            }
            let what = format!("deleted skeleton {}", label(w, sel.skeleton));
            w.skeletons.remove(sel.skeleton);
            let s = sel.skeleton;
            for b in &mut w.bundles {
                b.wisps.retain(|&i| i != s);
                for i in &mut b.wisps {
                    if *i > s {
                        *i -= 1;
                    }
                }
            }
            let before = w.bundles.len();
            w.bundles.retain(|b| b.wisps.len() >= 2);
            let dropped = before - w.bundles.len();
            *out = None;
            Ok(if dropped > 0 {
                format!("{what} (and {dropped} bundle(s) left with one wisp)")
            } else {
                what
            })
        })
    }

    /// Undo the last action (skeletons, bundles and selection as they were before it).
    pub fn undo(&mut self, w: &mut Wisps) -> Outcome {
        self.drag = None;
        self.merge = None;
        let out = match self.undo.pop_back() {
            None => Err("nothing to undo".into()),
            Some(s) => {
                let what = s.what.clone();
                self.redo
                    .push(Snapshot::of(w, self.selected(w), what.clone()));
                w.skeletons = s.skeletons;
                w.bundles = s.bundles;
                self.selection = s.selection;
                Ok(format!("undid: {what}"))
            }
        };
        self.say(out)
    }

    /// Redo the last undone action.
    pub fn redo(&mut self, w: &mut Wisps) -> Outcome {
        self.drag = None;
        self.merge = None;
        let out = match self.redo.pop() {
            None => Err("nothing to redo".into()),
            Some(s) => {
                let what = s.what.clone();
                self.push_undo(Snapshot::of(w, self.selected(w), what.clone()));
                w.skeletons = s.skeletons;
                w.bundles = s.bundles;
                self.selection = s.selection;
                Ok(format!("redid: {what}"))
            }
        };
        self.say(out)
    }
}
