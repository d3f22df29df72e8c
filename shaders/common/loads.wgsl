// Load fields limited to half-spaces. Twin of GpuLoad in src/systems/anjyo/gpu_data.rs and
// ResolvedLoad in src/systems/anjyo/groom.rs. Needs `loads: array<Load>` bound by the including shader.
struct Load {
    // xyz: force (uniform) or point (toward); w: 0 uniform, 1 toward.
    field: vec4<f32>,
    // x: strength (toward); y: number of planes.
    params: vec4<f32>,
    planes: array<vec4<f32>, 4>,
}

// Total load per unit length from loads [first, first + count) on a segment whose midpoint
// is `rest` on the straight unloaded beam (regions select by it) and `p` now (where the
// field is evaluated).
fn load_at(first: u32, count: u32, rest: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    var total = vec3<f32>(0.0);
    for (var i = first; i < first + count; i++) {
        var inside = true;
        let planes = u32(loads[i].params.y);
        for (var j = 0u; j < planes; j++) {
            let pl = loads[i].planes[j];
            if dot(pl.xyz, rest) < pl.w {
                inside = false;
            }
        }
        if !inside {
            continue;
        }
        let f = loads[i].field;
        if f.w < 0.5 {
            total += f.xyz;
        } else {
            let t = f.xyz - p;
            let l = length(t);
            if l > 0.0 {
                total += t / l * loads[i].params.x;
            }
        }
    }
    return total;
}
