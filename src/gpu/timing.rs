//! GPU time per pass of a frame, from timestamp queries written between passes.
//!
//! Why timestamps: waiting for the GPU after each pass to time it (what the viewer did)
//! serialises CPU and GPU, and on a real GPU the CPU clock around a submission measures the
//! driver, not the pass. A timestamp pair around each phase costs nothing and is read back
//! a few frames later from a small ring of mappable buffers, so the frame never waits.
//!
//! Adapters without `TIMESTAMP_QUERY` + `TIMESTAMP_QUERY_INSIDE_ENCODERS` get no timer
//! ([`GpuTimer::new`] returns `None`); callers then say so and fall back to CPU-side timing
//! (`kami bench scale` submits and waits per phase and labels the figures).

use super::Gpu;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

/// The phases of a frame, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Every system's motion (`Stage::advance`).
    Simulation = 0,
    /// View-dependent compute before drawing: fur generation, culling (`HairSystem::prepare`).
    Generation = 1,
    /// The scene pass: head, skins and every system's hair, supersampled and multisampled.
    Draw = 2,
    /// Averaging the supersampled, multisampled target down into the output.
    Resolve = 3,
    /// The viewer's egui panels.
    Panels = 4,
}

/// How many phases there are.
pub const PHASES: usize = 5;

impl Phase {
    pub const ALL: [Phase; PHASES] = [
        Phase::Simulation,
        Phase::Generation,
        Phase::Draw,
        Phase::Resolve,
        Phase::Panels,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Phase::Simulation => "simulation",
            Phase::Generation => "generation",
            Phase::Draw => "draw",
            Phase::Resolve => "resolve",
            Phase::Panels => "panels",
        }
    }
}

/// One frame's GPU times in milliseconds; `None` for a phase that did not run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassTimes {
    pub phases: [Option<f64>; PHASES],
    /// From the first phase's start to the last phase's end (includes any idle gap between
    /// submissions).
    pub frame: Option<f64>,
}

impl PassTimes {
    pub fn get(&self, p: Phase) -> Option<f64> {
        self.phases[p as usize]
    }

    /// The sum of the phases that ran (GPU busy time of the frame's passes).
    pub fn busy(&self) -> f64 {
        self.phases.iter().flatten().sum()
    }
}

/// Where a readback buffer is in its cycle.
const FREE: u8 = 0;
const QUEUED: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;

struct Slot {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
    used: [bool; PHASES],
}

/// Readback buffers in flight: results arrive this many frames late at most before a frame's
/// timings are dropped rather than waited for.
const RING: usize = 4;
/// Resolve destinations must be 256-byte aligned: one 256-byte row per phase.
const ROW: u64 = wgpu::QUERY_RESOLVE_BUFFER_ALIGNMENT;

/// Timestamp pairs around each phase, resolved and read back without waiting.
pub struct GpuTimer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    ring: Vec<Slot>,
    used: [bool; PHASES],
    open: [bool; PHASES],
    period_ns: f64,
    latest: Option<PassTimes>,
    /// Frames whose timings were dropped because every readback buffer was busy.
    pub dropped: u64,
}

/// The features a timer needs.
pub fn features() -> wgpu::Features {
    wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
}

