//! Renders to completion without a window: a render is a series of short dispatches (a band of
//! rows × a few camera samples each, `Accumulation`), so a long render shows progress, can be
//! stopped, and keeps to a time limit; an image larger than a buffer binding is rendered in tiles
//! of rows.

use crate::accumulation::{Accumulation, IMAGE_BUFFER_BYTES_PER_PIXEL};
use crate::error::{Error, Result};
use crate::output::{Progress, RenderOutput};
use crate::render::{GpuScene, Renderer};
use crate::scene::Camera;
use crate::settings::{DEFAULT_DISPATCH_TARGET, RenderSettings, check_image_size};
use std::time::Duration;

/// A headless render's first dispatch, in rays, with the default dispatch target: 2^21, eight
/// times the viewer's (accumulation.rs, FIRST_DISPATCH_RAYS), about 10 passes over a 256×256 image
/// at MIS 1 + 1, 0.15 s on lavapipe for the Cornell box and 0.6 s for the Veach scene. With the
/// short tail taken in (accumulation.rs, `take_short_tail`) a 256×256 render of up to 20 such
/// camera samples is one dispatch (docs/performance.md, "One dispatch for small renders" and "No
/// short last dispatch"). Scaled with a shorter target (a time budget's, or a test's 1 ns for one
/// row at a time), so that it does not overshoot it.
const HEADLESS_FIRST_DISPATCH_RAYS: u64 = 1 << 21;
/// The most camera samples a band of rows takes per pixel in a headless render
/// (`Accumulation::set_band_samples`): 8 leaves lavapipe's fixed cost per invocation about a
/// tenth of the work, while bands of a 500 ms dispatch stay many rows tall at 4K.
const BAND_SAMPLES: u32 = 8;

fn headless_first_dispatch_rays(dispatch_target: Duration) -> u64 {
    let scale = (dispatch_target.as_secs_f64() / DEFAULT_DISPATCH_TARGET.as_secs_f64()).min(1.0);
    (HEADLESS_FIRST_DISPATCH_RAYS as f64 * scale) as u64
}

impl Renderer {
    /// Renders `settings.spp` camera samples per pixel (or until the time limit), calling
    /// `progress` after every dispatch; returning false from it stops the render early. An image
    /// whose pixel buffers (16 bytes a pixel) exceed the adapter's binding size (lavapipe: 128 MiB,
    /// 8.4 million pixels) is rendered in tiles of rows, the same image (`render_in_tiles`).
    pub fn render(
        &self,
        scene: &GpuScene,
        settings: &RenderSettings,
        camera: &Camera,
        progress: &mut dyn FnMut(Progress) -> bool,
    ) -> Result<RenderOutput> {
        let max_binding = self.gpu.device.limits().max_storage_buffer_binding_size;
        let row_bytes = IMAGE_BUFFER_BYTES_PER_PIXEL * settings.width.max(1) as u64;
        let max_rows = (max_binding / row_bytes).min(u32::MAX as u64) as u32;
        self.render_in_tiles(scene, settings, camera, max_rows, progress)
    }

