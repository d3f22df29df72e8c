// The physical shading mode's hair BSDF (docs/shading.md): Chiang et al. 2016 as Mitsuba 3's
// `hair` plugin has it, in the fixed-cost far-field form of `Bsdf::radiance_cells` and with
// the dual scattering of `hair_bsdf::dual_radiance` (src/systems/hair_bsdf.rs, the f64
// reference this must match; tests/it/hair_bsdf.rs bounds the difference). Evaluated per
// node, never per fragment; every loop has a constant bound.

// Twin of GpuHairBsdf (tests/it/gpu_twins.rs checks it) in src/systems/hair_bsdf.rs.
struct HairBsdf {
    // rgb sigma_a; w 1 to shade physically
    sigma_a: vec4<f32>,
    // longitudinal variances of R, TT, TRT, the rest
    v: vec4<f32>,
    // sin 2a, cos 2a, sin a, cos a
    tilt: vec4<f32>,
    // sin 4a, cos 4a, eta, logistic scale s
    misc: vec4<f32>,
    // rgb a_f; w beta_f^2
    a_f: vec4<f32>,
    // rgb d_b A_b; w Delta_b
    back: vec4<f32>,
    // rgb ambient colour; w sigma_b^2
    ambient: vec4<f32>,
}

const HAIR_PI: f32 = 3.14159265358979;
// Keep equal to AMBIENT_RADIANCE in src/systems/hair_bsdf.rs (tests/it/hair_bsdf.rs checks it):
// the ambient colour (HairBsdf.ambient) is this times the colour a dense volume sends back.
const HAIR_AMBIENT_RADIANCE: f32 = 0.3;
// hair_bsdf::SKY_SEEN: the share of a_b a fibre on the hair's surface gets from the open sky.
const HAIR_SKY_SEEN: f32 = 0.8183098861837907;
// Keep equal to CELLS in src/systems/hair_bsdf.rs.
const HAIR_CELLS: u32 = 12u;
// A cell's width in gamma. The cells' edges and middles are fixed, so their sines and
// cosines step by a rotation through it, (cos, sin) (a software rasteriser pays for every
// sin and cos).
const HAIR_CELL: f32 = HAIR_PI / f32(HAIR_CELLS);
const HAIR_CELL_TURN: vec2<f32> = vec2<f32>(cos(HAIR_CELL), sin(HAIR_CELL));
const HAIR_CELL_HALF_TURN: vec2<f32> = vec2<f32>(cos(0.5 * HAIR_CELL), sin(0.5 * HAIR_CELL));

// Whether this pipeline compiles the physical mode: false when no material of its pass
// shades physically (set when the pipeline is built, src/gpu/pipeline.rs `Variant::constants`).
// A constant, not only the per-material flag: a software rasteriser runs both sides of a
// branch, so the mode tested at run time alone cost every vertex the whole BSDF.
override HAIR_PHYSICAL: bool = true;

fn hair_physical(b: HairBsdf) -> bool {
    return HAIR_PHYSICAL && b.sigma_a.w > 0.5;
}

// ln I_0(x) for x >= 0 by Abramowitz & Stegun 9.8.1 (below 3.75) and 9.8.2 (above, in log
// form so it never overflows): relative error under 5e-7, far below f32's share of the
// contract's bound, at a fixed cost (the power series it replaced took 28 steps per call).
fn hair_log_i0(x: f32) -> f32 {
    if x < 3.75 {
        let t = x * x / 14.0625;
        return log(1.0 + t * (3.5156229 + t * (3.0899424 + t * (1.2067492 + t * (0.2659732
            + t * (0.0360768 + t * 0.0045813))))));
    }
    let u = 3.75 / x;
    let p = 0.39894228 + u * (0.01328592 + u * (0.00225319 + u * (-0.00157565 + u * (0.00916281
        + u * (-0.02057706 + u * (0.02635537 + u * (-0.01647633 + u * 0.00392377)))))));
    return x - 0.5 * log(x) + log(p);
}

fn hair_mp(sin_i: f32, cos_i: f32, sin_o: f32, cos_o: f32, v: f32) -> f32 {
    let k = 1.0 / v;
    let norm = log(k) - k - log(1.0 - exp(-2.0 * k));
    return exp(norm - sin_i * sin_o * k + hair_log_i0(cos_i * cos_o * k));
}

fn hair_fresnel(cos_i: f32, eta: f32) -> f32 {
    let c = clamp(cos_i, 0.0, 1.0);
    let s2 = (1.0 - c * c) / (eta * eta);
    if s2 >= 1.0 {
        return 1.0;
    }
    let ct = sqrt(1.0 - s2);
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}

