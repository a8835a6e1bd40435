//! `veach bench`: error against run time for every strategy on a scene.
//!
//! For each strategy and each budget of a doubling series (camera samples per pixel, or seconds)
//! and several seeds: render, time the render alone (GPU timestamps where the adapter has them,
//! else wall clock around submit and wait; kernel creation and uploads excluded), and measure
//! RMSE, relMSE and MAE against a reference. The report adds the equal-time comparison, the
//! time each strategy needs to reach a target error and the fitted convergence slope.

use std::time::Duration;
use veach::error::{Error, Result};
use veach::output::RenderOutput;
use veach::render::{GpuScene, Renderer};
use veach::scene::Camera;
use veach::settings::{Heuristic, LightSampling, LightSelection, RenderSettings, Sampler, Strategy};

/// Bench renders leave out emitters seen directly: every strategy sees them through the same
/// camera samples, so they add only pixel-coverage noise at their edges, the same for all.
///
/// ε in relMSE = mean (x − r)² / (r² + ε): keeps near-black reference pixels from dominating
/// (the same regulariser as Rousselle et al., "Adaptive Sampling and Reconstruction using
/// Greedy Error Minimization", 2011).
pub const RELMSE_EPSILON: f64 = 1e-2;

/// One strategy as the bench runs it: a few samples per camera sample, so that every strategy
/// traces about the same number of rays per camera sample (one light chosen per light sample).
#[derive(Clone, Debug)]
pub struct BenchStrategy {
    pub name: String,
    pub strategy: Strategy,
    pub light_samples: u32,
    pub brdf_samples: u32,
    pub heuristic: Heuristic,
    pub light_selection: LightSelection,
    pub light_sampling: LightSampling,
    pub sampler: Sampler,
    /// The unshadowed diffuse light as a control variate (`RenderSettings::control_variate`).
    pub control_variate: bool,
}

/// The strategies `veach bench` runs unless told otherwise.
pub fn default_strategies() -> Vec<BenchStrategy> {
    let all = strategy_catalogue();
    ["uniform", "brdf", "light", "mis-balance", "mis-power", "mis-lobes"]
        .iter()
        .filter_map(|n| all.iter().find(|s| s.name == *n).cloned())
        .collect()
}

/// Every strategy `--strategies` can name: the defaults, the light-sampling ones again with
/// solid-angle sampling of emitter triangles (suffix `-solid-angle`) and with round lights sampled
/// by their bounding cones (suffix `-cone`), the defaults but mis-lobes with the unshadowed light
/// as a control variate (suffix `-cv`), and each of those with independent random numbers instead
/// of Sobol points (suffix `-independent`).
pub fn strategy_catalogue() -> Vec<BenchStrategy> {
    let mut all = area_strategies();
    let controlled: Vec<BenchStrategy> = all
        .iter()
        .filter(|s| s.strategy != Strategy::MisLobes)
        .map(|s| BenchStrategy { name: format!("{}-cv", s.name), control_variate: true, ..s.clone() })
        .collect();
    let by = |suffix: &str, light_sampling: LightSampling, all: &[BenchStrategy]| -> Vec<BenchStrategy> {
        all.iter()
            .filter(|s| s.strategy.samples_lights())
            .map(|s| BenchStrategy { name: format!("{}-{suffix}", s.name), light_sampling, ..s.clone() })
            .collect()
    };
    let solid = by("solid-angle", LightSampling::SolidAngle, &all);
    let cone = by("cone", LightSampling::Cone, &all);
    all.extend(solid);
    all.extend(cone);
    all.extend(controlled);
    let independent: Vec<BenchStrategy> = all
        .iter()
        .map(|s| BenchStrategy { name: format!("{}-independent", s.name), sampler: Sampler::Independent, ..s.clone() })
        .collect();
    all.extend(independent);
    all
}

/// Strategies by name (comma-separated), from `strategy_catalogue`.
pub fn strategies_by_name(names: &str) -> std::result::Result<Vec<BenchStrategy>, String> {
    let all = strategy_catalogue();
    names
        .split(',')
        .map(|n| n.trim())
        .filter(|n| !n.is_empty())
        .map(|n| {
            all.iter().find(|s| s.name == n).cloned().ok_or_else(|| {
                let known: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
                format!("unknown bench strategy '{n}' (known: {})", known.join(", "))
            })
        })
        .collect()
}

