//! What the viewer shows of an accumulated render: the image, the MIS contributions side by
//! side, the MIS weight as false colour, or the per-pixel variance. Pure functions from a
//! `RenderOutput` to display pixels, so tests can check them without a window.

use veach::RenderOutput;
use veach::image_io::{light_share_false_colour, linear_to_srgb};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    Image,
    /// Light-sample part | BRDF-sample part, side by side; they add up to the image.
    Contributions,
    /// Share of the pixel carried by light samples: blue = BRDF samples, red = light samples.
    MisWeight,
    /// Standard error of the pixel mean (luminance), on a logarithmic false-colour scale.
    Variance,
}

impl View {
    pub const ALL: [View; 4] = [View::Image, View::Contributions, View::MisWeight, View::Variance];

    pub fn label(self) -> &'static str {
        match self {
            View::Image => "image",
            View::Contributions => "light | BRDF contributions",
            View::MisWeight => "MIS weight",
            View::Variance => "variance",
        }
    }

    /// Views that need the kernel to write the contribution buffers.
    pub fn needs_contributions(self) -> bool {
        matches!(self, View::Contributions | View::MisWeight)
    }
}

/// Display pixels (sRGB, 8 bits) and their size.
pub struct DisplayImage {
    pub width: usize,
    pub height: usize,
    pub rgba: Vec<u8>,
}

fn luminance(c: &[f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn to_srgb8(v: f32) -> u8 {
    let v = if v.is_finite() { v } else { 0.0 };
    (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8
}

fn encode(pixels: &[[f32; 3]], scale: f32) -> Vec<u8> {
    pixels.iter().flat_map(|p| [to_srgb8(p[0] * scale), to_srgb8(p[1] * scale), to_srgb8(p[2] * scale), 255]).collect()
}

/// Decades the variance view spans below its brightest pixel.
const VARIANCE_DECADES: f32 = 4.0;

/// A dark-blue → yellow ramp for t in [0, 1] (linear values).
fn ramp(t: f32) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0);
    [t * t, t.powf(0.8) * 0.9, (1.0 - t) * 0.35 + 0.05]
}

/// The pixels of `view`; `exposure` in stops scales radiance views.
pub fn display(out: &RenderOutput, view: View, exposure: f32) -> DisplayImage {
    let (w, h) = (out.width as usize, out.height as usize);
    let scale = exposure.exp2();
    match (view, out.contribution_images()) {
        (View::Contributions, Some(c)) => {
            // Two images side by side, row by row.
            let mut side = Vec::with_capacity(2 * w * h);
            for y in 0..h {
                side.extend_from_slice(&c.light[y * w..(y + 1) * w]);
                side.extend_from_slice(&c.brdf[y * w..(y + 1) * w]);
            }
            DisplayImage { width: 2 * w, height: h, rgba: encode(&side, scale) }
        }
        (View::MisWeight, Some(c)) => {
            let colours = light_share_false_colour(&c.light, &c.brdf, &c.emitted_luminance);
            DisplayImage { width: w, height: h, rgba: encode(&colours, 1.0) }
        }
        (View::Variance, _) => {
            let std_err: Vec<f32> = out.variance_of_mean().iter().map(|v| luminance(v).max(0.0).sqrt()).collect();
            let top = std_err.iter().copied().filter(|v| v.is_finite()).fold(0.0f32, f32::max);
            let colours: Vec<[f32; 3]> = std_err
                .iter()
                .map(|&s| {
                    if !(s > 0.0 && top > 0.0) {
                        return [0.0; 3];
                    }
                    ramp(1.0 + (s / top).log10() / VARIANCE_DECADES)
                })
                .collect();
            DisplayImage { width: w, height: h, rgba: encode(&colours, 1.0) }
        }
        // The image, also while a contribution view waits for its first samples.
        _ => DisplayImage { width: w, height: h, rgba: encode(&out.mean(), scale) },
    }
}
