//! Kami (髪): a GPU viewer and simulator for hair, fur and toon hair.
//!
//! The flow of data: a scene file (`scene`) is loaded and validated; the `stage` builds the
//! hair systems it names (`systems::KINDS`, one folder each: Anjyo's strands `anjyo`, Van
//! Gelder and Wilhelms' fur `fur`, Sakai's toon wisps `wisps`, Kazama's strips `strips`),
//! advances all of them on one clock with the shared force fields (`forces`), and draws them
//! into one depth-tested pass, into a window (`app`) or an offscreen texture (the CLI, the
//! tests). Every GPU kernel has an f64 CPU reference beside it, used by the tests and by
//! `bench`, which holds every report (tables, plots, provenance) and every work–precision
//! study; a system exposes only what a study needs to run.
//!
//! Layers point one way: `gpu` is the leaf; `scene` knows no GPU; `forces` reads the scene;
//! `systems` build on `gpu`, `scene` and `forces`; `stage` knows systems only through the
//! `HairSystem` interface; `app` and `bench` sit on top. A kind's panels and mouse tools
//! take UI-neutral state (`systems::ui`) that the viewer hosts without knowing its type.

pub mod app;
pub mod bench;
pub mod error;
pub mod forces;
pub mod formats;
pub mod fuzz;
pub mod gpu;
pub mod rng;
pub mod scene;
pub mod shaders;
pub mod stage;
pub mod systems;

pub use error::{KamiError, Result};
pub use systems::Scene;
