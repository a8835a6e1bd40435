//! The viewer's window: controls on the left, the progressive image in the middle, statistics
//! and the live error plot at the bottom. `ViewerApp::show` draws one frame into any `Ui`, so
//! the same code runs in eframe's window and in egui_kittest's headless harness.

use crate::curves::{ErrorCurves, Reference};
use crate::display::{DisplayImage, View, display};
use crate::orbit::OrbitCamera;
use crate::session::{LoadedScene, RenderSession};
use egui::{Color32, ColorImage, TextureHandle, TextureOptions};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use veach::scene::Camera;
use veach::{Execution, Heuristic, LightSampling, LightSelection, RenderSettings, Renderer, Sampler, Strategy};

/// How the viewer starts.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    pub scene: PathBuf,
    /// Strategy, sample counts, heuristic, selection, seed and the base image size (before the
    /// resolution scale); `spp` is the sample count at which accumulation stops.
    pub settings: RenderSettings,
    pub camera: Option<String>,
    pub reference: Option<PathBuf>,
    pub exposure: f32,
    /// Render time per frame: dispatches are sized to fit it.
    pub frame_budget: Duration,
    /// Save what the window shows after this many frames, then close.
    pub screenshot: Option<(PathBuf, u32)>,
}

impl ViewerOptions {
    pub fn new(scene: PathBuf) -> ViewerOptions {
        ViewerOptions {
            scene,
            settings: RenderSettings { spp: 4096, ..RenderSettings::recommended() },
            camera: None,
            reference: None,
            exposure: 0.0,
            frame_budget: Duration::from_millis(40),
            screenshot: None,
        }
    }
}

/// What the user can change; any change restarts accumulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Controls {
    pub strategy: Strategy,
    pub heuristic: Heuristic,
    pub light_selection: LightSelection,
    pub light_sampling: LightSampling,
    pub sampler: Sampler,
    pub execution: Execution,
    pub light_samples: u32,
    pub brdf_samples: u32,
    pub seed: u32,
    pub resolution_scale: f32,
    pub max_spp: u32,
    pub hide_emitters: bool,
    pub control_variate: bool,
    pub exposure: f32,
    pub view: View,
}

/// Reference renders requested from the panel take this many camera samples (MIS 4+4, every light).
pub const REFERENCE_SPP: u32 = 256;

pub struct ViewerApp {
    options: ViewerOptions,
    pub controls: Controls,
    session: RenderSession,
    orbit: OrbitCamera,
    /// Settings and camera of the accumulation in progress.
    current: Option<(RenderSettings, Camera)>,
    /// A reference render in progress (it takes the GPU until done).
    rendering_reference: bool,
    pub curves: ErrorCurves,
    texture: Option<TextureHandle>,
    shown: Option<DisplayImage>,
    /// The last message for the user (errors included): the viewer never panics on input.
    pub status: String,
    scene_path_text: String,
    save_path_text: String,
    curves_path_text: String,
    reference_path_text: String,
    pub frames: u64,
    screenshot_requested: bool,
}

fn orbit_for(loaded: &LoadedScene, camera: Camera) -> OrbitCamera {
    let bounds = loaded.scene.bounds();
    let to_center = (bounds.center() - camera.position).dot(camera.forward);
    OrbitCamera::new(camera, to_center.max(0.1 * bounds.radius()))
}

