//! One image being accumulated on the GPU: the buffers, the kernel and how far it has got.
//! `Renderer::render` drives it to a sample budget; the viewer drives it one short dispatch
//! per frame and reads the image back whenever it wants to show it.

use crate::error::{Error, Result};
use crate::gpu::bindings;
use crate::gpu::context::GpuContext;
use crate::gpu::layout::{DEFERRED_WORKGROUP, DeferredSample, FrameParams, PixelCounters};
use crate::gpu::readback::{GpuTimer, read_buffer};
use crate::kernel_plan::{KernelPlan, PlannedKernel};
use crate::output::{Contributions, RenderOutput};
use crate::render::{GpuScene, Kernel, Renderer};
use crate::scene::Camera;
use crate::settings::RenderSettings;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The first dispatch's work, in rays (`rays_per_camera_sample`): 2^18, a 256×256 image's pass
/// with MIS 1 + 1, about 10 ms on lavapipe for the shipped scenes. It was 8 rows, whatever the
/// samples: on lavapipe each dispatch costs about 2 ms more than its samples, and the first pass
/// over a 256×256 image took four dispatches (12.3 ms against 10.3 ms in one; docs/performance.md,
/// "The first dispatch").
const FIRST_DISPATCH_RAYS: u64 = 1 << 18;

/// Bytes per pixel of each image buffer (`accum`, `accum_sq`, the contribution images): a vec4f.
pub(crate) const IMAGE_BUFFER_BYTES_PER_PIXEL: u64 = std::mem::size_of::<[f32; 4]>() as u64;

/// A dispatch of `n` of the `left` passes (or rows) still to do, grown to take them all where no
/// more than `n` would be left: a render then never ends on a short dispatch, which costs about as
/// much beyond its samples as a long one (on lavapipe about 15 ms at 256×256, mostly per
/// invocation; docs/performance.md, "No short last dispatch"). A dispatch so grown takes at most
/// twice its target.
fn take_short_tail(n: u32, left: u32) -> u32 {
    if left - n <= n { left } else { n }
}

pub struct Accumulation {
    gpu: GpuContext,
    settings: RenderSettings,
    kernel: Arc<Kernel>,
    key: KernelPlan,
    kernel_creation: Duration,
    bind_group: wgpu::BindGroup,
    params: FrameParams,
    params_buffer: wgpu::Buffer,
    accum: wgpu::Buffer,
    accum_sq: wgpu::Buffer,
    counters: wgpu::Buffer,
    aov_light: wgpu::Buffer,
    aov_brdf: wgpu::Buffer,
    wavefront: Option<WavefrontQueue>,
    timer: Option<GpuTimer>,
    /// Next dispatch starts at this camera sample and row.
    sample_start: u32,
    row_start: u32,
    /// Seconds per pixel-sample, measured as we go (None before the first dispatch).
    cost: Option<f64>,
    last_work: u64,
    /// The first dispatch's work in rays (`rays_per_camera_sample`), where a headless render has
    /// set it (`set_first_dispatch_rays`); None: FIRST_DISPATCH_RAYS, at most one pass.
    first_dispatch_rays: Option<u64>,
    /// The most camera samples a band of rows takes per pixel (`set_band_samples`; 1: the viewer's
    /// passes).
    band_samples: u32,
    pixel_samples_done: u64,
    render_time: Duration,
    /// The camera footprint lists' buffer (held for the bind group that reads it), and the time
    /// its building took (part of `render_time`).
    _footprints: Option<wgpu::Buffer>,
    footprint_build: Duration,
    gpu_time: Duration,
    dispatches: u32,
}

/// What the wavefront kernels add: the deferred samples' count (cleared before each dispatch),
/// the direction kernel's indirect dispatch arguments, that kernel's bind group (a placeholder
/// where the arguments are bound for the others), and how many pixels a dispatch may cover
/// (one deferred sample each at most).
struct WavefrontQueue {
    header: wgpu::Buffer,
    dispatch_args: wgpu::Buffer,
    direction_bind_group: wgpu::BindGroup,
    capacity: u64,
}