fn area_strategies() -> Vec<BenchStrategy> {
    let s = |name: &str, strategy, light_samples, brdf_samples, heuristic| BenchStrategy {
        name: name.into(),
        strategy,
        light_samples,
        brdf_samples,
        heuristic,
        light_selection: LightSelection::Power,
        light_sampling: LightSampling::Area,
        sampler: Sampler::Sobol,
        control_variate: false,
    };
    vec![
        s("uniform", Strategy::Uniform, 0, 2, Heuristic::Balance),
        s("brdf", Strategy::Brdf, 0, 2, Heuristic::Balance),
        s("light", Strategy::Light, 2, 0, Heuristic::Balance),
        s("mis-balance", Strategy::Mis, 1, 1, Heuristic::Balance),
        s("mis-power", Strategy::Mis, 1, 1, Heuristic::Power),
        s("mis-lobes", Strategy::MisLobes, 1, 1, Heuristic::Balance),
    ]
}

#[derive(Clone, Copy, Debug, Default)]
pub struct ErrorMetrics {
    pub rmse: f64,
    pub relmse: f64,
    pub mae: f64,
}

/// Errors of `image` against `reference`, over all pixels and colour channels.
pub fn error_metrics(image: &[[f32; 3]], reference: &[[f32; 3]]) -> ErrorMetrics {
    let (mut se, mut rel, mut ae) = (0.0, 0.0, 0.0);
    for (x, r) in image.iter().zip(reference) {
        for c in 0..3 {
            let (x, r) = (x[c] as f64, r[c] as f64);
            let d = x - r;
            se += d * d;
            rel += d * d / (r * r + RELMSE_EPSILON);
            ae += d.abs();
        }
    }
    let n = (image.len() * 3).max(1) as f64;
    ErrorMetrics { rmse: (se / n).sqrt(), relmse: rel / n, mae: ae / n }
}

#[derive(Clone)]
pub struct Reference {
    pub pixels: Vec<[f32; 3]>,
    /// How it was made: a file, or "MIS at N spp".
    pub source: String,
    /// Whether it leaves out emitters seen directly; the images measured against it are rendered
    /// the same way (an outside renderer's reference shows them).
    pub hides_emitters: bool,
    /// The reference's own expected relMSE, from the spread between its replicates (0 for a
    /// given file).
    pub own_relmse: f64,
}

/// The reference's settings: MIS with the balance heuristic, every light sampled, 4 + 4 samples
/// per camera sample, emitters seen directly left out (callers choose: `render_reference`).
pub fn reference_settings(width: u32, height: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width,
        height,
        spp,
        strategy: Strategy::Mis,
        light_samples: 4,
        brdf_samples: 4,
        heuristic: Heuristic::Balance,
        light_selection: LightSelection::Each,
        seed: 0x5eed,
        hide_emitters: true,
        ..Default::default()
    }
}

/// The rendered reference samples every light up to this many lights.
pub const MAX_LIGHTS_SAMPLED_EACH: u32 = 32;

/// The rendered reference is the mean of this many renders with independent scrambles (seeds).
/// A Sobol render's per-pixel sample variance does not measure its error (it over-estimates it
/// wherever stratification helps), so the reference's own error is estimated the way randomised
/// QMC's is, from the spread between replicates (Owen 1997; L'Ecuyer & Lemieux 2002).
pub const REFERENCE_REPLICATES: u32 = 4;

