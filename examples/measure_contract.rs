use glam::DVec3;
use kami::gpu::{Gpu, Preference};
use kami::groom::{cantilever, prepare};
fn main() -> anyhow::Result<()> {
    let gpu = Gpu::headless(Preference::Software)?;
    for name in ["bob", "swept_back", "ponytail", "short_cut"] {
        for conv in [false, true] {
            let mut s = kami::Scene::load(format!("assets/scenes/{name}.ron"))?;
            if conv {
                for g in &mut s.groups {
                    g.bending = kami::scene::Bending::Converged {
                        max_iterations: 400,
                        tolerance: 1e-5,
                    };
                }
            }
            let input = prepare(&s)?;
            let t = std::time::Instant::now();
            let r = cantilever::bend_all(&input);
            let tc = t.elapsed();
            let t = std::time::Instant::now();
            let hair = cantilever::groom_gpu(&gpu, &input)?;
            let tg = t.elapsed();
            let v = hair.read_vertices(&gpu)?;
            let st = hair.read_strands(&gpu)?;
            let off = input.vertex_offsets();
            let mut errs = vec![];
            let mut visd = 0.0f64;
            let mut min_e = f64::MAX;
            for (i, root) in input.roots.iter().enumerate() {
                let len = root.seg_len * input.groups[root.group as usize].segments as f64;
                let mut e = 0.0f64;
                for j in off[i] as usize..off[i + 1] as usize {
                    let g = DVec3::new(v[j][0] as f64, v[j][1] as f64, v[j][2] as f64);
                    e = e.max((g - r.nodes[j]).length() / len);
                    min_e = min_e.min(input.head.eval(g));
                }
                errs.push(e);
                visd = visd.max((st[i].visible as f64 - r.visible[i]).abs());
            }
            errs.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let n = errs.len();
            println!("{name} conv={conv}: cpu {tc:?} gpu {tg:?} median {:.2e} p99 {:.2e} p999 {:.2e} max {:.2e} vis-diff max {visd:.3} min E gpu {min_e:.2e} fallbacks cpu {} gpu {}", errs[n/2], errs[n*99/100], errs[n*999/1000], errs[n-1], r.fallbacks, st.iter().filter(|s| s.flags & 1 != 0).count());
        }
    }
    Ok(())
}
