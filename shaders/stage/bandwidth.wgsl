// The bandwidth probe of `kami bench scale`: every invocation reads one vec4 and writes one, a
// streaming copy through the shader cores as the simulation's kernels move their data, so the
// bound it measures is one a storage-buffer kernel can reach (a buffer-to-buffer copy may go
// through a copy engine that reads slower than the cores do).

@group(0) @binding(0) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> dst: array<vec4<f32>>;

// Rows of workgroups: one dispatch dimension holds at most 65,535 of them.
@compute @workgroup_size(256)
fn stream(@builtin(global_invocation_id) g: vec3<u32>, @builtin(num_workgroups) n: vec3<u32>) {
    let i = g.x + g.y * n.x * 256u;
    if (i < arrayLength(&dst)) {
        dst[i] = src[i];
    }
}
