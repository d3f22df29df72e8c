use glam::DVec3;
use kami::gpu::{Gpu, Preference};
use kami::groom::{cantilever, prepare};
use kami::sim::projective::{CpuSim, DynSetup};
fn main() -> anyhow::Result<()> {
    let gpu = Gpu::headless(Preference::Software)?;
    let mut scene = kami::Scene::load("assets/scenes/gust.ron")?;
    for g in &mut scene.groups {
        g.count /= 20;
    }
    let input = prepare(&scene)?;
    let out = cantilever::bend_all(&input);
    let hair = cantilever::groom_gpu(&gpu, &input)?;
    let mut sim = kami::sim::Simulation::new(&gpu, &scene, &input, &hair)?.unwrap();
    let setup = DynSetup::new(&scene, &input, &out.visible).unwrap();
    let mut cpu = CpuSim::new(setup, out.nodes.clone());
    for f in 1..=30 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        sim.record_frame(&gpu, &mut enc, &hair);
        gpu.queue.submit([enc.finish()]);
        cpu.frame();
        if f % 5 == 0 {
            let v = hair.read_vertices(&gpu)?;
            let off = input.vertex_offsets();
            let mut per: Vec<f64> = (0..input.roots.len())
                .map(|s| {
                    (off[s]..off[s + 1])
                        .map(|i| {
                            let p = v[i as usize];
                            (DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
                                - cpu.nodes[i as usize])
                                .length()
                        })
                        .fold(0.0, f64::max)
                        / 18.0
                })
                .collect();
            per.sort_by(f64::total_cmp);
            let n = per.len();
            println!(
                "frame {f}: strands {n} median {:.1e} p90 {:.1e} p99 {:.1e} max {:.1e} (>1e-2: {})",
                per[n / 2],
                per[n * 9 / 10],
                per[n * 99 / 100],
                per[n - 1],
                per.iter().filter(|&&x| x > 1e-2).count()
            );
        }
    }
    Ok(())
}
