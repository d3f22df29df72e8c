//! The scene file as a whole, as the kinds see it: the blocks every scene shares
//! (`crate::scene`: head, forces, camera, light, render settings) and each kind's block,
//! held by type (`Block`) so that this module names no kind. Each kind defines its block's
//! type, checks and accessors in its own folder (`systems/<kind>/block.rs`:
//! `scene.groups()`, `scene.fur_mut()`); the registry (`systems/mod.rs`) writes the
//! file format from `KINDS`, builds a default scene with every kind's block, and reads,
//! validates and merges scenes. Kinds import this module and the contract
//! (`systems::kind`, `systems::system`), never the registry: no import cycle.

use crate::scene::{CameraDesc, Ellipsoid, ForcesDesc, Head, Light, RenderSettings};
use std::any::Any;
use std::fmt::Debug;

/// A whole scene: the shared blocks and each kind's block. The file format (`Scene(...)`
/// with every field flat) is written by the registry from `KINDS`; a default scene (the file
/// `Scene()`) has every kind's default block and no hair.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Seed of every random draw (pores, lengths, per-strand ambient).
    pub seed: u64,
    /// The head hull (a default head when absent: fur scenes need none).
    pub head: Head,
    /// The world's forces, shared by every kind (`scene::forces`).
    pub forces: ForcesDesc,
    pub camera: CameraDesc,
    pub light: Light,
    pub render: RenderSettings,
    /// Each kind's block, in `KINDS` order; read through the accessors each kind defines.
    pub blocks: Blocks,
}

/// A kind's block of the scene: plain data a scene can clone, compare and print.
pub trait Block: Any + Debug + Send + Sync {
    fn clone_block(&self) -> Box<dyn Block>;
    /// Equal to `other` (a block of the same type).
    fn same(&self, other: &dyn Block) -> bool;
}

impl<T: Any + Clone + PartialEq + Debug + Send + Sync> Block for T {
    fn clone_block(&self) -> Box<dyn Block> {
        Box::new(self.clone())
    }

    fn same(&self, other: &dyn Block) -> bool {
        (other as &dyn Any).downcast_ref::<T>() == Some(self)
    }
}

/// Every kind's block of one scene, one per kind in `KINDS` order (the registry builds the
/// list; nothing else can, so a block a kind asks for is always there).
#[derive(Debug)]
pub struct Blocks(Vec<Box<dyn Block>>);

impl Blocks {
    /// The registry's list: one block per kind, in `KINDS` order.
    pub(crate) fn new(blocks: Vec<Box<dyn Block>>) -> Blocks {
        Blocks(blocks)
    }

    /// The kind block of type `T` (each kind's accessors on `Scene` call this; a kind's
    /// panel borrows it beside the shared blocks through `Scene { render, blocks, .. }`).
    pub fn get<T: Block>(&self) -> &T {
        self.0
            .iter()
            .find_map(|b| (b.as_ref() as &dyn Any).downcast_ref::<T>())
            .expect("the registry builds every kind's block")
    }

    /// The kind block of type `T`, to edit.
    pub fn get_mut<T: Block>(&mut self) -> &mut T {
        self.0
            .iter_mut()
            .find_map(|b| (b.as_mut() as &mut dyn Any).downcast_mut::<T>())
            .expect("the registry builds every kind's block")
    }

    /// Each block of `self` (the file's new version) picked against `base` and `ours` as
    /// [`pick`] does (`merge_edits`).
    pub(crate) fn pick(&mut self, base: &Blocks, ours: &Blocks) {
        for ((t, b), o) in self.0.iter_mut().zip(&base.0).zip(&ours.0) {
            if t.same(b.as_ref()) && !o.same(b.as_ref()) {
                *t = o.clone_block();
            }
        }
    }
}

impl Clone for Blocks {
    fn clone(&self) -> Blocks {
        Blocks(self.0.iter().map(|b| b.clone_block()).collect())
    }
}

impl PartialEq for Blocks {
    fn eq(&self, other: &Blocks) -> bool {
        self.0.len() == other.0.len()
            && self.0.iter().zip(&other.0).all(|(a, b)| a.same(b.as_ref()))
    }
}

/// `theirs` unless it equals `base` and `ours` was edited: then `ours` (`merge_edits`).
pub fn pick<T: PartialEq + Clone>(base: &T, ours: &T, theirs: T) -> T {
    if theirs == *base && ours != base {
        ours.clone()
    } else {
        theirs
    }
}

impl Scene {
    /// The kind block of type `T` (each kind's accessors call this).
    pub fn block<T: Block>(&self) -> &T {
        self.blocks.get()
    }

    /// The kind block of type `T`, to edit.
    pub fn block_mut<T: Block>(&mut self) -> &mut T {
        self.blocks.get_mut()
    }

    /// Pretty RON, for saving a tuned scene.
    pub fn to_ron(&self) -> String {
        let cfg = ron::ser::PrettyConfig::new()
            .depth_limit(6)
            .struct_names(true);
        ron::ser::to_string_pretty(self, cfg).expect("scene types always serialise")
    }

    /// The head hull as an ellipsoid.
    pub fn head_ellipsoid(&self) -> Ellipsoid {
        Ellipsoid::new(self.head.center, self.head.radii)
    }
}
