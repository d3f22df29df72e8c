mod common;

use glam::DVec3;
use kami::systems::strips::dynamics::*;

#[test]
fn explore() {
    let s = Setup::gust();
    let rows = work_precision(&s, &[30.0, 60.0, 120.0, 240.0, 480.0], 45).unwrap();
    for r in &rows {
        eprintln!("{r:?}");
    }
    eprintln!("order {:?}", observed_order(&rows));
    eprintln!("1% dt {:?}", dt_for_error(&rows, 0.01));
    let clip = simulate(&s.rest, &s.motion, &s.forces, &s.head, &s.extra, 45).unwrap();
    let n = clip[0].len();
    for f in [0, 5, 10, 20, 30, 45] {
        eprintln!("frame {f}: tip0 {:?} tip5 {:?}", clip[f][8], clip[f][n - 1]);
    }
    let _ = DVec3::ZERO;
}

#[test]
fn explore_gpu() {
    use kami::forces::eff::EffGpu;
    use kami::systems::strips::dynamics_gpu::DynamicsGpu;
    let gpu = common::gpu();
    let s = Setup::gust();
    let mut rig = Rig::new(&s.rest, &s.motion).unwrap();
    let eff = EffGpu::new(&gpu, None).unwrap();
    let mut g = DynamicsGpu::new(&gpu, &rig, &s.motion, &s.head, &eff).unwrap();
    g.set_extra(&gpu, &s.extra).unwrap();
    let stride = rig.stride();
    for f in 0..50u64 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        g.record(&gpu, &mut enc, &s.forces, f, 1).unwrap();
        gpu.queue.submit([enc.finish()]);
        rig.run_frames(&s.forces, &s.head, &s.motion, &s.extra, f, 1);
        if f % 10 == 9 {
            let gp = g.read_points(&gpu).unwrap();
            let cp = rig.points();
            let mut worst = 0.0f64;
            for (i, (a, b)) in gp.iter().zip(&cp).enumerate() {
                let e = (DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64) - *b).length() / rig.length(i / stride);
                worst = worst.max(e);
            }
            eprintln!("frame {f}: worst rel {worst:e}");
        }
    }
    gpu.take_error().unwrap();
}
