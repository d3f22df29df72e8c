//! The stage: it builds only the systems a scene names, keeps every system on one clock,
//! classifies edits per system, and resets to the rest pose.

use crate::common;
use crate::common::stage;

use kami::stage::Stage;
use kami::systems::anjyo::AnjyoSystem;
use kami::systems::fur::FurSystem;
use kami::systems::{anjyo, fur, Change};

fn kinds(s: &Stage) -> Vec<&'static str> {
    s.systems().iter().map(|s| s.kind()).collect()
}

/// The gust with a tenth of its hairs (the test is about bookkeeping, not looks).
fn small_gust() -> kami::Scene {
    let mut s = common::scene("gust");
    for g in s.groups_mut() {
        g.count /= 10;
    }
    s
}

fn vertices(gpu: &kami::gpu::Gpu, s: &Stage) -> Vec<[f32; 4]> {
    s.system::<AnjyoSystem>()
        .unwrap()
        .hair
        .read_vertices(gpu)
        .unwrap()
}

fn advance(gpu: &kami::gpu::Gpu, s: &mut Stage, frames: u32) {
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    s.advance(gpu, &mut enc, frames).unwrap();
    gpu.queue.submit([enc.finish()]);
}

#[test]
fn only_the_systems_a_scene_names_are_built() {
    let gpu = common::gpu();
    let bob = stage(gpu, &common::scene("bob"));
    assert_eq!(kinds(&bob), ["anjyo"]);
    assert!(
        bob.system::<AnjyoSystem>().unwrap().sim.is_none(),
        "a still groom allocates no simulation"
    );
    assert!(bob.has_head());
    let fur = stage(gpu, &common::scene("fur"));
    assert_eq!(kinds(&fur), ["fur"]);
    assert!(!fur.has_head(), "an invisible head builds no head pass");
    let both = stage(gpu, &common::scene("hair_and_fur"));
    assert_eq!(kinds(&both), ["anjyo", "fur"]);
    // The bounds hold both systems' spheres.
    let (c, r) = both.bounds();
    for s in both.systems() {
        let (sc, sr) = s.bounds();
        assert!(
            (sc - c).length() + sr <= r + 1e-9,
            "{} sticks out",
            s.kind()
        );
    }
}

#[test]
fn one_clock_for_every_system_and_reset_returns_to_rest() {
    let gpu = common::gpu();
    let mut s = stage(gpu, &small_gust());
    let rest = vertices(gpu, &s);
    advance(gpu, &mut s, 5);
    assert_eq!(s.frame(), 5);
    let moved = vertices(gpu, &s);
    let most = rest
        .iter()
        .zip(&moved)
        .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0f32, f32::max))
        .fold(0.0f32, f32::max);
    assert!(most > 1.0, "the hair did not move in 5 frames ({most})");
    // Five frames in one submission are five frames one by one.
    let mut t = stage(gpu, &small_gust());
    for _ in 0..5 {
        advance(gpu, &mut t, 1);
    }
    assert_eq!(vertices(gpu, &t), moved);
    s.reset(gpu).unwrap();
    assert_eq!(s.frame(), 0);
    assert_eq!(vertices(gpu, &s), rest, "reset is the groomed rest pose");
    // And from rest the same motion again.
    advance(gpu, &mut s, 5);
    assert_eq!(vertices(gpu, &s), moved);
}

#[test]
fn edits_rebuild_resimulate_or_redraw_one_system() {
    let gpu = common::gpu();
    let scene = small_gust();
    let mut s = stage(gpu, &scene);
    advance(gpu, &mut s, 3);

    let mut look = scene.clone();
    look.groups_mut()[0].material.color = [0.9, 0.5, 0.1];
    let a = s.apply(gpu, &look).unwrap();
    assert_eq!(a.changes, [("anjyo", Change::Redraw)]);
    assert!(!a.restarted);
    assert_eq!(s.frame(), 3, "a look change keeps the pose");

    let mut damp = look.clone();
    damp.dynamics_mut().as_mut().unwrap().damping = 2.0;
    let a = s.apply(gpu, &damp).unwrap();
    assert_eq!(a.changes, [("anjyo", Change::Resimulate)]);
    assert_eq!(s.frame(), 3);

    let mut stiff = damp.clone();
    stiff.groups_mut()[1].rigidity *= 2.0;
    let a = s.apply(gpu, &stiff).unwrap();
    assert_eq!(a.changes, [("anjyo", Change::Rebuild)]);
    assert!(a.restarted);
    assert_eq!(s.frame(), 0, "a new rest pose restarts the clock");

    // Adding fur builds the fur system beside the hair; taking the hair away frees it.
    let mut with_fur = stiff.clone();
    *with_fur.fur_mut() = common::scene("fur").fur().clone();
    let a = s.apply(gpu, &with_fur).unwrap();
    assert_eq!(
        a.changes,
        [("anjyo", Change::None), ("fur", Change::Rebuild)]
    );
    assert_eq!(kinds(&s), ["anjyo", "fur"]);
    let mut fur_only = with_fur.clone();
    fur_only.groups_mut().clear();
    s.apply(gpu, &fur_only).unwrap();
    assert_eq!(kinds(&s), ["fur"]);
    assert!(s.system::<FurSystem>().is_some());
}