impl ViewerApp {
    /// A viewer on `renderer`'s device, with the scene of `options` loaded.
    pub fn new(renderer: Arc<Renderer>, options: ViewerOptions) -> veach::Result<ViewerApp> {
        let loaded = LoadedScene::load(&renderer, &options.scene)?;
        let camera = loaded
            .scene
            .camera(options.camera.as_deref())
            .map_err(|m| veach::Error::Options(format!("{}: {m}", options.scene.display())))?;
        let orbit = orbit_for(&loaded, camera);
        let s = &options.settings;
        let controls = Controls {
            strategy: s.strategy,
            heuristic: s.heuristic,
            light_selection: s.light_selection,
            light_sampling: s.light_sampling,
            sampler: s.sampler,
            execution: s.execution,
            light_samples: s.light_samples,
            brdf_samples: s.brdf_samples,
            seed: s.seed,
            resolution_scale: 1.0,
            max_spp: s.spp,
            hide_emitters: s.hide_emitters,
            control_variate: s.control_variate,
            exposure: options.exposure,
            view: View::Image,
        };
        let mut app = ViewerApp {
            scene_path_text: options.scene.display().to_string(),
            save_path_text: "veach-view.exr".into(),
            curves_path_text: "veach-curves.csv".into(),
            reference_path_text: options.reference.as_ref().map(|p| p.display().to_string()).unwrap_or_default(),
            options,
            controls,
            session: RenderSession::new(renderer, loaded),
            orbit,
            current: None,
            rendering_reference: false,
            curves: ErrorCurves::default(),
            texture: None,
            shown: None,
            status: String::new(),
            frames: 0,
            screenshot_requested: false,
        };
        for w in &app.session.loaded.scene.warnings {
            app.status = format!("warning: {w}");
        }
        if let Some(path) = app.options.reference.clone() {
            app.load_reference(&path)?;
        }
        Ok(app)
    }

    /// The settings the controls ask for.
    pub fn wanted_settings(&self) -> RenderSettings {
        let c = &self.controls;
        let base = &self.options.settings;
        let scaled = |v: u32| ((v as f32 * c.resolution_scale).round() as u32).max(8);
        RenderSettings {
            width: scaled(base.width),
            height: scaled(base.height),
            spp: if c.max_spp == 0 { u32::MAX } else { c.max_spp },
            strategy: c.strategy,
            light_samples: c.light_samples,
            brdf_samples: c.brdf_samples,
            heuristic: c.heuristic,
            light_selection: c.light_selection,
            light_sampling: c.light_sampling,
            sampler: c.sampler,
            execution: c.execution,
            seed: c.seed,
            write_aovs: c.view.needs_contributions(),
            hide_emitters: c.hide_emitters,
            control_variate: c.control_variate,
            ..base.clone()
        }
    }

    fn strategy_label(s: &RenderSettings) -> String {
        let counts = match s.strategy {
            Strategy::Uniform | Strategy::Brdf => format!("{}", s.brdf_samples),
            Strategy::Light => format!("{}", s.light_samples),
            Strategy::Mis => format!(
                "{}+{} {}",
                s.light_samples,
                s.brdf_samples,
                if s.heuristic == Heuristic::Power { "power" } else { "balance" }
            ),
            Strategy::MisLobes => format!(
                "{}+{} per lobe {}",
                s.light_samples,
                s.brdf_samples,
                if s.heuristic == Heuristic::Power { "power" } else { "balance" }
            ),
        };
        let selection = match s.light_selection {
            LightSelection::Each => "each light",
            LightSelection::Uniform => "uniform light",
            LightSelection::Power => "light by power",
            LightSelection::Bsdf => "light by BSDF",
            LightSelection::Tree => "light by tree",
        };
        format!(
            "{} {counts}, {selection} ({}){}, {} samples, seed {}",
            s.strategy.name(),
            s.light_sampling.name(),
            if s.control_variate { ", control variate" } else { "" },
            s.sampler.name(),
            s.seed
        )
    }

    /// Restarts accumulation when the wanted settings or camera differ from the current ones.
    fn sync(&mut self) {
        let (settings, camera) = if self.rendering_reference {
            let w = self.wanted_settings();
            let mut s = veach_bench::bench::reference_settings(w.width, w.height, REFERENCE_SPP);
            s.hide_emitters = w.hide_emitters;
            (s, self.orbit.camera())
        } else {
            (self.wanted_settings(), self.orbit.camera())
        };
        if self.current.as_ref().is_some_and(|(s, c)| *s == settings && *c == camera) {
            return;
        }
        if let Some(problem) = sample_count_problem(&settings) {
            self.status = problem;
            self.current = Some((settings, camera));
            return;
        }
        match self.session.restart(&settings, &camera) {
            Ok(()) => {
                if !self.rendering_reference {
                    self.curves.start(Self::strategy_label(&settings));
                }
            }
            Err(e) => self.status = format!("error: {e}"),
        }
        self.current = Some((settings, camera));
    }

