//! Error against time while the image accumulates: relMSE (the bench's measure, ε as in
//! `veach_bench::bench::RELMSE_EPSILON`) of the current image against a reference, one curve per
//! accumulation, earlier ones kept for comparison.

use std::path::Path;
use veach::RenderOutput;
use veach_bench::bench::error_metrics;

pub struct Reference {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
    /// Where it came from, for the panel.
    pub source: String,
}

#[derive(Clone, Copy, Debug)]
pub struct CurvePoint {
    pub seconds: f64,
    pub spp: f64,
    pub relmse: f64,
}

pub struct Curve {
    pub label: String,
    pub points: Vec<CurvePoint>,
}

#[derive(Default)]
pub struct ErrorCurves {
    pub reference: Option<Reference>,
    pub curves: Vec<Curve>,
}

/// Curves kept: older ones are dropped first.
const MAX_CURVES: usize = 12;

impl ErrorCurves {
    /// A new curve for an accumulation that starts now; an earlier curve without points is
    /// replaced rather than kept.
    pub fn start(&mut self, label: String) {
        if self.curves.last().is_some_and(|c| c.points.is_empty()) {
            self.curves.pop();
        }
        if self.curves.len() >= MAX_CURVES {
            self.curves.remove(0);
        }
        self.curves.push(Curve { label, points: Vec::new() });
    }

    /// Why the current image cannot be compared, if it cannot.
    pub fn mismatch(&self, width: u32, height: u32) -> Option<String> {
        match &self.reference {
            None => Some("no reference: load an EXR or render one".into()),
            Some(r) if (r.width, r.height) != (width, height) => {
                Some(format!("the reference is {}x{}, the image {width}x{height}", r.width, r.height))
            }
            Some(_) => None,
        }
    }

    /// Adds a point for `out` to the current curve (when there is a matching reference).
    pub fn record(&mut self, out: &RenderOutput) {
        let seconds = out.render_time.as_secs_f64();
        // Until every pixel has a sample, the error is mostly the missing rows, not noise.
        if self.mismatch(out.width, out.height).is_some() || seconds <= 0.0 || out.min_samples() == 0 {
            return;
        }
        let reference = self.reference.as_ref().expect("checked by mismatch");
        let relmse = error_metrics(&out.mean(), &reference.pixels).relmse;
        let point = CurvePoint { seconds, spp: out.mean_samples(), relmse };
        if let Some(curve) = self.curves.last_mut() {
            curve.points.push(point);
        }
    }

    /// All curves as CSV: curve, seconds, spp, relmse.
    pub fn csv(&self) -> String {
        let mut text = String::from("curve,seconds,spp,relmse\n");
        for c in &self.curves {
            for p in &c.points {
                text.push_str(&format!(
                    "\"{}\",{:.6},{:.3},{:.6e}\n",
                    c.label.replace('"', "'"),
                    p.seconds,
                    p.spp,
                    p.relmse
                ));
            }
        }
        text
    }

    pub fn write_csv(&self, path: &Path) -> veach::Result<()> {
        let text = self.csv();
        veach::image_io::write_atomically(path, |f| {
            use std::io::Write;
            f.write_all(text.as_bytes()).map_err(|e| e.to_string())
        })
    }
}