/// Each kind's classification, without a GPU.
#[test]
fn each_kind_classifies_its_own_edits() {
    let a = common::scene("gust");
    let same = |b: &kami::Scene| (anjyo::classify(&a, b), fur::classify(&a, b));
    let mut b = a.clone();
    b.groups_mut()[0].material.width = 0.2;
    assert_eq!(same(&b), (Change::Redraw, Change::None));
    let mut b = a.clone();
    b.groups_mut()[0].material.ka_spread = 0.5;
    assert_eq!(
        same(&b).0,
        Change::Rebuild,
        "k_a is drawn per strand at groom"
    );
    let mut b = a.clone();
    *b.dynamics_mut() = None;
    assert_eq!(same(&b).0, Change::Rebuild);
    let mut b = a.clone();
    b.render.msaa = 1;
    b.light.intensity = 2.0;
    assert_eq!(same(&b), (Change::None, Change::None), "the stage's own");

    let f = common::scene("fur");
    let mut g = f.clone();
    g.fur_mut().as_mut().unwrap().coats[0].material.shininess = 5.0;
    assert_eq!(fur::classify(&f, &g), Change::Redraw);
    g.fur_mut().as_mut().unwrap().hairs += 1;
    assert_eq!(fur::classify(&f, &g), Change::Rebuild);
    let mut g = f.clone();
    g.fur_mut().as_mut().unwrap().coats[1].stiffness = 0.1;
    assert_eq!(fur::classify(&f, &g), Change::Rebuild, "shape, not look");
    let mut g = f.clone();
    g.seed += 1;
    assert_eq!(fur::classify(&f, &g), Change::Rebuild);
    assert_eq!(
        anjyo::classify(&f, &g),
        Change::Rebuild,
        "the seed draws the pores too"
    );
}

/// An edit the stage refuses (here fur beyond the adapter's limits, together with a hair
/// edit that would rebuild the hair) leaves the stage as it was: both systems, the clock,
/// the scene. It used to keep only the kinds handled before the failing one.
#[test]
fn a_refused_edit_keeps_what_was_drawn() {
    let gpu = common::gpu();
    let mut scene = small_gust();
    *scene.fur_mut() = common::scene("fur").fur().clone();
    let mut s = stage(gpu, &scene);
    advance(gpu, &mut s, 2);
    let before = vertices(gpu, &s);
    let mut bad = scene.clone();
    bad.groups_mut()[1].rigidity *= 2.0;
    bad.fur_mut().as_mut().unwrap().hairs = 3_900_000;
    kami::systems::validate(&bad).unwrap();
    assert!(
        s.apply(gpu, &bad).is_err(),
        "3.9 M fur hairs should be refused"
    );
    assert_eq!(kinds(&s), ["anjyo", "fur"]);
    assert_eq!(s.frame(), 2);
    assert_eq!(*s.scene(), scene);
    assert_eq!(vertices(gpu, &s), before, "the hair kept its pose");
    // And the stage still takes a good edit afterwards.
    let mut good = scene.clone();
    good.groups_mut()[1].rigidity *= 2.0;
    assert!(s.apply(gpu, &good).unwrap().restarted);
    assert_eq!(kinds(&s), ["anjyo", "fur"]);
}

