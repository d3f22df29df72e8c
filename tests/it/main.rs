//! Kami's integration tests, one binary (`cargo test --test it`; one module: `cargo test
//! --test it guides::`). One binary links wgpu and the library once instead of once per
//! file, and every test shares one GPU device per backend (`common::gpu`). Each module keeps
//! the name of the file it used to be (`tests/<name>.rs`, now `tests/it/<name>.rs`); data the
//! tests read stays where it was (`tests/snapshots`, `tests/fuzz_corpus`, `tests/usd_check.py`,
//! `tests/abc_write.py`).

mod alembic;
mod bad_input;
mod bench_paths;
mod caches;
mod cli;
mod common;
mod contract;
mod coverage;
mod docs;
mod eff;
mod eff_anjyo;
mod forces;
mod formats;
mod fur;
mod fur_skinned;
mod fuzz;
mod gpu_twins;
mod guides;
mod hair_bsdf;
mod head;
mod imported;
mod layers;
mod lod;
mod look;
mod mesh;
mod mesh_head;
mod near_field;
mod numerics;
mod scale;
mod shader_validation;
mod shadow_skin;
mod shadows;
mod snapshot;
mod splat;
mod stability;
mod stage;
mod strand_vary;
mod strips;
mod strips_capture;
mod strips_dynamics;
mod strips_mesh_head;
mod strips_pick;
mod strips_render;
mod strips_sky;
mod usd_curves;
mod viewer;
mod winding;
mod wisps;
mod wisps_edit;
mod wisps_field;
mod wisps_fingers;
mod wisps_forces;
mod wisps_mesh;
mod wisps_springs;
mod wisps_toon;

/// The binary's allocator: `fuzz::CappedAlloc` (allocations above `fuzz::ALLOC_CAP` made by
/// a fuzz input are findings, `fuzz`), recording the largest single allocation per thread
/// (`common::largest_allocation`: a loader never reserves what a lying header asks for,
/// `mesh`). Both watch only their own thread, so tests on other threads do not disturb them.
#[global_allocator]
static ALLOC: common::TestAlloc = common::TestAlloc;