    /// Whether the accumulation in progress has reached its sample count.
    pub fn is_complete(&self) -> bool {
        self.session.is_complete()
    }

    pub fn session(&self) -> &RenderSession {
        &self.session
    }

    /// The pixels on screen (after the view's mapping), if any.
    pub fn shown(&self) -> Option<&DisplayImage> {
        self.shown.as_ref()
    }

    /// One frame of work: restart if needed, render for the frame budget, update the image.
    pub fn advance(&mut self, ctx: &egui::Context) {
        self.sync();
        match self.session.advance(self.options.frame_budget) {
            Ok(true) => {}
            Ok(false) => return,
            Err(e) => {
                self.status = format!("error: {e}");
                return;
            }
        }
        if self.rendering_reference {
            if self.session.is_complete() {
                self.finish_reference();
            }
            return;
        }
        if let Some(out) = self.session.latest() {
            self.curves.record(out);
        }
        self.refresh_texture(ctx);
    }

    fn finish_reference(&mut self) {
        self.rendering_reference = false;
        if let Some(out) = self.session.latest() {
            self.curves.reference = Some(Reference {
                width: out.width,
                height: out.height,
                pixels: out.mean(),
                source: format!("rendered: MIS 4+4, every light, {REFERENCE_SPP} spp"),
            });
            self.status = "reference rendered".into();
        }
    }

    fn refresh_texture(&mut self, ctx: &egui::Context) {
        let Some(out) = self.session.latest() else { return };
        let image = display(out, self.controls.view, self.controls.exposure);
        let colour = ColorImage::from_rgba_unmultiplied([image.width, image.height], &image.rgba);
        match &mut self.texture {
            Some(t) => t.set(colour, TextureOptions::NEAREST),
            None => self.texture = Some(ctx.load_texture("veach image", colour, TextureOptions::NEAREST)),
        }
        self.shown = Some(image);
    }

    /// Loads a linear EXR/PFM as the reference for the error plot.
    pub fn load_reference(&mut self, path: &Path) -> veach::Result<()> {
        let (width, height, pixels) = veach::image_io::read_reference(path)?;
        self.curves.reference = Some(Reference { width, height, pixels, source: path.display().to_string() });
        self.status = format!("reference: {}", path.display());
        Ok(())
    }

    /// Opens another glTF scene, keeping the controls.
    pub fn open_scene(&mut self, path: &Path) -> veach::Result<()> {
        let loaded = LoadedScene::load(&self.session.renderer, path)?;
        let camera = loaded.scene.camera(None).map_err(veach::Error::Options)?;
        self.orbit = orbit_for(&loaded, camera);
        self.session.replace_scene(loaded);
        self.current = None;
        self.curves = ErrorCurves::default();
        self.status = format!("opened {}", path.display());
        Ok(())
    }

    /// Saves the current image (linear EXR/PFM, or PNG after exposure), an EXR or PNG with the
    /// settings that made it in its header, as `veach render` writes them.
    pub fn save_image(&self, path: &Path) -> veach::Result<()> {
        let nothing = || veach::Error::Options("nothing rendered yet".into());
        let out = self.session.latest().ok_or_else(nothing)?;
        let (settings, camera) = self.current.as_ref().ok_or_else(nothing)?;
        let loaded = &self.session.loaded;
        let metadata =
            veach::stats::image_metadata(settings, camera, &loaded.path, &loaded.scene, out, &self.session.renderer);
        veach::image_io::write_image_with_metadata(
            path,
            out.width,
            out.height,
            &out.mean(),
            self.controls.exposure,
            &metadata,
        )
    }

    fn report<T>(&mut self, result: veach::Result<T>, ok: String) {
        self.status = match result {
            Ok(_) => ok,
            Err(e) => format!("error: {e}"),
        };
    }