    /// `render`, one tile of at most `max_rows` rows after another: the same camera samples per
    /// pixel as in one piece, so the same image. A time limit is shared among the tiles by their
    /// rows; a render stopped by `progress` leaves the rows after its tile without samples.
    pub fn render_in_tiles(
        &self,
        scene: &GpuScene,
        settings: &RenderSettings,
        camera: &Camera,
        max_rows: u32,
        progress: &mut dyn FnMut(Progress) -> bool,
    ) -> Result<RenderOutput> {
        check_image_size(settings.width, settings.height)?;
        if max_rows == 0 {
            return Err(Error::Options(format!(
                "a row of {} pixels does not fit this adapter's largest buffer binding",
                settings.width
            )));
        }
        let tiles = tile_rows(settings.height, max_rows);
        if tiles.len() == 1 {
            return self.render_rows(scene, settings, camera, 0..settings.height, progress);
        }
        let height = settings.height as f64;
        let mut whole: Option<RenderOutput> = None;
        // The tiles before this one: their pixel samples and render time.
        let (mut samples_before, mut time_before) = (0u64, Duration::ZERO);
        // With a time limit, the first tile takes its share of it, and the others the camera
        // samples it reached: every pixel of the image has the same count.
        let mut tile_spp: Option<u32> = None;
        for rows in tiles {
            let share = rows.len() as f64 / height;
            let start = rows.start as f64 / height;
            let tile_settings = match tile_spp {
                Some(spp) => RenderSettings { spp, time_limit: None, ..settings.clone() },
                None => {
                    RenderSettings { time_limit: settings.time_limit.map(|t| t.mul_f64(share)), ..settings.clone() }
                }
            };
            let tile = self.render_rows(scene, &tile_settings, camera, rows, &mut |p| {
                progress(Progress {
                    fraction: start + share * p.fraction,
                    pixel_samples_done: samples_before + p.pixel_samples_done,
                    elapsed: time_before + p.elapsed,
                })
            })?;
            samples_before += tile.sum.iter().map(|s| s[3] as u64).sum::<u64>();
            tile_spp.get_or_insert(tile.min_samples());
            time_before += tile.render_time;
            let stop = tile.interrupted;
            whole = Some(match whole {
                None => tile,
                Some(w) => w.with_rows_below(tile),
            });
            if stop {
                break;
            }
        }
        let mut out = whole.expect("at least one tile");
        out.pad_rows_to(settings.height);
        Ok(out)
    }

    /// The image's rows `rows` (all of them: `render`), with `settings` the whole image's.
    fn render_rows(
        &self,
        scene: &GpuScene,
        settings: &RenderSettings,
        camera: &Camera,
        rows: std::ops::Range<u32>,
        progress: &mut dyn FnMut(Progress) -> bool,
    ) -> Result<RenderOutput> {
        let mut acc = Accumulation::for_rows(self, scene, settings, camera, rows.clone())?;
        // With a time limit, no dispatch longer than a tenth of it, so that the render stops near it.
        let target = match settings.time_limit {
            Some(t) => settings.dispatch_target.min(t / 10),
            None => settings.dispatch_target,
        };
        acc.set_first_dispatch_rays(headless_first_dispatch_rays(target));
        // Without a time limit nothing stops a render between passes, so bands of rows may take
        // several samples each (a time limit keeps whole passes, so its pixels' counts stay even).
        if settings.time_limit.is_none() {
            acc.set_band_samples(BAND_SAMPLES);
        }
        let total_pixel_samples = settings.width as u64 * rows.len() as u64 * settings.spp as u64;
        // Whether `progress` asked to stop.
        let mut stopping = false;
        while !acc.is_complete() {
            // A render ends only between passes, and after its first: every pixel of the image
            // then has the same camera samples, whatever stopped it.
            let out_of_time = settings.time_limit.is_some_and(|t| acc.render_time() >= t);
            if (out_of_time || stopping) && acc.at_pass_boundary() && acc.complete_samples() > 0 {
                break;
            }
            acc.dispatch(target)?;
            let done = acc.pixel_samples_done();
            let mut fraction = if total_pixel_samples > 0 { done as f64 / total_pixel_samples as f64 } else { 1.0 };
            if let Some(t) = settings.time_limit {
                fraction = fraction.max(acc.render_time().as_secs_f64() / t.as_secs_f64().max(1e-9));
            }
            let p = Progress { fraction: fraction.min(1.0), pixel_samples_done: done, elapsed: acc.render_time() };
            stopping |= !progress(p);
        }
        acc.take_left_out_samples()?;
        let mut out = acc.read()?;
        // Running out of time is the budget, not an interruption.
        out.interrupted = stopping && !acc.is_complete();
        Ok(out)
    }
}

/// An image's rows in tiles of at most `max_rows` (and at least 1), as even as they come.
pub fn tile_rows(height: u32, max_rows: u32) -> Vec<std::ops::Range<u32>> {
    let count = height.div_ceil(max_rows.max(1)).max(1);
    (0..count)
        .map(|i| {
            (height as u64 * i as u64 / count as u64) as u32..(height as u64 * (i as u64 + 1) / count as u64) as u32
        })
        .collect()
}