impl WavefrontQueue {
    /// The queue's buffers, and the bind group of the first two kernels (the direction kernel's
    /// own is in the queue). Bind groups keep the buffers they bind alive.
    fn new(
        renderer: &Renderer,
        kernel: &Kernel,
        params: &wgpu::Buffer,
        scene: &GpuScene,
        outputs: &[&wgpu::Buffer; 5],
        capacity: u64,
        width: u32,
    ) -> Result<(wgpu::BindGroup, WavefrontQueue)> {
        if capacity < width as u64 {
            return Err(Error::Options(format!("width {width} exceeds what a wavefront dispatch can hold")));
        }
        let device = &renderer.gpu.device;
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let sample_bytes = std::mem::size_of::<DeferredSample>() as u64;
        let samples = buffer("deferred samples", capacity * sample_bytes, wgpu::BufferUsages::empty());
        let header = buffer("deferred header", 16, wgpu::BufferUsages::COPY_DST);
        let dispatch_args = buffer("deferred dispatch", 16, wgpu::BufferUsages::INDIRECT);
        let placeholder = buffer("placeholder", 16, wgpu::BufferUsages::empty());
        let with_args = |args| {
            [(bindings::DEFERRED, &samples), (bindings::DEFERRED_HEADER, &header), (bindings::DEFERRED_DISPATCH, args)]
        };
        let bind_group = renderer.bind_group(kernel, params, scene, outputs, &with_args(&dispatch_args));
        let direction_bind_group = renderer.bind_group(kernel, params, scene, outputs, &with_args(&placeholder));
        Ok((bind_group, WavefrontQueue { header, dispatch_args, direction_bind_group, capacity }))
    }
}

impl Accumulation {
    /// Allocates the image buffers and gets the kernel for `settings` (compiling it now if it
    /// is not cached; that time is `kernel_creation`, outside the render time).
    /// For progressive renders (the viewer's), whose passes may take one sample per invocation:
    /// their kernels keep the closest-hit list for camera rays (no footprint lists, which a pass
    /// of one sample a run does not pay for: docs/performance.md, "Camera rays by footprint
    /// lists").
    pub fn new(renderer: &Renderer, scene: &GpuScene, settings: &RenderSettings, camera: &Camera) -> Result<Self> {
        Self::create(renderer, scene, settings, camera, 0..settings.height, false)
    }

    /// The image's rows `rows` alone (a tile, `Renderer::render`): buffers of that many rows, the
    /// same camera samples in them as the whole image's render takes (the kernels see image rows,
    /// `tile_row`). Its `settings()` and `read()` are the tile's: `height` is `rows.len()`.
    /// Headless renders without a time limit take runs of several samples per invocation
    /// (`Renderer::render` sets `set_band_samples`), which footprint lists may serve
    /// (`KernelPlan::for_render`); with a time limit a pass over bands takes one.
    pub fn for_rows(
        renderer: &Renderer,
        scene: &GpuScene,
        image: &RenderSettings,
        camera: &Camera,
        rows: std::ops::Range<u32>,
    ) -> Result<Self> {
        Self::create(renderer, scene, image, camera, rows, image.time_limit.is_none())
    }