/// One submission that keeps llvmpipe busy for longer than the 2.1 s that wgpu's GL backend
/// allows one fence wait: `Gpu::wait` must keep waiting, not report a timeout (the clean-clone
/// CI once failed a snapshot this way), and the work must be complete when it returns. It is
/// a draw, not a dispatch, because llvmpipe's GL runs compute at submit and defers drawing.
#[test]
fn wait_outlasts_one_fence_timeout() {
    let gpu = common::gpu();
    let rounds: u32 = std::env::var("KAMI_TEST_WAIT_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(16_000);
    assert!(
        rounds < 65_535,
        "KAMI_TEST_WAIT_ROUNDS: llvmpipe ends longer loops"
    );
    let src = "
        @group(0) @binding(0) var<uniform> rounds: vec4<u32>;
        @vertex
        fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
            let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
            return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
        }
        @fragment
        fn fs(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<u32> {
            var x = u32(pos.x) + u32(pos.y) * 256u + 1u;
            // llvmpipe ends a loop after 65,535 iterations in all (nested ones count
            // together), so each iteration takes eight steps (xorshift and a multiply,
            // which the compiler cannot fold into one).
            for (var r = 0u; r < rounds.x; r++) {
                STEPS
            }
            return vec4<u32>(x, 0u, 0u, 0u);
        }";
    let step = "x ^= x << 13u; x ^= x >> 17u; x ^= x << 5u; x = x * 747796405u + 2891336453u;\n";
    let src = src.replace("STEPS", &step.repeat(8));
    let module = kami::gpu::shader_module(&gpu.device, "busy", &src).unwrap();
    use wgpu::util::DeviceExt;
    let uni = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rounds"),
            contents: bytemuck::cast_slice(&[rounds, 0, 0, 0]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
    let side = 256u32;
    let format = wgpu::TextureFormat::R32Uint;
    let target = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("busy target"),
        size: wgpu::Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let pipe = gpu
        .device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("busy"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(format.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
    let bind =
        kami::gpu::bind::buffers(&gpu.device, "busy", &pipe.get_bind_group_layout(0), &[&uni]);
    let out = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("busy readback"),
        size: (side * side * 4) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let view = target.create_view(&Default::default());
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("busy"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            ..Default::default()
        });
        pass.set_pipeline(&pipe);
        pass.set_bind_group(0, &bind, &[]);
        pass.draw(0..3, 0..1);
    }
    let t = std::time::Instant::now();
    gpu.queue.submit([enc.finish()]);
    let submitted = t.elapsed().as_secs_f64();
    gpu.wait().unwrap();
    let waited = t.elapsed().as_secs_f64() - submitted;
    // Read back in a second submission (on GL the copy would draw inside the first submit).
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        target.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &out,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(side * 4),
                rows_per_image: None,
            },
        },
        target.size(),
    );
    gpu.queue.submit([enc.finish()]);
    let got: Vec<u32> = kami::gpu::map_read(gpu, &out).unwrap();
    // The same steps on the CPU, for a few pixels.
    for (px, py) in [(0u32, 0u32), (1, 0), (77, 130), (side - 1, side - 1)] {
        let mut x = px + py * side + 1;
        for _ in 0..rounds * 8 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x = x.wrapping_mul(747796405).wrapping_add(2891336453);
        }
        assert_eq!(got[(px + py * side) as usize], x, "pixel ({px}, {py})");
    }
    eprintln!(
        "{}: submit {submitted:.2} s, wait {waited:.2} s",
        gpu.describe()
    );
}

/// `kami render --set N:KEY=VALUE` (`render_animation_edited`): a wind set at frame 2 of the
/// gust acts from the next step on, as an edit in the viewer does (Anjyo re-simulates, no
/// restart): frames 0 to 2 are the unedited ones, frame 4 differs.
#[test]
fn an_edit_at_frame_n_acts_from_the_next_step() {
    let gpu = common::gpu();
    let scene = common::scene("gust");
    let (first, edits) =
        kami::app::params::scripted(scene.clone(), &[(2, "wind=0,0,900".to_string())]).unwrap();
    assert_eq!(first, scene);
    let size = (64, 64);
    let mut plain = Vec::new();
    kami::stage::render_animation(gpu, &scene, size, 0..=4, |_, img| {
        plain.push(img);
        Ok(())
    })
    .unwrap();
    let mut edited = Vec::new();
    kami::stage::render_animation_edited(gpu, &first, &edits, size, 0..=4, |_, img| {
        edited.push(img);
        Ok(())
    })
    .unwrap();
    for f in 0..=2 {
        assert!(
            plain[f] == edited[f],
            "frame {f} changed before the edit acted"
        );
    }
    assert!(
        plain[4] != edited[4],
        "the wind set at frame 2 changed nothing by frame 4"
    );
}