/// Renders the reference: MIS with the balance heuristic, every light sampled, 4 + 4 samples
/// per camera sample, `spp` in all over REFERENCE_REPLICATES scrambles.
#[allow(clippy::too_many_arguments)]
pub fn render_reference(
    renderer: &Renderer,
    scene: &GpuScene,
    camera: &Camera,
    width: u32,
    height: u32,
    spp: u32,
    hide_emitters: bool,
    progress: &mut dyn FnMut(f64) -> bool,
) -> Result<Reference> {
    let mut settings = RenderSettings { hide_emitters, ..reference_settings(width, height, spp) };
    // Every light's own samples cost rays in proportion to the light count: past a few dozen
    // lights, one light chosen by power per light sample (16 of them) reaches a lower error.
    let by_power = scene.light_count() > MAX_LIGHTS_SAMPLED_EACH;
    if by_power {
        settings.light_selection = LightSelection::Power;
        settings.light_samples = 16;
    }
    settings.spp = spp.div_ceil(REFERENCE_REPLICATES).max(1);
    let first_seed = settings.seed;
    let mut replicates = Vec::new();
    for r in 0..REFERENCE_REPLICATES {
        settings.seed = first_seed + r;
        let done = r as f64 / REFERENCE_REPLICATES as f64;
        let out = renderer
            .render(scene, &settings, camera, &mut |p| progress(done + p.fraction / REFERENCE_REPLICATES as f64))?;
        if out.interrupted {
            return Err(Error::Options("the reference render was interrupted".into()));
        }
        replicates.push(out.mean());
    }
    let (pixels, own_relmse) = replicate_mean(&replicates);
    let source = if by_power {
        format!("MIS 16+4, lights by power, {spp} spp")
    } else {
        format!("MIS 4+4, every light, {spp} spp")
    };
    Ok(Reference { pixels, source, own_relmse, hides_emitters: hide_emitters })
}

/// The mean of R ≥ 2 independently randomised images, and its expected relMSE against the
/// truth: per pixel and channel, the variance between the images over R (the variance of their
/// mean), relative as in `error_metrics`.
pub fn replicate_mean(images: &[Vec<[f32; 3]>]) -> (Vec<[f32; 3]>, f64) {
    let r = images.len() as f64;
    let len = images.first().map_or(0, |i| i.len());
    let mut mean = vec![[0.0f32; 3]; len];
    let mut sum = 0.0;
    for (p, m) in mean.iter_mut().enumerate() {
        for c in 0..3 {
            let mu = images.iter().map(|i| i[p][c] as f64).sum::<f64>() / r;
            let var = images.iter().map(|i| (i[p][c] as f64 - mu).powi(2)).sum::<f64>() / (r - 1.0).max(1.0);
            m[c] = mu as f32;
            sum += var / r / (mu * mu + RELMSE_EPSILON);
        }
    }
    (mean, sum / (len * 3).max(1) as f64)
}

#[derive(Clone, Debug)]
pub enum Budget {
    Spp(u32),
    Seconds(f64),
}

#[derive(Clone, Debug)]
pub struct BenchRow {
    pub scene: String,
    pub strategy: String,
    pub budget: String,
    /// Mean camera samples per pixel reached.
    pub spp: f64,
    pub seconds: f64,
    pub metrics: ErrorMetrics,
    pub seed: u32,
    /// Largest channel value of the image (a firefly shows here first).
    pub max_value: f32,
    /// Non-finite samples the kernel dropped.
    pub nonfinite: u64,
    /// Rays the kernel traced: camera, shadow and BRDF (or uniform) rays.
    pub rays: u64,
}

impl BenchRow {
    /// Rays traced per second of render time.
    pub fn rays_per_second(&self) -> f64 {
        if self.seconds > 0.0 { self.rays as f64 / self.seconds } else { 0.0 }
    }

    /// 1 / (relMSE × seconds): higher is better; constant for a finite-variance estimator.
    pub fn efficiency(&self) -> f64 {
        1.0 / (self.metrics.relmse * self.seconds).max(f64::MIN_POSITIVE)
    }
}

pub fn render_settings(
    s: &BenchStrategy,
    width: u32,
    height: u32,
    budget: &Budget,
    seed: u32,
    hide_emitters: bool,
) -> RenderSettings {
    let (spp, time_limit) = match *budget {
        Budget::Spp(n) => (n, None),
        Budget::Seconds(t) => (u32::MAX, Some(Duration::from_secs_f64(t))),
    };
    RenderSettings {
        width,
        height,
        spp,
        strategy: s.strategy,
        light_samples: s.light_samples,
        brdf_samples: s.brdf_samples,
        heuristic: s.heuristic,
        light_selection: s.light_selection,
        light_sampling: s.light_sampling,
        sampler: s.sampler,
        control_variate: s.control_variate,
        seed,
        time_limit,
        // Short dispatches keep a time budget from overshooting.
        dispatch_target: match budget {
            Budget::Seconds(t) => Duration::from_secs_f64((t / 20.0).clamp(0.002, 0.15)),
            Budget::Spp(_) => RenderSettings::default().dispatch_target,
        },
        hide_emitters,
        ..Default::default()
    }
}