    fn create(
        renderer: &Renderer,
        scene: &GpuScene,
        image: &RenderSettings,
        camera: &Camera,
        rows: std::ops::Range<u32>,
        runs_of_samples: bool,
    ) -> Result<Self> {
        let gpu = renderer.gpu.clone();
        let device = &gpu.device;
        if image.width == 0 || image.height == 0 {
            return Err(Error::Options(format!("image size {}x{} is empty", image.width, image.height)));
        }
        if rows.is_empty() || rows.end > image.height {
            return Err(Error::Options(format!("rows {rows:?} are not a tile of {} rows", image.height)));
        }
        crate::settings::check_sample_counts(image.light_samples, image.brdf_samples)?;
        crate::settings::check_sample_range(image.first_sample, image.spp)?;
        let settings = &RenderSettings { height: rows.len() as u32, ..image.clone() };
        let (w, h) = (settings.width, settings.height);
        let pixels = w as u64 * h as u64;
        let accum_bytes = pixels * IMAGE_BUFFER_BYTES_PER_PIXEL;
        let max_binding = device.limits().max_storage_buffer_binding_size;
        if accum_bytes > max_binding {
            return Err(Error::Options(format!(
                "{w}x{h} needs {} MiB per image buffer; this adapter allows {} MiB",
                accum_bytes >> 20,
                max_binding >> 20
            )));
        }
        crate::control_variate::check(&scene.features, scene.emitter_triangles, settings)?;
        let zeroed = |label: &str, bytes: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let accum = zeroed("accum", accum_bytes);
        let accum_sq = zeroed("accum_sq", accum_bytes);
        let counters = zeroed("counters", pixels * std::mem::size_of::<PixelCounters>() as u64);
        let aov_bytes = if settings.write_aovs { accum_bytes } else { 16 };
        let aov_light = zeroed("aov_light", aov_bytes);
        let aov_brdf = zeroed("aov_brdf", aov_bytes);
        let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame params"),
            size: std::mem::size_of::<FrameParams>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });

        let outputs = [&accum, &accum_sq, &counters, &aov_light, &aov_brdf];
        let adapter = gpu.profile();
        let PlannedKernel { plan: key, footprints } =
            KernelPlan::for_render(scene.uploaded(), image, camera, rows.clone(), runs_of_samples, &adapter);
        if w.div_ceil(key.driver.workgroup.0) > device.limits().max_compute_workgroups_per_dimension {
            return Err(Error::Options(format!("width {w} exceeds this adapter's dispatch limit")));
        }
        let footprints =
            footprints.map(|(lists, words)| (lists.build_time, storage_words(device, "camera footprints", &words)));
        // The deferred samples of one dispatch: a band of rows, each pixel once, within the
        // binding size and the direction kernel's one-dimensional indirect dispatch.
        let deferred_capacity = pixels
            .min(max_binding / std::mem::size_of::<DeferredSample>() as u64)
            .min(device.limits().max_compute_workgroups_per_dimension as u64 * DEFERRED_WORKGROUP as u64);
        let creation_start = Instant::now();
        let (kernel, created) = renderer.kernel(&key)?;
        let (bind_group, wavefront) = if key.wavefront {
            let (bind_group, queue) =
                WavefrontQueue::new(renderer, &kernel, &params_buffer, scene, &outputs, deferred_capacity, w)?;
            (bind_group, Some(queue))
        } else {
            let extra: Vec<(u32, &wgpu::Buffer)> =
                footprints.iter().map(|(_, b)| (bindings::CAMERA_FOOTPRINTS, b)).collect();
            (renderer.bind_group(&kernel, &params_buffer, scene, &outputs, &extra), None)
        };
        // Building the lists is part of the render: it depends on the camera and the image.
        let (footprints, footprint_build) = footprints.map_or((None, Duration::ZERO), |(t, b)| (Some(b), t));
        let mut params = renderer.frame_params(scene, image, camera);
        (params.height, params.tile_row) = (h, rows.start);
        let mut acc = Accumulation {
            gpu: gpu.clone(),
            settings: settings.clone(),
            kernel,
            key,
            kernel_creation: Duration::ZERO,
            bind_group,
            params,
            params_buffer,
            accum,
            accum_sq,
            counters,
            aov_light,
            aov_brdf,
            wavefront,
            timer: gpu.has_timestamps.then(|| GpuTimer::new(&gpu.device, &gpu.queue)),
            sample_start: 0,
            row_start: 0,
            cost: None,
            last_work: 0,
            first_dispatch_rays: None,
            band_samples: 1,
            pixel_samples_done: 0,
            render_time: footprint_build,
            gpu_time: Duration::ZERO,
            dispatches: 0,
            _footprints: footprints,
            footprint_build,
        };
        if created {
            // An empty dispatch (no rows): drivers such as lavapipe compile the kernel here.
            acc.submit(0, 0, false, false)?;
            acc.kernel_creation = creation_start.elapsed();
        }
        Ok(acc)
    }

    /// Whether every camera sample of `settings.spp` has been taken.
    pub fn is_complete(&self) -> bool {
        self.sample_start >= self.settings.spp
    }

    /// Whether the last dispatch ended a pass over the image (or none ran): every pixel then has
    /// `complete_samples` camera samples, once `take_left_out_samples` has taken any that the
    /// driver's loop limit cut short.
    pub fn at_pass_boundary(&self) -> bool {
        self.row_start == 0
    }

    /// Camera samples that every pixel has (a dispatch may have covered only some rows of the next).
    pub fn complete_samples(&self) -> u32 {
        self.sample_start
    }

    pub fn pixel_samples_done(&self) -> u64 {
        self.pixel_samples_done
    }

    /// Wall-clock time of the dispatches so far (submit until the GPU is done).
    pub fn render_time(&self) -> Duration {
        self.render_time
    }

    /// Sizes the first dispatch, which measures the cost the later ones are sized by, to about
    /// `rays` (at least one row), passes over the image included. The viewer keeps the default,
    /// FIRST_DISPATCH_RAYS at most one pass, so that a change of settings shows within a frame.
    pub fn set_first_dispatch_rays(&mut self, rays: u64) {
        self.first_dispatch_rays = Some(rays);
    }

    /// Lets a band of rows take up to `n` camera samples per pixel where a whole image's pass
    /// does not fit a dispatch. Each invocation then spreads its fixed cost over several samples:
    /// on lavapipe one sample per invocation costs about 2.4× what a sample in a longer run costs
    /// (docs/performance.md, "Bands of several samples"). The image is the same; only the order in
    /// which pixels reach their count changes, so the viewer, which shows every pass, keeps 1.
    pub fn set_band_samples(&mut self, n: u32) {
        self.band_samples = n.max(1);
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    pub fn kernel_creation(&self) -> Duration {
        self.kernel_creation
    }

    /// Runs one dispatch of about `target` (a band of rows, or whole images × a few samples),
    /// waits for it and returns its time. Does nothing once complete.
    pub fn dispatch(&mut self, target: Duration) -> Result<Duration> {
        if self.is_complete() {
            return Ok(Duration::ZERO);
        }
        let (w, h) = (self.settings.width, self.settings.height);
        let pixels = w as u64 * h as u64;
        let mut max_rows = self.gpu.device.limits().max_compute_workgroups_per_dimension * self.key.driver.workgroup.1;
        if let Some(q) = &self.wavefront {
            max_rows = max_rows.min((q.capacity / w as u64) as u32);
        }
        // Start small, to measure the cost safely; then size the dispatch to `target`.
        // Never more than 4× the last dispatch's work, so one misleading measurement (a
        // dispatch that waited behind other work, say) cannot size a dispatch of minutes.
        let target_work = match self.cost {
            None => match self.first_dispatch_rays {
                Some(rays) => (rays / self.rays_per_camera_sample()).max(w as u64),
                None => (FIRST_DISPATCH_RAYS / self.rays_per_camera_sample()).clamp(w as u64, pixels),
            },
            Some(c) => ((target.as_secs_f64() / c) as u64).clamp(w as u64, 4 * self.last_work.max(w as u64)),
        };
        // A time budget's render keeps its dispatches to their target, so as not to overshoot it.
        let short_tail = |n: u32, left: u32| match self.settings.time_limit {
            None => take_short_tail(n, left),
            Some(_) => n,
        };
        let (rows, samples) = if self.row_start == 0 && target_work >= pixels && h <= max_rows {
            let left = self.settings.spp - self.sample_start;
            let k = (target_work / pixels).clamp(1, left as u64) as u32;
            (h, short_tail(k, left))
        } else {
            // A pass of bands: sample_start moves only when the pass ends, so every band of it
            // takes the same samples.
            let samples = self.band_samples.min(self.settings.spp - self.sample_start);
            let left = h - self.row_start;
            let rows = (target_work / (w as u64 * samples as u64)).clamp(1, left as u64) as u32;
            (short_tail(rows, left).min(max_rows), samples)
        };
        // The first pass over these rows (sample_start 0) finds their sums zeroed at creation.
        let elapsed = self.submit(rows, samples, self.sample_start == 0, true)?;
        let work = w as u64 * rows as u64 * samples as u64;
        self.last_work = work;
        self.pixel_samples_done += work;
        self.cost = Some(elapsed.as_secs_f64().max(1e-6) / work as f64);
        self.row_start += rows;
        if self.row_start >= h {
            self.row_start = 0;
            self.sample_start += samples;
        }
        Ok(elapsed)
    }

    /// Rays one camera sample traces at most, roughly: the camera's, the light samples' and the
    /// direction samples'.
    fn rays_per_camera_sample(&self) -> u64 {
        let p = &self.params;
        let lights = if p.light_selection == crate::gpu::layout::SELECT_EACH { p.light_count.max(1) } else { 1 };
        1 + p.brdf_samples as u64 + p.light_samples as u64 * lights as u64
    }

    /// Submits rows [row_start, row_start + rows) × `samples` camera samples, waits, and returns
    /// the wall-clock time. Dispatches are sized by it, not by timestamps: under eframe on
    /// lavapipe the timestamps of a 13 ms dispatch read 0.08 ms, and one bad reading must not
    /// size a dispatch of minutes. `fresh_sums`: the rows' sums are still zero (their first pass),
    /// so the kernel writes them without reading them.
    fn submit(&mut self, rows: u32, samples: u32, fresh_sums: bool, timed: bool) -> Result<Duration> {
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        self.params.row_start = self.row_start;
        self.params.row_count = rows;
        self.params.sample_start = self.sample_start;
        self.params.sample_count = samples;
        self.params.fresh_sums = fresh_sums as u32;
        queue.write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
        let timer = self.timer.as_ref().filter(|_| timed);
        let mut encoder = device.create_command_encoder(&Default::default());
        if let Some(q) = &self.wavefront {
            encoder.clear_buffer(&q.header, 0, None);
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("render"),
                timestamp_writes: timer.map(GpuTimer::writes),
            });
            pass.set_pipeline(&self.kernel.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            let groups_y = rows.div_ceil(self.key.driver.workgroup.1).max(1);
            let groups_x = self.settings.width.div_ceil(self.key.driver.workgroup.0);
            match (&self.kernel.wavefront, &self.wavefront) {
                (Some((prepare, direction)), Some(q)) => {
                    // One round of the three kernels per camera sample (shaders/wavefront.wgsl).
                    for _ in 0..samples.max(1) {
                        pass.set_pipeline(&self.kernel.pipeline);
                        pass.set_bind_group(0, &self.bind_group, &[]);
                        pass.dispatch_workgroups(groups_x, groups_y, 1);
                        pass.set_pipeline(prepare);
                        pass.dispatch_workgroups(1, 1, 1);
                        pass.set_pipeline(direction);
                        pass.set_bind_group(0, &q.direction_bind_group, &[]);
                        pass.dispatch_workgroups_indirect(&q.dispatch_args, 0);
                    }
                }
                _ => pass.dispatch_workgroups(groups_x, groups_y, 1),
            }
        }
        if let Some(t) = timer {
            t.resolve(&mut encoder);
        }
        let start = Instant::now();
        queue.submit([encoder.finish()]);
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("waiting for the GPU failed: {e}")))?;
        let elapsed = start.elapsed();
        if timed {
            self.render_time += elapsed;
            self.dispatches += 1;
            if let Some(t) = timer {
                self.gpu_time += t.read(device)?;
            }
        }
        Ok(elapsed)
    }

    /// Takes again the camera samples that Mesa 22's loop limit cut short (`loop_budget_held` in
    /// shaders/megakernel.wgsl left them out), until every pixel has the samples of the passes
    /// completed (`complete_samples`; at a pass boundary): each pixel continues from its own
    /// count, so it ends with the same samples as without the limit. Fails where one camera
    /// sample alone needs more loop iterations than the driver allows.
    pub fn take_left_out_samples(&mut self) -> Result<()> {
        let target = self.sample_start;
        let mut behind = u32::MAX;
        loop {
            let sum: Vec<[f32; 4]> = read_buffer(&self.gpu.device, &self.gpu.queue, &self.accum)?;
            let fewest = sum.iter().map(|s| s[3] as u32).min().unwrap_or(target);
            if fewest >= target {
                return Ok(());
            }
            if fewest <= behind && behind != u32::MAX {
                return Err(Error::Gpu(format!(
                    "a camera sample needs more loop iterations than this driver allows in one \
                     invocation (Mesa 22's lavapipe: 65,535); take fewer samples per camera sample \
                     (now {} light samples{} + {} BRDF samples) or use Mesa 23 or later",
                    self.settings.light_samples,
                    if self.settings.light_selection == crate::settings::LightSelection::Each
                        && self.settings.strategy.samples_lights()
                    {
                        " per light"
                    } else {
                        ""
                    },
                    self.settings.brdf_samples,
                )));
            }
            behind = fewest;
            let (row_start, sample_start) = (self.row_start, self.sample_start);
            self.row_start = 0;
            self.sample_start = fewest;
            // Pixels that already have samples: the sums are read (fresh_sums false). No direction
            // ray is held, so that each run keeps the samples before the one cut short
            // (take_samples_deferred in shaders/deferred_rays.wgsl).
            self.params.finish_samples = 1;
            let submitted = self.submit(self.settings.height, target - fewest, false, true);
            self.params.finish_samples = 0;
            submitted?;
            (self.row_start, self.sample_start) = (row_start, sample_start);
        }
    }

    /// Reads the image accumulated so far back to the host.
    pub fn read(&self) -> Result<RenderOutput> {
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        let sum: Vec<[f32; 4]> = read_buffer(device, queue, &self.accum)?;
        let sum_sq: Vec<[f32; 4]> = read_buffer(device, queue, &self.accum_sq)?;
        let counts: Vec<PixelCounters> = read_buffer(device, queue, &self.counters)?;
        let contributions = if self.settings.write_aovs {
            Some(Contributions {
                light: read_buffer(device, queue, &self.aov_light)?,
                brdf: read_buffer(device, queue, &self.aov_brdf)?,
            })
        } else {
            None
        };
        Ok(RenderOutput {
            width: self.settings.width,
            height: self.settings.height,
            sum,
            sum_sq,
            contributions,
            rays: counts.iter().map(|c| c.rays as u64).sum(),
            nonfinite_samples: counts.iter().map(|c| c.nonfinite as u64).sum(),
            truncated_samples: counts.iter().map(|c| c.truncated as u64).sum(),
            render_time: self.render_time,
            footprint_build: self.footprint_build,
            gpu_time: self.timer.is_some().then_some(self.gpu_time),
            kernel: self.key.clone(),
            kernel_creation: self.kernel_creation,
            dispatches: self.dispatches,
            interrupted: !self.is_complete(),
        })
    }
}

fn storage_words(device: &wgpu::Device, label: &str, words: &[u32]) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::cast_slice(words),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

#[cfg(test)]
mod tests {
    use super::take_short_tail;

    #[test]
    fn a_tail_no_longer_than_the_dispatch_joins_it() {
        // 16 spp after a first dispatch of 10 passes: the 6 left join it, one dispatch in all.
        assert_eq!(take_short_tail(10, 16), 16);
        // Exactly as many left as the dispatch takes: both in one.
        assert_eq!(take_short_tail(8, 16), 16);
        // More left than the dispatch takes: it stays at its target.
        assert_eq!(take_short_tail(5, 16), 5);
        assert_eq!(take_short_tail(1, 3), 1);
        // The last row or pass is never split off on its own.
        assert_eq!(take_short_tail(1, 2), 2);
        assert_eq!(take_short_tail(7, 7), 7);
    }
}