    /// Draws one frame and renders for the frame budget.
    pub fn show(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        self.frames += 1;
        self.handle_dropped_files(&ctx);
        self.handle_keys(&ctx);
        egui::Panel::left("controls").resizable(false).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls_ui(ui));
        });
        // After the controls, so that a change restarts in the frame it was made.
        self.advance(&ctx);
        egui::Panel::bottom("statistics").resizable(true).default_size(200.0).show(ui, |ui| {
            self.statistics_ui(ui);
        });
        egui::CentralPanel::default().show(ui, |ui| self.image_ui(ui));

        if !self.session.is_complete() {
            ctx.request_repaint();
        }
        self.screenshot(&ctx);
    }

    fn controls_ui(&mut self, ui: &mut egui::Ui) {
        let c = &mut self.controls;
        ui.heading("Strategy");
        for s in Strategy::ALL {
            if ui.radio_value(&mut c.strategy, s, s.name()).changed() {
                (c.light_samples, c.brdf_samples) = interactive_sample_counts(s);
            }
        }
        ui.add_enabled_ui(c.strategy.samples_lights(), |ui| {
            ui.horizontal(|ui| {
                let label = ui.label("light samples");
                ui.add(egui::DragValue::new(&mut c.light_samples).range(0..=1024)).labelled_by(label.id);
            });
        });
        ui.add_enabled_ui(c.strategy != Strategy::Light, |ui| {
            ui.horizontal(|ui| {
                let label = ui.label(if c.strategy == Strategy::Uniform { "directions" } else { "BRDF samples" });
                ui.add(egui::DragValue::new(&mut c.brdf_samples).range(0..=1024)).labelled_by(label.id);
            });
        });
        ui.add_enabled_ui(matches!(c.strategy, Strategy::Mis | Strategy::MisLobes), |ui| {
            ui.label("MIS heuristic");
            ui.horizontal(|ui| {
                ui.radio_value(&mut c.heuristic, Heuristic::Balance, "balance");
                ui.radio_value(&mut c.heuristic, Heuristic::Power, "power");
            });
        });
        ui.add_enabled_ui(c.strategy.samples_lights(), |ui| {
            // A list, not radio buttons: five rows would push the panel's lower controls off a
            // small window.
            let selections = [
                (LightSelection::Each, "every light"),
                (LightSelection::Uniform, "one, uniformly"),
                (LightSelection::Power, "one, by power"),
                (LightSelection::Bsdf, "one, by BSDF and power"),
                (LightSelection::Tree, "one, by the light tree"),
            ];
            let shown = selections.iter().find(|(s, _)| *s == c.light_selection).map_or("", |(_, n)| *n);
            egui::ComboBox::from_label("light selection").selected_text(shown).show_ui(ui, |ui| {
                for (selection, name) in selections {
                    ui.selectable_value(&mut c.light_selection, selection, name);
                }
            });
            ui.horizontal(|ui| {
                ui.label("point on a light, uniform in");
                ui.radio_value(&mut c.light_sampling, LightSampling::Area, "area");
                ui.radio_value(&mut c.light_sampling, LightSampling::SolidAngle, "solid angle");
                ui.radio_value(&mut c.light_sampling, LightSampling::Cone, "cone (spheres)");
                ui.radio_value(&mut c.light_sampling, LightSampling::Auto, "auto (by shape)");
            });
        });
        ui.checkbox(&mut c.control_variate, "unshadowed light as a control variate").on_hover_text(
            "adds the light a diffuse surface would get with nothing in the way, in closed form, and \
             samples only the difference: no noise where a light is fully visible (uniform, brdf, \
             light, mis; lights of at most 32 triangles without emission textures)",
        );
        ui.horizontal(|ui| {
            ui.label("samples").on_hover_text(
                "sobol: each pixel's camera samples stratified (Owen-scrambled Sobol points); \
                 independent: plain Monte Carlo",
            );
            ui.radio_value(&mut c.sampler, Sampler::Sobol, "sobol");
            ui.radio_value(&mut c.sampler, Sampler::Independent, "independent");
        });
        // The same image either way: only the speed differs (docs/performance.md).
        ui.horizontal(|ui| {
            ui.label("kernels").on_hover_text(
                "megakernel: one kernel per camera sample; wavefront: light samples, then the \
                 direction samples of the points that take some; auto: whichever measured faster",
            );
            ui.radio_value(&mut c.execution, Execution::Auto, "auto");
            ui.radio_value(&mut c.execution, Execution::Megakernel, "mega");
            ui.radio_value(&mut c.execution, Execution::Wavefront, "wavefront");
        });
        ui.separator();
        ui.heading("Image");
        ui.horizontal(|ui| {
            let label = ui.label("seed");
            ui.add(egui::DragValue::new(&mut c.seed)).labelled_by(label.id);
        });
        ui.horizontal(|ui| {
            let label = ui.label("stop at spp");
            ui.add(egui::DragValue::new(&mut c.max_spp).range(0..=1 << 20))
                .labelled_by(label.id)
                .on_hover_text("0: never stop");
        });
        ui.add(egui::Slider::new(&mut c.resolution_scale, 0.25..=2.0).text("resolution"));
        ui.add(egui::Slider::new(&mut c.exposure, -8.0..=8.0).text("exposure"));
        ui.checkbox(&mut c.hide_emitters, "hide emitters");
        ui.label("view");
        let mut view = c.view;
        for v in View::ALL {
            let radio = ui.radio_value(&mut view, v, v.label());
            if v == View::Variance {
                radio.on_hover_text(
                    "each pixel's standard error from its sample variance: the error of its mean with \
                     independent samples; with Sobol samples an over-estimate wherever stratification helps",
                );
            }
        }
        let exposure_or_view_changed = view != c.view;
        c.view = view;
        let (w, h) = (
            (self.options.settings.width as f32 * c.resolution_scale).round() as u32,
            (self.options.settings.height as f32 * c.resolution_scale).round() as u32,
        );
        ui.label(format!("{w} x {h} pixels"));
        if exposure_or_view_changed || ui.ctx().input(|i| i.pointer.any_released()) {
            let ctx = ui.ctx().clone();
            self.refresh_texture(&ctx);
        }

        ui.separator();
        ui.heading("Camera");
        ui.label("drag: orbit · right/middle drag: pan · wheel: zoom");
        ui.label("keys: arrows orbit, +/- zoom, R reset");
        if ui.button("reset camera").clicked() {
            self.orbit.reset();
        }

        ui.separator();
        ui.heading("Files");
        if let Some(path) = path_row(ui, "scene", &mut self.scene_path_text, "open") {
            let result = self.open_scene(&path);
            self.report(result, format!("opened {}", path.display()));
        }
        if let Some(path) = path_row(ui, "image file", &mut self.save_path_text, "save image") {
            let result = self.save_image(&path);
            self.report(result, format!("saved {}", path.display()));
        }
        if let Some(path) = path_row(ui, "curves file", &mut self.curves_path_text, "save curves") {
            let result = self.curves.write_csv(&path);
            self.report(result, format!("saved {}", path.display()));
        }
        if let Some(path) = path_row(ui, "reference", &mut self.reference_path_text, "load reference") {
            let result = self.load_reference(&path);
            self.report(result, format!("reference: {}", path.display()));
        }
        let button = egui::Button::new(format!("render reference ({REFERENCE_SPP} spp)"));
        if ui.add_enabled(!self.rendering_reference, button).clicked() {
            self.rendering_reference = true;
            self.status = "rendering the reference…".into();
        }
    }

    fn statistics_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            if let (Some(acc), Some(out)) = (self.session.accumulation(), self.session.latest()) {
                // Wall clock (it also counts the UI's drawing queued before a dispatch): under
                // eframe on lavapipe the GPU timestamps read far too low to be used.
                let seconds = out.render_time.as_secs_f64();
                let spp = out.mean_samples();
                let rate = |v: f64| if seconds > 0.0 { v / seconds } else { 0.0 };
                let what = if self.rendering_reference { "reference" } else { "spp" };
                ui.label(format!("{what} {spp:.1} ({} complete)", acc.complete_samples()));
                ui.separator();
                ui.label(format!(
                    "{:.1} spp/s · {:.2} s · {:.2} Mrays/s",
                    rate(spp),
                    seconds,
                    rate(out.rays as f64) / 1e6
                ));
                if out.nonfinite_samples > 0 {
                    ui.separator();
                    ui.colored_label(Color32::YELLOW, format!("{} non-finite samples dropped", out.nonfinite_samples));
                }
            } else {
                ui.label("starting…");
            }
        });
        ui.label(format!("scene: {}", self.session.loaded.path.display()));
        let baked = match self.session.loaded.gpu.baked_triangles() {
            0 => String::new(),
            n => format!(" · {n} triangles compiled into the kernel"),
        };
        ui.label(format!("features: {}{baked}", self.session.loaded.gpu.features.describe()));
        let shape = match &self.current {
            Some((s, _))
                if veach::kernel_plan::runs_wavefront(
                    &self.session.loaded.gpu.features,
                    s,
                    self.session.renderer.gpu.auto_execution(),
                ) =>
            {
                "wavefront"
            }
            Some(_) => "megakernel",
            None => "none yet",
        };
        ui.label(format!(
            "adapter: {} · kernels compiled: {} · running: {shape}",
            self.session.renderer.gpu.describe(),
            self.session.renderer.cached_kernels()
        ));
        if !self.status.is_empty() {
            let colour = if self.status.starts_with("error") { Color32::LIGHT_RED } else { ui.visuals().text_color() };
            ui.colored_label(colour, &self.status);
        }
        self.plot_ui(ui);
    }

    fn plot_ui(&mut self, ui: &mut egui::Ui) {
        let (w, h) = self.current.as_ref().map(|(s, _)| (s.width, s.height)).unwrap_or((0, 0));
        if let Some(problem) = self.curves.mismatch(w, h) {
            ui.label(format!("relMSE plot: {problem}"));
            return;
        }
        if let Some(r) = &self.curves.reference {
            ui.label(format!("relMSE against {} (log-log)", r.source));
        }
        let log10 =
            |mark: egui_plot::GridMark, _: &std::ops::RangeInclusive<f64>| format!("{:.3}", 10f64.powf(mark.value));
        egui_plot::Plot::new("relmse against time")
            .legend(egui_plot::Legend::default())
            .x_axis_label("seconds")
            .y_axis_label("relMSE")
            .x_axis_formatter(log10)
            .y_axis_formatter(log10)
            .show(ui, |plot| {
                for curve in &self.curves.curves {
                    let points: Vec<[f64; 2]> = curve
                        .points
                        .iter()
                        .filter(|p| p.seconds > 0.0 && p.relmse > 0.0)
                        .map(|p| [p.seconds.log10(), p.relmse.log10()])
                        .collect();
                    plot.line(egui_plot::Line::new(curve.label.clone(), points));
                }
            });
    }

    fn image_ui(&mut self, ui: &mut egui::Ui) {
        let Some(texture) = &self.texture else {
            ui.centered_and_justified(|ui| ui.label("compiling the kernel and rendering the first samples…"));
            return;
        };
        let avail = ui.available_size();
        let tex = texture.size_vec2();
        let fit = (avail.x / tex.x).min(avail.y / tex.y).max(0.01);
        let response = ui
            .centered_and_justified(|ui| {
                ui.add(egui::Image::new(texture).fit_to_exact_size(tex * fit).sense(egui::Sense::click_and_drag()))
            })
            .inner;
        let delta = response.drag_delta();
        if response.dragged_by(egui::PointerButton::Primary) && delta != egui::Vec2::ZERO {
            self.orbit.orbit(delta.x * 0.01, delta.y * 0.01);
        } else if (response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle))
            && delta != egui::Vec2::ZERO
        {
            let height = response.rect.height().max(1.0);
            self.orbit.pan(-delta.x / height, delta.y / height);
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.orbit.zoom((-scroll * 0.002).exp());
            }
        }
    }

    fn handle_keys(&mut self, ctx: &egui::Context) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        let step = 5f32.to_radians();
        ctx.input(|i| {
            use egui::Key;
            if i.key_pressed(Key::ArrowLeft) {
                self.orbit.orbit(-step, 0.0);
            }
            if i.key_pressed(Key::ArrowRight) {
                self.orbit.orbit(step, 0.0);
            }
            if i.key_pressed(Key::ArrowUp) {
                self.orbit.orbit(0.0, step);
            }
            if i.key_pressed(Key::ArrowDown) {
                self.orbit.orbit(0.0, -step);
            }
            if i.key_pressed(Key::Plus) || i.key_pressed(Key::Equals) {
                self.orbit.zoom(0.9);
            }
            if i.key_pressed(Key::Minus) {
                self.orbit.zoom(1.0 / 0.9);
            }
            if i.key_pressed(Key::R) {
                self.orbit.reset();
            }
        });
    }

    fn handle_dropped_files(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw.dropped_files.iter().map(|f| f.path().to_owned()).filter(|p| !p.as_os_str().is_empty()).collect()
        });
        for path in dropped {
            let is_image = path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("exr") || e.eq_ignore_ascii_case("pfm"));
            let result = if is_image { self.load_reference(&path) } else { self.open_scene(&path) };
            self.report(result, format!("opened {}", path.display()));
        }
    }

    /// `--screenshot FILE --frames N`: after N frames ask the window for a screenshot; the
    /// callback saves it and closes the window.
    fn screenshot(&mut self, ctx: &egui::Context) {
        let Some((path, frames)) = self.options.screenshot.clone() else { return };
        if self.screenshot_requested {
            return;
        }
        if self.frames >= frames as u64 {
            self.screenshot_requested = true;
            let window = ctx.clone();
            let callback = egui::ScreenshotCallback::new(move |image| {
                match save_colour_image(&path, &image) {
                    Ok(()) => eprintln!("screenshot: {}", path.display()),
                    Err(e) => eprintln!("error: {e}"),
                }
                window.send_viewport_cmd(egui::ViewportCommand::Close);
                window.request_repaint();
            });
            ctx.send_viewport_cmd(egui::ViewportCommand::Screenshot(callback));
        }
        ctx.request_repaint();
    }
}