/// Render time of a bench render: GPU timestamps where there are any, else wall clock.
pub fn render_seconds(out: &RenderOutput) -> f64 {
    out.gpu_time.unwrap_or(out.render_time).as_secs_f64()
}

/// Renders one point of the sweep and measures it.
#[allow(clippy::too_many_arguments)]
pub fn measure(
    renderer: &Renderer,
    scene: &GpuScene,
    camera: &Camera,
    scene_name: &str,
    reference: &Reference,
    strategy: &BenchStrategy,
    budget: &Budget,
    seed: u32,
    width: u32,
    height: u32,
) -> Result<(BenchRow, RenderOutput)> {
    let settings = render_settings(strategy, width, height, budget, seed, reference.hides_emitters);
    let out = renderer.render(scene, &settings, camera, &mut |_| true)?;
    let metrics = error_metrics(&out.mean(), &reference.pixels);
    let row = BenchRow {
        scene: scene_name.into(),
        strategy: strategy.name.clone(),
        budget: match budget {
            Budget::Spp(n) => format!("{n}spp"),
            Budget::Seconds(t) => format!("{t}s"),
        },
        spp: out.mean_samples(),
        seconds: render_seconds(&out),
        metrics,
        seed,
        max_value: out.mean().iter().flatten().fold(0.0f32, |m, &v| m.max(v)),
        nonfinite: out.nonfinite_samples,
        rays: out.rays,
    };
    Ok((row, out))
}

/// Median, minimum and maximum.
pub fn median_spread(values: &mut [f64]) -> (f64, f64, f64) {
    values.sort_by(|a, b| a.total_cmp(b));
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let median = if n % 2 == 1 { values[n / 2] } else { 0.5 * (values[n / 2 - 1] + values[n / 2]) };
    (median, values[0], values[n - 1])
}

/// One strategy's curve: per budget, the median seconds and the median, min and max relMSE.
#[derive(Clone, Debug)]
pub struct Curve {
    pub strategy: String,
    pub points: Vec<CurvePoint>,
}

#[derive(Clone, Copy, Debug)]
pub struct CurvePoint {
    pub seconds: f64,
    pub relmse: f64,
    pub relmse_min: f64,
    pub relmse_max: f64,
    pub spp: f64,
}

pub fn curves(rows: &[BenchRow]) -> Vec<Curve> {
    let mut out: Vec<Curve> = Vec::new();
    for row in rows {
        if !out.iter().any(|c| c.strategy == row.strategy) {
            out.push(Curve { strategy: row.strategy.clone(), points: Vec::new() });
        }
    }
    for curve in &mut out {
        let mut budgets: Vec<&str> = Vec::new();
        for r in rows.iter().filter(|r| r.strategy == curve.strategy) {
            if !budgets.contains(&r.budget.as_str()) {
                budgets.push(&r.budget);
            }
        }
        for b in budgets {
            let sel: Vec<&BenchRow> = rows.iter().filter(|r| r.strategy == curve.strategy && r.budget == b).collect();
            let (seconds, _, _) = median_spread(&mut sel.iter().map(|r| r.seconds).collect::<Vec<_>>());
            let (spp, _, _) = median_spread(&mut sel.iter().map(|r| r.spp).collect::<Vec<_>>());
            let (relmse, lo, hi) = median_spread(&mut sel.iter().map(|r| r.metrics.relmse).collect::<Vec<_>>());
            curve.points.push(CurvePoint { seconds, relmse, relmse_min: lo, relmse_max: hi, spp });
        }
    }
    out
}

/// Least-squares line log relMSE = a + b log seconds over a curve's points: (a, b).
/// A finite-variance estimator has slope b ≈ −1 where render time grows with the samples.
pub fn fit_convergence(curve: &Curve) -> Option<(f64, f64)> {
    fit_log_log(curve.points.iter().map(|p| (p.seconds, p.relmse)))
}

/// Least-squares line log relMSE = a + b log spp (camera samples per pixel): (a, b). The
/// variance of a finite-variance estimator falls as 1 / samples, b ≈ −1, whatever fixed costs
/// do to the render time (on a small image they dominate it).
pub fn fit_sample_convergence(curve: &Curve) -> Option<(f64, f64)> {
    fit_log_log(curve.points.iter().map(|p| (p.spp, p.relmse)))
}

