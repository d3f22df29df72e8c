//! The physical shading mode's WGSL hair BSDF (`shaders/common/hair_bsdf.wgsl`) against its
//! f64 reference (`kami::systems::hair_bsdf`): a small compute entry point evaluates the dual
//! scattered radiance factor over a grid of directions, tangents, strand counts and
//! materials on the test adapter, and the worst element (relative to the larger of the
//! value and a floor of 2 % of its material's largest value) is bounded.

use crate::common;
use kami::systems::hair_bsdf::{
    dual_radiance, Angles, Bsdf, DualScattering, GpuHairBsdf, HairParams,
};

const ENTRY: &str = "
// Per element: tangent (xyz, w strand count n), view (xyz, w material), light.
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) { return; }
    let c = case_input(i);
    out[i] = vec4<f32>(hair_dual_radiance(mats[u32(c[1].w)], c[0].xyz, c[1].xyz, c[2].xyz, c[0].w), 0.0);
}";

/// What every contract's entry point reads and writes: the materials, its input (laid out
/// as the entry says) and one vec4 per element; `case_input` reads a case of
/// [`contract_input`].
const BINDINGS: &str = "
@group(0) @binding(0) var<storage, read> mats: array<HairBsdf>;
@group(0) @binding(1) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;
fn case_input(c: u32) -> array<vec4<f32>, 3> {
    return array<vec4<f32>, 3>(input[3u * c], input[3u * c + 1u], input[3u * c + 2u]);
}";