fn hair_wrap(x: f32) -> f32 {
    return x - 2.0 * HAIR_PI * floor((x + HAIR_PI) / (2.0 * HAIR_PI));
}

fn hair_logistic(x: f32, s: f32) -> f32 {
    let e = exp(-abs(x) / s);
    return e / (s * (1.0 + e) * (1.0 + e));
}

fn hair_logistic_cdf(x: f32, s: f32) -> f32 {
    return 1.0 / (1.0 + exp(-x / s));
}

// The logistic of scale s trimmed to [-pi, pi] and normalised there: its CDF at -pi and
// the inverse of its mass on [-pi, pi], made once per evaluation rather than per call.
struct HairTrim {
    s: f32,
    lo: f32,
    inv_k: f32,
}

fn hair_trim(s: f32) -> HairTrim {
    let lo = hair_logistic_cdf(-HAIR_PI, s);
    return HairTrim(s, lo, 1.0 / (hair_logistic_cdf(HAIR_PI, s) - lo));
}

fn hair_np(x: f32, t: HairTrim) -> f32 {
    return hair_logistic(hair_wrap(x), t.s) * t.inv_k;
}

// The periodic integral of the normalised trimmed logistic from -pi to x.
fn hair_np_cdf(x: f32, t: HairTrim) -> f32 {
    let w = hair_wrap(x);
    let turns = round((x - w) / (2.0 * HAIR_PI));
    return turns + (hair_logistic_cdf(w, t.s) - t.lo) * t.inv_k;
}

// The fibre seen from the view at offset angle g (sin g given): azimuthal centres of R,
// TT, TRT.
fn hair_phis(g: f32, sin_g: f32, eta_p: f32) -> vec3<f32> {
    let gt = asin(clamp(sin_g / eta_p, -1.0, 1.0));
    return vec3<f32>(-2.0 * g, 2.0 * gt - 2.0 * g + HAIR_PI, 4.0 * gt - 2.0 * g + 2.0 * HAIR_PI);
}

// Angles of a direction pair about the fibre: x sin theta_v, y cos theta_v, z sin theta_l,
// w cos theta_l; and phi in [0, pi].
struct HairAngles {
    sc: vec4<f32>,
    phi: f32,
}

fn hair_angles(t: vec3<f32>, v: vec3<f32>, l: vec3<f32>) -> HairAngles {
    var a: HairAngles;
    let sv = clamp(dot(v, t), -1.0, 1.0);
    let sl = clamp(dot(l, t), -1.0, 1.0);
    a.sc = vec4<f32>(sv, sqrt(max(1.0 - sv * sv, 0.0)), sl, sqrt(max(1.0 - sl * sl, 0.0)));
    let pv = v - sv * t;
    let pl = l - sl * t;
    let n = sqrt(dot(pv, pv) * dot(pl, pl));
    let c = select(1.0, dot(pv, pl) / n, n > 1e-20);
    a.phi = acos(clamp(c, -1.0, 1.0));
    return a;
}

// Keep equal to BINS in src/systems/hair_bsdf.rs: the bins of the fibre's width that the
// near field is kept in, HAIR_CELLS / HAIR_BINS cells of gamma each.
const HAIR_BINS: u32 = 6u;

fn hair_bins_sum(s: array<vec3<f32>, HAIR_BINS>) -> vec3<f32> {
    return s[0] + s[1] + s[2] + s[3] + s[4] + s[5];
}

// A walk over the cells of gamma of `Bsdf::radiance_cells`, one cell per hair_cell_next:
// what the evaluation fixes, and what a cell hands the next (its far edge is the next one's
// near edge: its sine, azimuths and CDFs carry over). S and its bins are two walks.
struct HairCells {
    // The longitudinal terms R, TT, TRT and the rest, the view turned by the tilt.
    m: vec4<f32>,
    cos_v: f32,
    cos_t: f32,
    eta_p: f32,
    trim: HairTrim,
    // The near edge's gamma and (cos, sin), the middle's (cos, sin), the near edge's
    // azimuths and CDFs.
    g0: f32,
    e0: vec2<f32>,
    em: vec2<f32>,
    phi0: vec3<f32>,
    cdf0: vec3<f32>,
}

