//! What a render gives back: the per-pixel sums and the image they mean, the MIS contribution
//! images, and what the render cost (`RenderOutput`); the progress a long render reports.

use crate::kernel_plan::KernelPlan;
use std::time::Duration;

/// What the progress callback sees after each dispatch.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// 0..=1 of the sample budget (or of the time limit, whichever is nearer).
    pub fraction: f64,
    pub pixel_samples_done: u64,
    pub elapsed: Duration,
}

/// Per-pixel sums of the MIS-weighted light-sample contributions and of the BRDF-sample
/// contributions (with emission seen directly); per pixel their rgb add up to
/// `RenderOutput::sum`. `brdf[i][3]` sums the luminance of the emission part.
pub struct Contributions {
    pub light: Vec<[f32; 4]>,
    pub brdf: Vec<[f32; 4]>,
}

/// Per-pixel means of `Contributions`: `light + brdf` is the image; `emitted_luminance` is the
/// luminance of the directly seen emission inside `brdf`.
pub struct ContributionImages {
    pub light: Vec<[f32; 3]>,
    pub brdf: Vec<[f32; 3]>,
    pub emitted_luminance: Vec<f32>,
}

/// The accumulated image and what it cost.
pub struct RenderOutput {
    pub width: u32,
    pub height: u32,
    /// Per pixel: sum of radiance samples (rgb) and the number of camera samples (w).
    pub sum: Vec<[f32; 4]>,
    pub sum_sq: Vec<[f32; 4]>,
    /// Sums of the light-sample and BRDF-sample contributions (with `write_aovs`).
    pub contributions: Option<Contributions>,
    pub rays: u64,
    pub nonfinite_samples: u64,
    /// Camera samples that the driver's loop limit cut short, left out and taken again
    /// (Mesa 22's lavapipe; `Accumulation::take_left_out_samples`).
    pub truncated_samples: u64,
    /// Wall-clock time of the dispatches (submit until the GPU is done), plus the camera
    /// footprint lists' building where the kernel reads them (`footprint_build`).
    pub render_time: Duration,
    /// Time spent building the camera footprint lists (gpu/camera_footprints.rs), zero without.
    pub footprint_build: Duration,
    /// The dispatches' time by GPU timestamps, where the adapter has timestamp queries.
    pub gpu_time: Option<Duration>,
    /// The kernel that rendered, and the time spent creating it for this render (zero when it
    /// was cached).
    pub kernel: KernelPlan,
    pub kernel_creation: Duration,
    pub dispatches: u32,
    /// Stopped by the callback (Ctrl-C) before the budget was spent.
    pub interrupted: bool,
}

impl RenderOutput {
    /// This tile's rows with `below`'s after them: one output, its counts and times added up.
    pub(crate) fn with_rows_below(mut self, below: RenderOutput) -> RenderOutput {
        self.height += below.height;
        self.sum.extend(below.sum);
        self.sum_sq.extend(below.sum_sq);
        if let (Some(c), Some(b)) = (&mut self.contributions, below.contributions) {
            c.light.extend(b.light);
            c.brdf.extend(b.brdf);
        }
        self.rays += below.rays;
        self.nonfinite_samples += below.nonfinite_samples;
        self.truncated_samples += below.truncated_samples;
        self.render_time += below.render_time;
        self.footprint_build += below.footprint_build;
        self.gpu_time = self.gpu_time.zip(below.gpu_time).map(|(a, b)| a + b);
        self.kernel_creation += below.kernel_creation;
        self.dispatches += below.dispatches;
        self.interrupted |= below.interrupted;
        self
    }

    /// Rows without samples up to `height` (a tiled render stopped before its last tiles).
    pub(crate) fn pad_rows_to(&mut self, height: u32) {
        let pixels = self.width as usize * height as usize;
        self.sum.resize(pixels, [0.0; 4]);
        self.sum_sq.resize(pixels, [0.0; 4]);
        if let Some(c) = &mut self.contributions {
            c.light.resize(pixels, [0.0; 4]);
            c.brdf.resize(pixels, [0.0; 4]);
        }
        self.interrupted |= self.height < height;
        self.height = height;
    }

    /// Per-pixel mean radiance; non-finite values (which the kernel never writes, but a sum can
    /// overflow) become 0.
    pub fn mean(&self) -> Vec<[f32; 3]> {
        self.sum
            .iter()
            .map(|s| {
                let n = s[3].max(1.0);
                let m = [s[0] / n, s[1] / n, s[2] / n];
                m.map(|v| if v.is_finite() { v } else { 0.0 })
            })
            .collect()
    }

    /// Per-pixel variance of the mean (sample variance / n), per channel.
    pub fn variance_of_mean(&self) -> Vec<[f32; 3]> {
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                let n = s[3] as f64;
                if n < 2.0 {
                    return [0.0; 3];
                }
                std::array::from_fn(|c| {
                    let mean = s[c] as f64 / n;
                    let var = ((q[c] as f64 - n * mean * mean) / (n - 1.0)).max(0.0);
                    (var / n) as f32
                })
            })
            .collect()
    }

    /// Mean light-sample and BRDF-sample images (see `Contributions`), when rendered.
    pub fn contribution_images(&self) -> Option<ContributionImages> {
        let c = self.contributions.as_ref()?;
        let mean = |sums: &[[f32; 4]]| -> Vec<[f32; 3]> {
            sums.iter()
                .zip(&self.sum)
                .map(|(v, s)| {
                    let n = s[3].max(1.0);
                    [v[0] / n, v[1] / n, v[2] / n].map(|x| if x.is_finite() { x } else { 0.0 })
                })
                .collect()
        };
        Some(ContributionImages {
            light: mean(&c.light),
            brdf: mean(&c.brdf),
            emitted_luminance: c.brdf.iter().zip(&self.sum).map(|(v, s)| v[3] / s[3].max(1.0)).collect(),
        })
    }

    pub fn min_samples(&self) -> u32 {
        self.sum.iter().map(|s| s[3] as u32).min().unwrap_or(0)
    }

    pub fn max_samples(&self) -> u32 {
        self.sum.iter().map(|s| s[3] as u32).max().unwrap_or(0)
    }

    pub fn mean_samples(&self) -> f64 {
        self.sum.iter().map(|s| s[3] as f64).sum::<f64>() / self.sum.len().max(1) as f64
    }
}