fn fit_log_log(points: impl Iterator<Item = (f64, f64)>) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = points.filter(|&(x, y)| x > 0.0 && y > 0.0).map(|(x, y)| (x.ln(), y.ln())).collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

/// A slope this much shallower than −1 is reported as a sign of infinite variance.
pub const SHALLOW_SLOPE: f64 = -0.8;

/// What a convergence curve says about its estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Convergence {
    /// Slope about −1 (or too few points to tell).
    Finite,
    /// The error levels off at about `floor` relMSE: the images converge to something other
    /// than the reference (a bias, or a reference that shows something else), not a variance
    /// problem.
    BiasFloor { floor: f64 },
    /// A straight but shallow line in log-log: heavy tails, a sign of infinite variance.
    HeavyTails { slope: f64 },
}

/// Tells a bias floor from heavy tails, against camera samples per pixel n. A floor, relMSE =
/// B + V / n, bends in log-log: its slope goes from about −1 towards 0 as V / n falls below B,
/// and is flat where B dominates from the start. Heavy tails, relMSE ∝ n^−b with 0 < b < 1
/// (about 1/2 for the usual infinite-variance estimators), keep one slope. So a shallow curve
/// (`fit_sample_convergence`) whose least-squares floor B (fitted on 1 / n)
/// holds at least half of its last error, and which either bends (its later half at least `BEND`
/// flatter than its earlier half) or is flat (slope above `FLAT`), is a floor; any other shallow
/// curve has heavy tails.
pub fn diagnose_convergence(curve: &Curve) -> Convergence {
    const BEND: f64 = 0.25;
    const FLAT: f64 = -0.25;
    let Some((_, slope)) = fit_sample_convergence(curve) else { return Convergence::Finite };
    if slope <= SHALLOW_SLOPE {
        return Convergence::Finite;
    }
    let mut points: Vec<CurvePoint> = curve.points.iter().copied().filter(|p| p.spp > 0.0 && p.relmse > 0.0).collect();
    points.sort_by(|a, b| a.spp.total_cmp(&b.spp));
    let half =
        |range: &[CurvePoint]| fit_sample_convergence(&Curve { strategy: String::new(), points: range.to_vec() });
    let n = points.len();
    let bends = n >= 4
        && matches!(
            (half(&points[..n.div_ceil(2)]), half(&points[n / 2..])),
            (Some((_, early)), Some((_, late))) if late - early >= BEND
        );
    // relMSE = B + V x with x = 1 / n, by least squares.
    let xs: Vec<f64> = points.iter().map(|p| 1.0 / p.spp).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / n as f64, points.iter().map(|p| p.relmse).sum::<f64>() / n as f64);
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    let sxy: f64 = xs.iter().zip(&points).map(|(x, p)| (x - mx) * (p.relmse - my)).sum();
    let v = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let floor = my - v * mx;
    let last = points.last().map_or(0.0, |p| p.relmse);
    if (bends || slope > FLAT) && v >= 0.0 && floor >= 0.5 * last {
        Convergence::BiasFloor { floor }
    } else {
        Convergence::HeavyTails { slope }
    }
}