fn hair_cells_begin(b: HairBsdf, a: HairAngles, extra_var: f32) -> HairCells {
    var c: HairCells;
    let sin_v = a.sc.x;
    let cos_v = a.sc.y;
    let eta = b.misc.z;
    // Longitudinal terms, the view turned by the tilt: R -2a, TT +a, TRT +4a.
    c.m = vec4<f32>(
        hair_mp(sin_v * b.tilt.y - cos_v * b.tilt.x, abs(cos_v * b.tilt.y + sin_v * b.tilt.x),
            a.sc.z, a.sc.w, b.v.x + extra_var),
        hair_mp(sin_v * b.tilt.w + cos_v * b.tilt.z, abs(cos_v * b.tilt.w - sin_v * b.tilt.z),
            a.sc.z, a.sc.w, b.v.y + extra_var),
        hair_mp(sin_v * b.misc.y + cos_v * b.misc.x, abs(cos_v * b.misc.y - sin_v * b.misc.x),
            a.sc.z, a.sc.w, b.v.z + extra_var),
        hair_mp(sin_v, cos_v, a.sc.z, a.sc.w, b.v.w + extra_var));
    c.cos_v = cos_v;
    let sin_t = sin_v / eta;
    c.cos_t = sqrt(max(1.0 - sin_t * sin_t, 0.0));
    c.eta_p = sqrt(max(eta * eta - sin_v * sin_v, 0.0)) / max(cos_v, 1e-12);
    c.trim = hair_trim(b.misc.w);
    c.g0 = -0.5 * HAIR_PI;
    c.e0 = vec2<f32>(0.0, -1.0);
    c.em = vec2<f32>(HAIR_CELL_HALF_TURN.y, -HAIR_CELL_HALF_TURN.x);
    c.phi0 = hair_phis(c.g0, c.e0.y, c.eta_p);
    c.cdf0 = vec3<f32>(hair_np_cdf(a.phi - c.phi0.x, c.trim), hair_np_cdf(a.phi - c.phi0.y, c.trim),
        hair_np_cdf(a.phi - c.phi0.z, c.trim));
    return c;
}

// The next cell's share of S (weighed by its share of h), and the walk moved past it.
fn hair_cell_next(c: ptr<function, HairCells>, b: HairBsdf, a: HairAngles) -> vec3<f32> {
    let rot = HAIR_CELL_TURN;
    let eta = b.misc.z;
    let g1 = (*c).g0 + HAIR_CELL;
    let e0 = (*c).e0;
    let em = (*c).em;
    let phi0 = (*c).phi0;
    let e1 = vec2<f32>(e0.x * rot.x - e0.y * rot.y, e0.y * rot.x + e0.x * rot.y);
    let phi1 = hair_phis(g1, e1.y, (*c).eta_p);
    let trim = (*c).trim;
    let cdf1 = vec3<f32>(hair_np_cdf(a.phi - phi1.x, trim), hair_np_cdf(a.phi - phi1.y, trim),
        hair_np_cdf(a.phi - phi1.z, trim));
    let sin_gt = clamp(em.y / (*c).eta_p, -1.0, 1.0);
    let f = hair_fresnel((*c).cos_v * em.x, eta);
    let tr = exp(-b.sigma_a.rgb * (2.0 * sqrt(1.0 - sin_gt * sin_gt) / max((*c).cos_t, 1e-12)));
    let a1 = (1.0 - f) * (1.0 - f) * tr;
    let a2 = a1 * tr * f;
    let a3 = a2 * f * tr / (1.0 - tr * f);
    // R's centre moves by -2 HAIR_CELL across every cell, so its CDF difference never
    // degenerates; TT's and TRT's can (TRT at its caustic): there N_p at the cell's
    // middle, Phi_p linear across the cell as the CDF form takes it.
    let dphi = phi1 - phi0;
    var n = ((*c).cdf0 - cdf1) / select(vec3<f32>(1.0), dphi, abs(dphi) > vec3<f32>(1e-3));
    for (var p = 1u; p < 3u; p++) {
        if abs(dphi[p]) <= 1e-3 {
            n[p] = hair_np(a.phi - 0.5 * (phi0[p] + phi1[p]), trim);
        }
    }
    let w = 0.5 * (e1.y - e0.y);
    let m = (*c).m;
    (*c).g0 = g1;
    (*c).e0 = e1;
    (*c).em = vec2<f32>(em.x * rot.x - em.y * rot.y, em.y * rot.x + em.x * rot.y);
    (*c).phi0 = phi1;
    (*c).cdf0 = cdf1;
    return w * (vec3<f32>(m.x * f * n.x) + m.y * a1 * n.y + m.z * a2 * n.z
        + m.w * a3 / (2.0 * HAIR_PI));
}

