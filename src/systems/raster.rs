//! `render.strands: Auto`: each kind that draws thin strands picks, every frame, ribbons
//! (two triangles per segment, MSAA coverage) or the compute rasteriser
//! (`shaders/common/splat.wgsl`) by how wide its widest strand is on screen, in samples.
//! Ribbons for close-ups, compute for thin hair.
//!
//! The switch point is not chosen by hand: `kami bench raster` sweeps strand widths on a
//! scene of each kind, times both rasterisers and measures their image error against 64
//! samples per pixel, and writes the widest width at which the compute rasteriser is both
//! faster and no less accurate than the ribbons at the scene's MSAA
//! (`docs/raster_switch.ron`, read here at compile time). The file has one entry per
//! adapter class it was measured on (a software adapter such as lavapipe or llvmpipe, and a
//! hardware GPU), each with a width per kind; a class not measured yet uses the other's.

use crate::scene::StrandRaster;
use serde::Deserialize;
use std::sync::OnceLock;

/// What `kami bench raster` wrote.
const MEASURED: &str = include_str!("../../docs/raster_switch.ron");

/// The switch points of one adapter class and where they were measured.
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct SwitchPoint {
    /// The adapter the bench ran on.
    pub adapter: String,
    /// Per kind (`Kind::name`): the compute rasteriser draws its strands up to this wide,
    /// in samples (0: never).
    pub compute_up_to: std::collections::BTreeMap<String, f64>,
}

/// The switch points by adapter class (`docs/raster_switch.ron`).
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct Switches {
    pub software: Option<SwitchPoint>,
    pub hardware: Option<SwitchPoint>,
}

/// Past the switch point by this factor before the choice flips back (no flicker while an
/// artist zooms about the switch).
const HYSTERESIS: f64 = 1.1;

/// The measured switch points, or the reason they cannot be read.
pub fn switches() -> &'static Result<Switches, String> {
    static S: OnceLock<Result<Switches, String>> = OnceLock::new();
    S.get_or_init(|| {
        ron::from_str::<Switches>(MEASURED)
            .map_err(|e| format!("docs/raster_switch.ron: {e}"))
            .and_then(|s| {
                let ok = |p: &Option<SwitchPoint>| {
                    p.as_ref().is_none_or(|p| {
                        p.compute_up_to.values().all(|w| w.is_finite() && *w >= 0.0)
                    })
                };
                if !ok(&s.software) || !ok(&s.hardware) {
                    return Err(
                        "docs/raster_switch.ron: compute_up_to must be finite and >= 0".into(),
                    );
                }
                Ok(s)
            })
    })
}

/// The widest strand, in samples, the compute rasteriser draws of `kind` under `Auto` on
/// this class of adapter: the class's measured point, else the other class's, else 0
/// (ribbons).
pub fn compute_up_to(kind: &str, software: bool) -> f64 {
    let Ok(s) = switches() else { return 0.0 };
    let (own, other) = if software {
        (&s.software, &s.hardware)
    } else {
        (&s.hardware, &s.software)
    };
    [own, other]
        .into_iter()
        .flatten()
        .find_map(|p| p.compute_up_to.get(kind).copied())
        .unwrap_or(0.0)
}

/// Why `Auto` never picks the compute rasteriser on this adapter, if it does not: lavapipe
/// (Mesa's Vulkan software adapter; measured on Mesa 22.3.6) grows the process by about
/// 1 MiB for every frame that dispatches the compute rasteriser (320x240, one kind; the
/// same kernels on llvmpipe's GL stay flat), which a viewer left running cannot afford.
/// `render.strands: Compute` still draws with it there.
pub fn auto_refused(info: &wgpu::AdapterInfo) -> Option<&'static str> {
    (info.device_type == wgpu::DeviceType::Cpu && info.backend == wgpu::Backend::Vulkan).then_some(
        "lavapipe leaks about 1 MiB per frame that dispatches the compute rasteriser: Auto draws ribbons there",
    )
}

/// `Auto`'s switch point for `kind` on this adapter: the measured one for its class, or 0
/// (ribbons) where `auto_refused` says so.
pub fn switch_for(kind: &str, info: &wgpu::AdapterInfo) -> f64 {
    if auto_refused(info).is_some() {
        return 0.0;
    }
    compute_up_to(kind, info.device_type == wgpu::DeviceType::Cpu)
}

/// Whether strands `width` samples wide are drawn by the compute rasteriser under
/// `setting`; `was` is the last frame's choice (kept within the hysteresis band).
pub fn draws_in_compute(setting: StrandRaster, width: f64, up_to: f64, was: bool) -> bool {
    match setting {
        StrandRaster::Ribbons => false,
        StrandRaster::Compute => true,
        StrandRaster::Auto => {
            if !(width.is_finite() && up_to > 0.0) {
                return false;
            }
            if was {
                width <= up_to * HYSTERESIS
            } else {
                width <= up_to / HYSTERESIS
            }
        }
    }
}

/// The width in samples, at the nearest point of a bounding sphere (`center`, `radius`) seen
/// from `eye`, of a strand `width` world units wide drawn `scale` times wider (the level of
/// detail's widening): infinite with the eye inside the sphere (a close-up).
pub fn width_in_samples(
    width: f64,
    scale: f64,
    focal_samples: f64,
    eye: glam::DVec3,
    center: glam::DVec3,
    radius: f64,
) -> f64 {
    let near = (eye - center).length() - radius;
    if near <= 0.0 {
        return f64::INFINITY;
    }
    width * scale * focal_samples / near
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_measured_file_reads() {
        let s = switches().as_ref().unwrap();
        assert!(s.software.is_some() || s.hardware.is_some());
    }

    #[test]
    fn auto_switches_with_hysteresis() {
        let a = StrandRaster::Auto;
        assert!(draws_in_compute(a, 1.0, 2.0, false));
        assert!(!draws_in_compute(a, 3.0, 2.0, true));
        // Inside the band the last choice stays.
        assert!(draws_in_compute(a, 2.1, 2.0, true));
        assert!(!draws_in_compute(a, 2.1, 2.0, false));
        assert!(!draws_in_compute(a, f64::INFINITY, 2.0, true));
        assert!(!draws_in_compute(a, 0.5, 0.0, false));
        assert!(draws_in_compute(StrandRaster::Compute, 99.0, 0.0, false));
        assert!(!draws_in_compute(StrandRaster::Ribbons, 0.1, 9.0, true));
    }

    #[test]
    fn width_grows_as_the_eye_nears() {
        let c = glam::DVec3::ZERO;
        let far = width_in_samples(0.01, 1.0, 1000.0, glam::DVec3::new(0.0, 0.0, 5.0), c, 1.0);
        let near = width_in_samples(0.01, 1.0, 1000.0, glam::DVec3::new(0.0, 0.0, 2.0), c, 1.0);
        assert!((far - 2.5).abs() < 1e-12 && (near - 10.0).abs() < 1e-12);
        let inside = width_in_samples(0.01, 1.0, 1000.0, glam::DVec3::ZERO, c, 1.0);
        assert!(inside.is_infinite());
    }
}