impl GpuTimer {
    /// A timer, or `None` when the device was not given timestamp queries (the adapter lacks
    /// them).
    pub fn new(gpu: &Gpu) -> Option<GpuTimer> {
        if !gpu.device.features().contains(features()) {
            return None;
        }
        let device = &gpu.device;
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * PHASES as u32,
        });
        let size = ROW * PHASES as u64;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp resolve"),
            size,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let ring = (0..RING)
            .map(|_| Slot {
                buffer: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamp readback"),
                    size,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                state: Arc::new(AtomicU8::new(FREE)),
                used: [false; PHASES],
            })
            .collect();
        Some(GpuTimer {
            set,
            resolve,
            ring,
            used: [false; PHASES],
            open: [false; PHASES],
            period_ns: gpu.queue.get_timestamp_period() as f64,
            latest: None,
            dropped: 0,
        })
    }

    /// Record the start of `phase`.
    pub fn begin(&mut self, enc: &mut wgpu::CommandEncoder, phase: Phase) {
        let p = phase as usize;
        enc.write_timestamp(&self.set, 2 * p as u32);
        self.open[p] = true;
    }

    /// Record the end of `phase` (after a `begin` for it this frame).
    pub fn end(&mut self, enc: &mut wgpu::CommandEncoder, phase: Phase) {
        let p = phase as usize;
        if self.open[p] {
            enc.write_timestamp(&self.set, 2 * p as u32 + 1);
            self.open[p] = false;
            self.used[p] = true;
        }
    }

    /// Record the read-back of this frame's timestamps into a free ring buffer (call once,
    /// in the frame's last encoder, then [`GpuTimer::submitted`] after submitting it). With
    /// every buffer still in flight the frame's timings are dropped, never waited for.
    pub fn finish(&mut self, enc: &mut wgpu::CommandEncoder) {
        let used = std::mem::take(&mut self.used);
        self.open = [false; PHASES];
        if !used.iter().any(|u| *u) {
            return;
        }
        let Some(slot) = self
            .ring
            .iter_mut()
            .find(|s| s.state.load(Ordering::Acquire) == FREE)
        else {
            self.dropped += 1;
            return;
        };
        for (p, _) in used.iter().enumerate().filter(|(_, u)| **u) {
            enc.resolve_query_set(
                &self.set,
                2 * p as u32..2 * p as u32 + 2,
                &self.resolve,
                ROW * p as u64,
            );
        }
        enc.copy_buffer_to_buffer(&self.resolve, 0, &slot.buffer, 0, ROW * PHASES as u64);
        slot.used = used;
        slot.state.store(QUEUED, Ordering::Release);
    }

    /// Start mapping what [`GpuTimer::finish`] recorded, once its encoder is submitted.
    pub fn submitted(&mut self) {
        for slot in &self.ring {
            if slot.state.load(Ordering::Acquire) != QUEUED {
                continue;
            }
            slot.state.store(MAPPING, Ordering::Release);
            let state = slot.state.clone();
            slot.buffer
                .slice(..)
                .map_async(wgpu::MapMode::Read, move |r| {
                    // A failed map frees the slot; that frame's timings are lost.
                    state.store(if r.is_ok() { MAPPED } else { FREE }, Ordering::Release);
                });
        }
    }

    /// The newest frame's times that have arrived, without waiting (polls the device).
    pub fn poll(&mut self, gpu: &Gpu) -> Option<PassTimes> {
        let _ = gpu.device.poll(wgpu::PollType::Poll);
        self.collect();
        self.latest
    }

    /// Wait for everything submitted, then the newest frame's times (benches).
    pub fn wait(&mut self, gpu: &Gpu) -> crate::error::Result<Option<PassTimes>> {
        gpu.wait()?;
        self.collect();
        Ok(self.latest)
    }

    /// Forget the last result (so a caller can tell a new one from an old one).
    pub fn clear(&mut self) {
        self.latest = None;
    }

    fn collect(&mut self) {
        for slot in &self.ring {
            if slot.state.load(Ordering::Acquire) != MAPPED {
                continue;
            }
            let ticks: Option<Vec<u64>> = slot
                .buffer
                .slice(..)
                .get_mapped_range()
                .ok()
                .map(|view| bytemuck::cast_slice::<u8, u64>(&view).to_vec());
            slot.buffer.unmap();
            slot.state.store(FREE, Ordering::Release);
            if let Some(ticks) = ticks {
                self.latest = Some(times(&ticks, &slot.used, self.period_ns));
            }
        }
    }
}

/// Milliseconds per phase from resolved ticks (row p holds phase p's begin and end).
fn times(ticks: &[u64], used: &[bool; PHASES], period_ns: f64) -> PassTimes {
    let per_row = (ROW / 8) as usize;
    let mut t = PassTimes::default();
    let (mut first, mut last) = (u64::MAX, 0u64);
    for (p, _) in used.iter().enumerate().filter(|(_, u)| **u) {
        let (b, e) = (ticks[p * per_row], ticks[p * per_row + 1]);
        t.phases[p] = Some(e.saturating_sub(b) as f64 * period_ns * 1e-6);
        first = first.min(b);
        last = last.max(e);
    }
    if first < last {
        t.frame = Some((last - first) as f64 * period_ns * 1e-6);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_become_milliseconds_per_phase() {
        let mut ticks = vec![0u64; (ROW / 8) as usize * PHASES];
        let row = (ROW / 8) as usize;
        ticks[0] = 1_000;
        ticks[1] = 3_000;
        ticks[2 * row] = 4_000;
        ticks[2 * row + 1] = 9_000;
        let mut used = [false; PHASES];
        used[0] = true;
        used[2] = true;
        let t = times(&ticks, &used, 1000.0);
        assert_eq!(t.get(Phase::Simulation), Some(2.0));
        assert_eq!(t.get(Phase::Draw), Some(5.0));
        assert_eq!(t.get(Phase::Generation), None);
        assert_eq!(t.frame, Some(8.0));
        assert_eq!(t.busy(), 7.0);
    }
}
