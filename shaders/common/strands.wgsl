// One layout for every kind of strand. Twin of GpuStrand in src/gpu/gpu_data.rs.
struct Strand {
    first_vertex: u32,
    segments: u32,
    group: u32,
    flags: u32,
    // Drawn segments, fractional (cuts).
    visible: f32,
    ka: f32,
    seg_len: f32,
    rand: f32,
}