/// `entry` after the hair BSDF's WGSL and [`BINDINGS`], run over `n` elements with the
/// materials at binding 0 and `input` at binding 1.
fn run_bsdf_contract(
    gpu: &kami::gpu::Gpu,
    label: &str,
    entry: &str,
    mats: &[GpuHairBsdf],
    input: &[[f32; 4]],
    n: usize,
) -> Vec<[f32; 4]> {
    use kami::gpu::bind;
    common::run_contract(
        gpu,
        label,
        &format!("{}\n{BINDINGS}\n{entry}", kami::shaders::HAIR_BSDF),
        &[
            (bytemuck::cast_slice(mats), bind::storage::<GpuHairBsdf>()),
            (bytemuck::cast_slice(input), bind::storage::<[f32; 4]>()),
        ],
        n,
    )
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

/// One element of the BSDF contracts: material, tangent, view, light, strand count.
struct Case {
    m: usize,
    t: [f64; 3],
    v: [f64; 3],
    l: [f64; 3],
    n: f64,
}

/// The contracts' materials (f64 and GPU) and grid of directions, tangents and strand counts.
fn contract_grid() -> (Vec<(Bsdf, DualScattering)>, Vec<GpuHairBsdf>, Vec<Case>) {
    let params = [
        HairParams::default(),
        HairParams {
            eumelanin: 0.05,
            pheomelanin: 0.3,
            beta_m: 0.15,
            beta_n: 0.6,
            alpha: -3.0,
            eta: 1.4,
        },
        HairParams {
            eumelanin: 3.0,
            beta_m: 0.6,
            beta_n: 0.2,
            ..HairParams::default()
        },
    ];
    let refs: Vec<(Bsdf, DualScattering)> = params
        .iter()
        .map(|p| {
            let b = p.bsdf();
            (b, DualScattering::new(&b))
        })
        .collect();
    let mats: Vec<GpuHairBsdf> = params.iter().map(|p| GpuHairBsdf::new(p, true)).collect();
    let tangents = [
        [0.0, 1.0, 0.0],
        unit([0.3, -0.8, 0.5]),
        unit([1.0, 0.2, -0.1]),
    ];
    let mut dirs = Vec::new();
    for i in 0..7 {
        let th = -1.3 + 2.6 * i as f64 / 6.0;
        for j in 0..6 {
            let ph = std::f64::consts::PI * 2.0 * j as f64 / 6.0 + 0.1;
            dirs.push([th.cos() * ph.cos(), th.sin(), th.cos() * ph.sin()]);
        }
    }
    let mut cases = Vec::new();
    for m in 0..refs.len() {
        for t in tangents {
            for (k, v) in dirs.iter().enumerate() {
                for (q, l) in dirs.iter().enumerate() {
                    if (k + q) % 3 != 0 {
                        continue;
                    }
                    let n = [0.0, 0.5, 3.0][(k + 2 * q) % 3];
                    cases.push(Case {
                        m,
                        t,
                        v: *v,
                        l: *l,
                        n,
                    });
                }
            }
        }
    }
    (refs, mats, cases)
}

/// Each case as the entry points read it: tangent (w: n), view (w: material), light.
fn contract_input(cases: &[Case]) -> Vec<[f32; 4]> {
    let f = |x: f64| x as f32;
    cases
        .iter()
        .flat_map(|c| {
            [
                [f(c.t[0]), f(c.t[1]), f(c.t[2]), f(c.n)],
                [f(c.v[0]), f(c.v[1]), f(c.v[2]), c.m as f32],
                [f(c.l[0]), f(c.l[1]), f(c.l[2]), 0.0],
            ]
        })
        .collect()
}

/// The worst error of `got` against `want` (per element its material and value), relative
/// to the larger of the value and 2 % of its material's largest (`top`).
fn worst_relative(want: &[(usize, [f64; 3])], got: &[[f32; 4]], top: &[f64]) -> (f64, usize) {
    let mut worst = (0.0f64, 0);
    for (i, ((m, s), g)) in want.iter().zip(got).enumerate() {
        for c in 0..3 {
            let err = (g[c] as f64 - s[c]).abs() / s[c].max(0.02 * top[*m]);
            if err > worst.0 || !g[c].is_finite() {
                worst = (if g[c].is_finite() { err } else { f64::INFINITY }, i);
            }
        }
    }
    worst
}

/// Fails unless the worst error of `got` against `want` ([`worst_relative`]) is under
/// `bound`; `at` says what the worst element is (its case and part).
fn assert_contract(
    what: &str,
    want: &[(usize, [f64; 3])],
    got: &[[f32; 4]],
    top: &[f64],
    bound: f64,
    at: impl Fn(usize) -> String,
) {
    let (err, i) = worst_relative(want, got, top);
    eprintln!("{what}: worst relative error {err:.2e}");
    assert!(
        err < bound,
        "{what}: worst relative error {err} at element {i} of {} ({}): gpu {:?}, f64 {:?}",
        want.len(),
        at(i),
        got[i],
        want[i].1
    );
}

#[test]
fn wgsl_bsdf_matches_the_f64_reference() {
    let gpu = common::gpu();
    let (refs, mats, cases) = contract_grid();
    let mut top = vec![0.0f64; refs.len()];
    let want: Vec<(usize, [f64; 3])> = cases
        .iter()
        .map(|c| {
            let (b, d) = &refs[c.m];
            let s = dual_radiance(b, d, &Angles::new(c.v, c.l, c.t), c.n);
            top[c.m] = top[c.m].max(s[0]).max(s[1]).max(s[2]);
            (c.m, s)
        })
        .collect();
    let input = contract_input(&cases);
    let got = run_bsdf_contract(gpu, "hair bsdf contract", ENTRY, &mats, &input, want.len());
    assert_contract("hair BSDF", &want, &got, &top, 2e-3, |i| {
        format!("case {i}")
    });
}

const PARTS_ENTRY: &str = "
// Element i: part i % (HAIR_BINS + 1) of case i / (HAIR_BINS + 1): the bins, then the back.
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) { return; }
    let c = i / (HAIR_BINS + 1u);
    let part = i % (HAIR_BINS + 1u);
    let k = case_input(c);
    let d = hair_dual_parts(mats[u32(k[1].w)], k[0].xyz, k[1].xyz, k[2].xyz, k[0].w);
    var s = d.back;
    for (var k = 0u; k < HAIR_BINS; k++) {
        if k == part {
            s = d.single[k];
        }
    }
    out[i] = vec4<f32>(s, 0.0);
}";