// S of `Bsdf::radiance_cells`: the far-field radiance factor with the longitudinal variances
// widened by extra_var. Fur, the strips and the compute rasteriser's strands need no more.
fn hair_radiance_cells(b: HairBsdf, a: HairAngles, extra_var: f32) -> vec3<f32> {
    var c = hair_cells_begin(b, a, extra_var);
    var s = vec3<f32>(0.0);
    for (var i = 0u; i < HAIR_CELLS; i++) {
        s += hair_cell_next(&c, b, a);
    }
    return s;
}

// `Bsdf::radiance_bins`: S split by where on the fibre's width it leaves. Bin k holds the
// cells of gamma from -pi/2 + k pi/6 to -pi/2 + (k + 1) pi/6, each weighed by its share of
// h as in S (so the bins sum to S); gamma is measured so that the azimuth phi from the view
// to the light is positive (hair_angles).
fn hair_radiance_bins(b: HairBsdf, a: HairAngles, extra_var: f32) -> array<vec3<f32>, HAIR_BINS> {
    var c = hair_cells_begin(b, a, extra_var);
    var out: array<vec3<f32>, HAIR_BINS>;
    for (var k = 0u; k < HAIR_BINS; k++) {
        var s = vec3<f32>(0.0);
        for (var j = 0u; j < HAIR_CELLS / HAIR_BINS; j++) {
            s += hair_cell_next(&c, b, a);
        }
        out[k] = s;
    }
    return out;
}

// Dual scattering's weights at a node (`hair_bsdf::dual_parts`), all but S: W, the share
// of the key light that reaches the fibre directly or forward scattered through n fibres
// (shadow_strands), d_f a_f^n of it; the longitudinal spread n beta_f^2; and the local
// backscattering W d_b f_back, which leaves the fibre evenly.
struct HairDualWeights {
    a: HairAngles,
    spread: f32,
    w: vec3<f32>,
    back: vec3<f32>,
}

fn hair_dual_weights(b: HairBsdf, t: vec3<f32>, v: vec3<f32>, l: vec3<f32>, n_in: f32) -> HairDualWeights {
    var d: HairDualWeights;
    let n = max(n_in, 0.0);
    let a = hair_angles(t, v, l);
    d.a = a;
    d.spread = n * b.a_f.w;
    let theta_v = atan2(a.sc.x, a.sc.y);
    let theta_l = atan2(a.sc.z, a.sc.w);
    let th = 0.5 * (theta_v + theta_l) - b.back.w;
    let var_b = b.ambient.w + d.spread;
    let g = exp(-th * th / (2.0 * var_b)) / sqrt(2.0 * HAIR_PI * var_b);
    let cos_d = max(cos(0.5 * (theta_v - theta_l)), 0.2);
    // Zinke's f_back = 2 A_b g / (pi cos^2 theta_d), times cos theta_l (S's convention).
    let back = 2.0 * g * a.sc.w / (HAIR_PI * cos_d * cos_d);
    let direct = exp(-n);
    let through = (1.0 - direct) * 0.7 * exp(n * log(max(b.a_f.rgb, vec3<f32>(1e-6))));
    d.w = direct + through;
    // The forward-scattered light's backscattering counts pi times (Zinke's F^scatter).
    d.back = (direct + HAIR_PI * through) * b.back.rgb * back;
    return d;
}

// The physical mode's radiance factor of the key light at a node (`hair_bsdf::dual_radiance`):
// W S(v + 4 n beta_f^2) plus the backscattering.
fn hair_dual_radiance(b: HairBsdf, t: vec3<f32>, v: vec3<f32>, l: vec3<f32>, n_in: f32) -> vec3<f32> {
    let d = hair_dual_weights(b, t, v, l, n_in);
    return d.w * hair_radiance_cells(b, d.a, 4.0 * d.spread) + d.back;
}

// hair_dual_radiance in two parts (`hair_bsdf::dual_parts`), for the ribbons' near field:
// W S by bins of the fibre's width (hair_radiance_bins), and the backscattering.
struct HairDual {
    single: array<vec3<f32>, HAIR_BINS>,
    back: vec3<f32>,
}

fn hair_dual_parts(b: HairBsdf, t: vec3<f32>, v: vec3<f32>, l: vec3<f32>, n_in: f32) -> HairDual {
    let d = hair_dual_weights(b, t, v, l, n_in);
    let s = hair_radiance_bins(b, d.a, 4.0 * d.spread);
    var out: HairDual;
    for (var k = 0u; k < HAIR_BINS; k++) {
        out.single[k] = d.w * s[k];
    }
    out.back = d.back;
    return out;
}