/// A labelled path field with a button; the path when the button was clicked.
fn path_row(ui: &mut egui::Ui, label: &str, text: &mut String, button: &str) -> Option<PathBuf> {
    ui.horizontal(|ui| {
        let label = ui.label(label);
        ui.add(egui::TextEdit::singleline(text).desired_width(170.0)).labelled_by(label.id);
        ui.button(button).clicked().then(|| PathBuf::from(text.trim()))
    })
    .inner
}

/// Sample counts per camera sample when a strategy is picked in the viewer: two samples of the
/// strategy's kind (1 + 1 for MIS), so strategies compare at about equal cost per frame.
pub fn interactive_sample_counts(strategy: Strategy) -> (u32, u32) {
    match strategy {
        Strategy::Uniform | Strategy::Brdf => (0, 2),
        Strategy::Light => (2, 0),
        Strategy::Mis | Strategy::MisLobes => (1, 1),
    }
}

/// Why `settings` cannot render (a strategy with no samples of its kind), if so.
fn sample_count_problem(s: &RenderSettings) -> Option<String> {
    let problem = match s.strategy {
        Strategy::Uniform | Strategy::Brdf => s.brdf_samples == 0,
        Strategy::Light => s.light_samples == 0,
        Strategy::Mis => s.light_samples + s.brdf_samples == 0,
        Strategy::MisLobes => s.light_samples == 0,
    };
    problem.then(|| format!("{} needs at least one sample of its kind per camera sample", s.strategy.name()))
}

/// Writes a window screenshot as PNG, whole or not at all.
pub fn save_colour_image(path: &Path, image: &ColorImage) -> veach::Result<()> {
    let [w, h] = image.size;
    let rgba: Vec<u8> = image.pixels.iter().flat_map(|p| p.to_array()).collect();
    veach::image_io::write_atomically(path, |f| {
        image::write_buffer_with_format(
            f,
            &rgba,
            w as u32,
            h as u32,
            image::ExtendedColorType::Rgba8,
            image::ImageFormat::Png,
        )
        .map_err(|e| e.to_string())
    })
}