/// The near field the ribbons shade with: each bin of the fibre's width, as the mean a
/// fragment shows (the bin over its weight), and the even backscattering, WGSL against f64,
/// bounded as the whole S is (relative to the larger of the value and 2 % of the material's
/// largest).
#[test]
fn wgsl_bins_of_the_fibres_width_match_the_f64_reference() {
    use kami::systems::hair_bsdf::{bin_weight, dual_parts, BINS};
    let gpu = common::gpu();
    let (refs, mats, cases) = contract_grid();
    let mut top = vec![0.0f64; refs.len()];
    let mut want: Vec<(usize, [f64; 3])> = Vec::new();
    for c in &cases {
        let (b, d) = &refs[c.m];
        let (bins, back) = dual_parts(b, d, &Angles::new(c.v, c.l, c.t), c.n);
        for (k, s) in bins.iter().enumerate() {
            let mean = s.map(|x| x / bin_weight(k));
            top[c.m] = top[c.m].max(mean[0]).max(mean[1]).max(mean[2]);
            want.push((c.m, mean));
        }
        want.push((c.m, back));
    }
    let input = contract_input(&cases);
    let mut got = run_bsdf_contract(
        gpu,
        "hair bins contract",
        PARTS_ENTRY,
        &mats,
        &input,
        want.len(),
    );
    for (i, g) in got.iter_mut().enumerate() {
        let part = i % (BINS + 1);
        if part < BINS {
            *g = g.map(|x| (x as f64 / bin_weight(part)) as f32);
        }
    }
    // Looser than the whole S's 2e-3: f32 rounding of the azimuthal CDF at a cell edge
    // moves light between the two cells beside it, which cancels in S (the differences
    // telescope) but not where a bin's edge falls between them. The worst element, on the
    // dark material's narrow lobes, is 4.3e-3 on lavapipe and 5.4e-3 on llvmpipe over GL,
    // at a bin about 2 % of the material's largest.
    assert_contract("hair BSDF bins", &want, &got, &top, 1e-2, |i| {
        format!("case {}, part {}", i / (BINS + 1), i % (BINS + 1))
    });
}

/// Three physical materials for the coat contracts: Mitsuba's default brown, a light
/// blond, and the shipped fur's red (pheomelanin 2.15).
fn coat_materials() -> Vec<GpuHairBsdf> {
    let params = [
        HairParams::default(),
        HairParams {
            eumelanin: 0.05,
            pheomelanin: 0.3,
            ..HairParams::default()
        },
        HairParams {
            eumelanin: 0.0,
            pheomelanin: 2.15,
            ..HairParams::default()
        },
    ];
    params.iter().map(|p| GpuHairBsdf::new(p, true)).collect()
}

/// A coat contract's entry point: per element, `SHARE(m, p.x)` (material m, area p.x) in rgb and
/// `OPEN(p.x)` (a share of the open sky: `hair_two_e3` or `hair_fibre_sky`) in w.
const COAT_ENTRY: &str = "
// Per element: x the fibre-area index, y the material.
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) { return; }
    let p = input[i];
    let m = mats[u32(p.y)];
    out[i] = vec4<f32>(SHARE(m, p.x), OPEN(p.x));
}";

/// The ambient's transmittance through a coat (`hair_ambient_through_af`, fur's skin
/// ambient) against its f64 reference (`hair_bsdf::ambient_transmittance`, exact
/// exponential integrals), over three materials and fibre-area indices from none to a
/// hundred: the worst error is bounded relative to the value or 1e-4 (the darkest
/// share that shows), and so is `hair_two_e3` against 2 E_3.
#[test]
fn wgsl_ambient_transmittance_matches_the_f64_reference() {
    use kami::systems::hair_bsdf::{ambient_transmittance, expint, AMBIENT_RADIANCE};
    let gpu = common::gpu();
    // The constant the varied ambient divides by is the reference's.
    assert!(
        kami::shaders::HAIR_BSDF.contains(&format!(
            "const HAIR_AMBIENT_RADIANCE: f32 = {AMBIENT_RADIANCE};"
        )),
        "HAIR_AMBIENT_RADIANCE in shaders/common/hair_bsdf.wgsl is not AMBIENT_RADIANCE"
    );
    let mats = coat_materials();
    let areas = [
        0.0, 1e-6, 1e-3, 0.02, 0.1, 0.3, 0.7, 0.99, 1.0, 1.01, 1.7, 3.0, 6.0, 12.0, 30.0, 100.0,
    ];
    let mut input: Vec<[f32; 4]> = Vec::new();
    let mut want = Vec::new();
    for (m, mat) in mats.iter().enumerate() {
        for a in areas {
            // The GPU reads its a_f in f32: the reference starts from the same numbers.
            let a_f = mat.a_f.map(f64::from);
            let t = ambient_transmittance([a_f[0], a_f[1], a_f[2]], a);
            assert!(
                t.iter().all(|x| (0.0..=1.0 + 1e-12).contains(x)),
                "{t:?} at {a}"
            );
            input.push([a as f32, m as f32, 0.0, 0.0]);
            want.push([t[0], t[1], t[2], 2.0 * expint(3, a)]);
        }
    }
    let got = run_bsdf_contract(
        gpu,
        "ambient transmittance contract",
        &COAT_ENTRY
            .replace("SHARE(m, p.x)", "hair_ambient_through_af(m.a_f.rgb, p.x)")
            .replace("OPEN(p.x)", "hair_two_e3(p.x)"),
        &mats,
        &input,
        want.len(),
    );
    check_coat_contract("ambient transmittance", &input, &got, &want);
}