/// Seconds a strategy needs to reach `target` relMSE on its fitted line, and whether that lies
/// outside the measured range (an extrapolation).
pub fn time_to_reach(curve: &Curve, target: f64) -> Option<(f64, bool)> {
    let (a, b) = fit_convergence(curve)?;
    if b >= 0.0 {
        return None;
    }
    let t = ((target.ln() - a) / b).exp();
    let (lo, hi) = curve.points.iter().fold((f64::INFINITY, 0.0f64), |(l, h), p| (l.min(p.seconds), h.max(p.seconds)));
    Some((t, t < lo || t > hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strategy_names_compose_their_suffixes() {
        let s = strategies_by_name("mis-power-cv, light-solid-angle-independent, brdf-cv-independent").unwrap();
        assert!(s[0].control_variate && s[0].strategy == Strategy::Mis && s[0].heuristic == Heuristic::Power);
        assert!(!s[1].control_variate && s[1].light_sampling == LightSampling::SolidAngle);
        assert_eq!(s[1].sampler, Sampler::Independent);
        assert!(s[2].control_variate && s[2].sampler == Sampler::Independent);
        // mis-lobes does not take the control variate (crate::control_variate::check).
        let unknown = strategies_by_name("mis-lobes-cv").unwrap_err();
        assert!(unknown.contains("unknown bench strategy 'mis-lobes-cv'"), "{unknown}");
    }

    fn curve_of(relmse: impl Fn(f64) -> f64) -> Curve {
        let points = [0.01, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64].map(|t| CurvePoint {
            seconds: t,
            relmse: relmse(t),
            relmse_min: 0.0,
            relmse_max: 0.0,
            spp: 100.0 * t,
        });
        Curve { strategy: "test".into(), points: points.to_vec() }
    }

    #[test]
    fn convergence_tells_a_bias_floor_from_heavy_tails() {
        assert_eq!(diagnose_convergence(&curve_of(|t| 1e-3 / t)), Convergence::Finite);
        // relMSE ∝ t^-0.5 (heavy tails, the shape of an infinite-variance estimator): one slope.
        let tails = diagnose_convergence(&curve_of(|t| 1e-2 * t.powf(-0.5)));
        assert!(matches!(tails, Convergence::HeavyTails { slope } if (slope + 0.5).abs() < 1e-9), "{tails:?}");
        // A floor of 0.05 under a 1 / t fall (a reference that shows emitters the images leave out).
        let floor = diagnose_convergence(&curve_of(|t| 0.05 + 2e-3 / t));
        assert!(matches!(floor, Convergence::BiasFloor { floor } if (floor - 0.05).abs() < 1e-6), "{floor:?}");
        // A floor that dominates from the first point: a flat line.
        let flat = diagnose_convergence(&curve_of(|t| 0.9 + 1e-4 / t));
        assert!(matches!(flat, Convergence::BiasFloor { floor } if (floor - 0.9).abs() < 1e-6), "{flat:?}");
        // A floor the curve never comes near is not yet one: the fall dominates throughout.
        assert_eq!(diagnose_convergence(&curve_of(|t| 1e-6 + 1e-3 / t)), Convergence::Finite);
    }

    #[test]
    fn metrics_follow_their_definitions() {
        let r = [[1.0, 0.0, 2.0], [0.5, 0.5, 0.5]];
        let x = [[1.5, 0.1, 2.0], [0.5, 0.0, 0.5]];
        let m = error_metrics(&x, &r);
        let d2 = [0.25, 0.01, 0.0, 0.0, 0.25, 0.0];
        let r2 = [1.0, 0.0, 4.0, 0.25, 0.25, 0.25];
        assert!((m.rmse - (d2.iter().sum::<f64>() / 6.0).sqrt()).abs() < 1e-7);
        let rel: f64 = d2.iter().zip(r2).map(|(d, r)| d / (r + RELMSE_EPSILON)).sum::<f64>() / 6.0;
        assert!((m.relmse - rel).abs() < 1e-7);
        assert!((m.mae - (0.5 + 0.1 + 0.5) / 6.0).abs() < 1e-7);
    }

    #[test]
    fn replicate_mean_estimates_the_variance_of_the_mean() {
        // Two replicates: per channel mean (a + b) / 2, variance between them (a − b)² / 2,
        // variance of the mean that over 2.
        let a = vec![[1.0, 0.0, 2.0]];
        let b = vec![[3.0, 0.0, 2.0]];
        let (mean, relmse) = replicate_mean(&[a, b]);
        assert_eq!(mean, vec![[2.0, 0.0, 2.0]]);
        let expected = (2.0 / 2.0) / (4.0 + RELMSE_EPSILON) / 3.0;
        assert!((relmse - expected).abs() < 1e-12, "{relmse} vs {expected}");
    }

    #[test]
    fn a_one_over_time_curve_has_slope_minus_one() {
        let points = [0.1, 0.2, 0.4, 0.8]
            .iter()
            .map(|&t| CurvePoint { seconds: t, relmse: 0.01 / t, relmse_min: 0.0, relmse_max: 0.0, spp: 0.0 })
            .collect();
        let c = Curve { strategy: "x".into(), points };
        let (_, b) = fit_convergence(&c).unwrap();
        assert!((b + 1.0).abs() < 1e-9);
        let (t, extrapolated) = time_to_reach(&c, 0.025).unwrap();
        assert!((t - 0.4).abs() < 1e-9 && !extrapolated);
        assert!(time_to_reach(&c, 0.001).unwrap().1);
    }
}