// E_2(x), the exponential integral (E_1 by Abramowitz & Stegun 5.1.53 below 1 and 5.1.56
// above, E_2 written as a multiple of e^-x so nothing cancels); 1 at 0, 0 past 60.
fn hair_e2(x_in: f32) -> f32 {
    let x = max(x_in, 0.0);
    if x > 60.0 {
        return 0.0;
    }
    if x < 1e-8 {
        return 1.0;
    }
    let ex = exp(-x);
    // r = x e^x E_1(x)
    var r: f32;
    if x < 1.0 {
        let e1 = -log(x) - 0.57721566 + x * (0.99999193 + x * (-0.24991055 + x * (0.05519968
            + x * (-0.00976004 + x * 0.00107857))));
        r = x * e1 / ex;
    } else {
        let num = 0.2677737343 + x * (8.6347608925 + x * (18.0590169730 + x * (8.5733287401 + x)));
        let den = 3.9584969228 + x * (21.0996530827 + x * (25.6329561486 + x * (9.5733223454 + x)));
        r = num / den;
    }
    return ex * (1.0 - r);
}

// 2 E_3(x), the share of even light through a slab of optical depth x, weighed by
// irradiance (E_3 = (e^-x - x E_2) / 2).
fn hair_two_e3(x_in: f32) -> f32 {
    let x = max(x_in, 0.0);
    if x > 60.0 {
        return 0.0;
    }
    return exp(-x) - x * hair_e2(x);
}

// The share of the open sky's light a fibre lying across its coat's normal gets past a coat
// of fibre-area index x unscattered (hair_bsdf::fibre_sky, its f64 reference): e^(-x / mu)
// weighed by the fibre's cross-section towards each direction (FIBRE_SKY_WEIGHT, a quartic
// in mu), sum_k c_k E_(k+2)(x) / sum_k c_k / (k + 1), the E_n by their recurrence
// E_(n+1) = (e^-x - x E_n) / n.
fn hair_fibre_sky(x_in: f32) -> f32 {
    let x = max(x_in, 0.0);
    if x > 60.0 {
        return 0.0;
    }
    let ex = exp(-x);
    let e2 = hair_e2(x);
    let e3 = (ex - x * e2) / 2.0;
    let e4 = (ex - x * e3) / 3.0;
    let e5 = (ex - x * e4) / 4.0;
    let e6 = (ex - x * e5) / 5.0;
    return (0.63530033 * e2 + 0.062738523 * e3 + 0.60936659 * e4 - 0.46037703 * e5
        + 0.15350340 * e6) / 0.78539821;
}

// The share of Kami's even ambient light that reaches a fibre of forward scattering
// attenuation a_f (rgb) under a coat of fibre-area index `area`
// (hair_bsdf::ambient_transmittance, its f64 reference): dual scattering's forward
// transmittance averaged over the open hemisphere.
fn hair_ambient_through_af(a_f: vec3<f32>, area: f32) -> vec3<f32> {
    let a = max(area, 0.0);
    if a <= 0.0 {
        return vec3<f32>(1.0);
    }
    return vec3<f32>(hair_two_e3(a)) + hair_scattered_through(a_f, a);
}

// The forward-scattered part of hair_ambient_through_af: d_f (2 E_3(k A) - 2 E_3((1 + k) A)),
// k = -ln a_f (0 at A = 0).
fn hair_scattered_through(a_f: vec3<f32>, a: f32) -> vec3<f32> {
    let k = -log(max(a_f, vec3<f32>(1e-6)));
    return 0.7 * (vec3<f32>(hair_two_e3(k.x * a), hair_two_e3(k.y * a), hair_two_e3(k.z * a))
        - vec3<f32>(hair_two_e3((1.0 + k.x) * a), hair_two_e3((1.0 + k.y) * a), hair_two_e3((1.0 + k.z) * a)));
}

// The share of a fibre's ambient colour that reaches it under a coat of fibre-area index
// `area` (hair_bsdf::ambient_in_coat, its f64 reference): the sky's single backscattering
// past the fibres above unscattered, `open` (as the fibre weighs the sky: hair_fibre_sky for
// fur, hair_two_e3 for a strip's sheet; hair_bsdf::SkyWeight), the volume's multiple
// backscattering fed by all that comes through the coat's top (hair_ambient_through_af, by
// irradiance); a_f alone splits the colour.
fn hair_ambient_in_coat(b: HairBsdf, area: f32, open: f32) -> vec3<f32> {
    let a = max(area, 0.0);
    let af = b.a_f.rgb;
    let t = vec3<f32>(hair_two_e3(a)) + hair_scattered_through(af, a);
    let m = af / max(vec3<f32>(1.0) - af * af, vec3<f32>(1e-6));
    return (HAIR_SKY_SEEN * open + m * t) / (HAIR_SKY_SEEN + m);
}