/// The worst of a coat contract's elements (rgb and 2 E_3 in w) relative to the f64 value
/// or 1e-4 (the darkest share that shows) is under 1e-3; a non-finite one fails.
fn check_coat_contract(what: &str, input: &[[f32; 4]], got: &[[f32; 4]], want: &[[f64; 4]]) {
    let mut worst = (0.0f64, 0);
    for (i, (w, g)) in want.iter().zip(got).enumerate() {
        for c in 0..4 {
            let err = (g[c] as f64 - w[c]).abs() / w[c].max(1e-4);
            if err > worst.0 || !g[c].is_finite() {
                worst = (if g[c].is_finite() { err } else { f64::INFINITY }, i);
            }
        }
    }
    let (err, i) = worst;
    eprintln!("{what}: worst relative error {err:.2e}");
    assert!(
        err < 1e-3,
        "{what}: worst relative error {err} at element {i} (area {}): gpu {:?}, f64 {:?}",
        input[i][0],
        got[i],
        want[i]
    );
}

/// The share of the ambient colour under a coat (`hair_ambient_in_coat`: fur's physical
/// ambient, a fibre weighing the sky by its cross-section; the strips', a sheet weighing it
/// by irradiance) against its f64 reference (`hair_bsdf::ambient_in_coat`) over three
/// materials and fibre-area indices from none to a hundred, within 1e-3 relative (floor
/// 1e-4), and the share of the open sky (`hair_fibre_sky`, `hair_two_e3`) with it; the share
/// lies between the open sky's and the whole transmittance T(A), and the shader's
/// `HAIR_SKY_SEEN` is `SKY_SEEN`.
#[test]
fn wgsl_ambient_in_coat_matches_the_f64_reference() {
    use kami::systems::hair_bsdf::{ambient_in_coat, ambient_transmittance, SkyWeight, SKY_SEEN};
    let gpu = common::gpu();
    assert!(
        kami::shaders::HAIR_BSDF.contains(&format!("const HAIR_SKY_SEEN: f32 = {SKY_SEEN};")),
        "HAIR_SKY_SEEN in shaders/common/hair_bsdf.wgsl is not SKY_SEEN"
    );
    let mats = coat_materials();
    let areas = [
        0.0, 1e-6, 1e-3, 0.02, 0.1, 0.3, 0.99, 1.0, 1.7, 3.0, 6.0, 12.0, 30.0, 100.0,
    ];
    for (sky, open_wgsl) in [
        (SkyWeight::Fibre, "hair_fibre_sky(p.x)"),
        (SkyWeight::Sheet, "hair_two_e3(p.x)"),
    ] {
        let mut input: Vec<[f32; 4]> = Vec::new();
        let mut want = Vec::new();
        for (m, mat) in mats.iter().enumerate() {
            for a in areas {
                let a_f = mat.a_f.map(f64::from);
                let a_f = [a_f[0], a_f[1], a_f[2]];
                let s = ambient_in_coat(a_f, a, sky);
                let (t, open) = (ambient_transmittance(a_f, a), sky.open(a));
                for c in 0..3 {
                    assert!(
                        s[c] >= open - 1e-12 && s[c] <= t[c] + 1e-12,
                        "{sky:?}: share {} outside [{open}, {}] at {a}",
                        s[c],
                        t[c]
                    );
                }
                input.push([a as f32, m as f32, 0.0, 0.0]);
                want.push([s[0], s[1], s[2], open]);
            }
        }
        let shader = COAT_ENTRY
            .replace(
                "SHARE(m, p.x)",
                &format!("hair_ambient_in_coat(m, p.x, {open_wgsl})"),
            )
            .replace("OPEN(p.x)", open_wgsl);
        let what = format!("ambient in coat ({sky:?})");
        let got = run_bsdf_contract(gpu, &what, &shader, &mats, &input, want.len());
        check_coat_contract(&what, &input, &got, &want);
    }
}