/// One world per scene (issue 35 item 1): a scene whose three moving kinds all read the EFF
/// and a mesh head's signed distance field uploads each once (the stage's
/// `systems::world::WorldGpu`), not once per kind or per kernel; frames upload neither; an
/// edit the world fits (the gust keys) rewrites it in place, and one it does not (the EFF
/// gone) makes one new world and builds every system again over it.
#[test]
fn the_world_is_uploaded_once_per_scene() {
    use kami::systems::world::uploads;
    let gpu = common::gpu();
    let mut scene = common::scene("strips_mesh_head");
    let anjyo = common::thinned("mesh_head", 16);
    *scene.groups_mut() = anjyo.groups().clone();
    *scene.dynamics_mut() = anjyo.dynamics().clone();
    *scene.wisps_mut() = common::scene("toon_mesh_head").wisps().clone();
    scene.forces.eff = common::scene("strips").forces.eff;
    let before = uploads();
    let mut s = stage(gpu, &scene);
    assert_eq!(kinds(&s), ["anjyo", "wisps", "strips"]);
    let (eff, sdf) = uploads();
    assert_eq!(
        (eff - before.0, sdf - before.1),
        (1, 1),
        "one EFF grid and one head field for the whole scene"
    );
    advance(gpu, &mut s, 2);
    assert_eq!(uploads(), (eff, sdf), "frames upload no grid");

    let mut gusty = scene.clone();
    if let Some(e) = gusty.forces.eff.as_mut() {
        e.gust.truncate(1);
    }
    s.apply(gpu, &gusty).unwrap();
    assert_eq!(
        uploads(),
        (eff, sdf),
        "an edit that fits rewrites the world"
    );

    let mut still = gusty.clone();
    still.forces.eff = None;
    let applied = s.apply(gpu, &still).unwrap();
    assert!(applied.restarted);
    assert!(applied.changes.iter().all(|(_, c)| *c == Change::Rebuild));
    assert_eq!(uploads(), (eff + 1, sdf + 1), "a new world, once");
    advance(gpu, &mut s, 1);
    gpu.take_error().unwrap();
}

/// What every kind reads per substep of the world (the keyed wind here) is the stage's
/// samples (`systems::world::WorldSteps`), not a copy of its own: a calm stage whose samples
/// are rewritten from a windy scene's forces after it records a frame, before the frame is
/// submitted, moves every kind (Anjyo's projective kernel, the wisps' springs, the strips)
/// exactly as the windy stage does.
#[test]
fn every_kind_reads_the_worlds_samples() {
    use kami::forces::Forces;
    use kami::scene::forces::WindKey;
    use kami::systems::strips::StripsSystem;
    use kami::systems::wisps::WispsSystem;
    let gpu = common::gpu();
    let mut calm = common::scene("strips_mesh_head");
    let anjyo = common::thinned("mesh_head", 16);
    *calm.groups_mut() = anjyo.groups().clone();
    *calm.dynamics_mut() = anjyo.dynamics().clone();
    *calm.wisps_mut() = common::scene("toon_mesh_head").wisps().clone();
    calm.forces.wind.clear();
    let mut windy = calm.clone();
    windy.forces.wind = vec![WindKey {
        frame: 0.0,
        force: [400.0, 0.0, 250.0],
        interp: Default::default(),
    }];
    let windy_forces = Forces::new(&windy.forces, &windy.head);
    let motion = |s: &Stage| {
        let a = s.system::<AnjyoSystem>().unwrap().hair.read_vertices(gpu);
        let w = s
            .system::<WispsSystem>()
            .unwrap()
            .springs()
            .unwrap()
            .read_positions(gpu);
        let st = s
            .system::<StripsSystem>()
            .unwrap()
            .dynamics
            .read_points(gpu);
        [
            ("anjyo", a.unwrap()),
            ("wisps", w.unwrap()),
            ("strips", st.unwrap()),
        ]
    };
    let frames = 2;
    let mut wind = stage(gpu, &windy);
    advance(gpu, &mut wind, 1);
    wind.reset(gpu).unwrap();
    let mut still = stage(gpu, &calm);
    let mut blown = stage(gpu, &calm);
    // A frame first, so the samples' buffer has grown to a frame's need (a growth while
    // recording would move later samples to a new buffer).
    advance(gpu, &mut blown, 1);
    blown.reset(gpu).unwrap();
    for _ in 0..frames {
        advance(gpu, &mut wind, 1);
        advance(gpu, &mut still, 1);
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        blown.advance(gpu, &mut enc, 1).unwrap();
        assert!(!blown.world().steps().times().is_empty());
        blown.world().steps().rewrite(gpu, &windy_forces);
        gpu.queue.submit([enc.finish()]);
    }
    let (want, calm_motion, got) = (motion(&wind), motion(&still), motion(&blown));
    let mut wrong = Vec::new();
    for (((kind, w), (_, c)), (_, g)) in want.iter().zip(&calm_motion).zip(&got) {
        let moved = w
            .iter()
            .zip(c)
            .any(|(a, b)| (0..3).any(|k| (a[k] - b[k]).abs() > 1e-3));
        assert!(moved, "{kind}: the wind should move it");
        if w != g {
            wrong.push(*kind);
        }
    }
    assert!(
        wrong.is_empty(),
        "these kinds did not move with the world's samples: {wrong:?}"
    );
    gpu.take_error().unwrap();
}