/// A fibre's share of the open sky under a coat (`hair_bsdf::fibre_sky`, from the quartic
/// fit of its weight) against its definition by brute-force quadrature: e^(-A / mu) weighed
/// by the fibre's cross-section sqrt(1 - (w.t)^2) over the open hemisphere and the fibre's
/// azimuth, within 1e-3 relative (floor 1e-4) for A up to 6. It lies between E_2(A) (every
/// direction alike) and 2 E_3(A) (a surface's, by irradiance).
#[test]
fn the_fibre_sky_is_the_cross_section_weighted_sky() {
    use kami::systems::hair_bsdf::{expint, fibre_sky, fibre_sky_weight};
    let (nm, np) = (4000, 256);
    let weight = |mu: f64| {
        // sqrt(1 - (1 - mu^2) cos^2 phi) averaged over phi (midpoint rule; smooth, periodic).
        (0..np)
            .map(|j| {
                let c = (std::f64::consts::TAU * (j as f64 + 0.5) / np as f64).cos();
                (1.0 - (1.0 - mu * mu) * c * c).max(0.0).sqrt()
            })
            .sum::<f64>()
            / np as f64
    };
    let mus: Vec<(f64, f64)> = (0..nm)
        .map(|i| {
            let mu = (i as f64 + 0.5) / nm as f64;
            (mu, weight(mu))
        })
        .collect();
    let norm: f64 = mus.iter().map(|m| m.1).sum();
    for (mu, w) in mus.iter().step_by(97) {
        assert!(
            (fibre_sky_weight(*mu) - w).abs() < 1.5e-3,
            "weight at {mu}: {w}"
        );
    }
    let mut worst = 0.0f64;
    for a in [0.0, 1e-4, 1e-2, 0.1, 0.3, 0.7, 1.0, 2.0, 4.0, 6.0] {
        let brute = mus.iter().map(|(mu, w)| w * (-a / mu).exp()).sum::<f64>() / norm;
        let got = fibre_sky(a);
        let err = (got - brute).abs() / brute.max(1e-4);
        println!(
            "A = {a}: fibre_sky {got:.6}, quadrature {brute:.6}, E_2 {:.6}, 2 E_3 {:.6}",
            expint(2, a),
            2.0 * expint(3, a)
        );
        worst = worst.max(err);
        assert!(
            got >= expint(2, a) - 1e-12 && got <= 2.0 * expint(3, a) + 1e-12,
            "A = {a}: {got} outside [E_2, 2 E_3]"
        );
    }
    assert!(worst < 1e-3, "worst relative error {worst}");
}

/// The reference's closed form (exponential integrals) is the integral it stands for:
/// W(area / mu) averaged over the hemisphere with weight 2 mu, by brute-force quadrature;
/// it is 1 with no coat, falls as the coat thickens, and the channel a fibre absorbs most
/// (smallest a_f) falls first.
#[test]
fn ambient_transmittance_is_the_hemisphere_average_of_dual_scattering() {
    use kami::systems::hair_bsdf::{ambient_transmittance, expint, D_F};
    // E_1 against Abramowitz & Stegun's table 5.1, E_3 against E_1 through the recurrence
    // E_(n+1) = (e^-x - x E_n) / n.
    for (n, x, v) in [
        (1, 0.5, 0.559_773_594_8),
        (1, 2.0, 0.048_900_510_7),
        (3, 0.5, 0.221_604_364_3),
        (3, 2.0, 0.030_133_379_8),
    ] {
        assert!(
            (expint(n, x) - v).abs() < 1e-9,
            "E_{n}({x}) = {}",
            expint(n, x)
        );
    }
    let a_f = [0.405, 0.2, 0.074];
    let mut last = [1.0f64; 3];
    for area in [0.0, 0.05, 0.3, 1.0, 2.5, 8.0] {
        let t = ambient_transmittance(a_f, area);
        // Midpoint rule in mu on a fine grid (the integrand is smooth and bounded).
        let n = 200_000;
        let brute: [f64; 3] = std::array::from_fn(|c| {
            (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    let k = area / mu;
                    let direct = (-k).exp();
                    let w = direct + (1.0 - direct) * D_F * a_f[c].powf(k);
                    2.0 * mu * w / n as f64
                })
                .sum()
        });
        for c in 0..3 {
            assert!(
                (t[c] - brute[c]).abs() < 1e-6,
                "area {area} channel {c}: closed form {} against quadrature {}",
                t[c],
                brute[c]
            );
            assert!(t[c] <= last[c] + 1e-15, "not falling at {area}");
        }
        if area == 0.0 {
            assert!(t.iter().all(|x| (x - 1.0).abs() < 1e-12), "{t:?}");
        } else {
            assert!(t[2] < t[0], "blue should fall first: {t:?}");
        }
        last = t;
    }
    assert!(expint(3, 0.0) == 0.5);
}
