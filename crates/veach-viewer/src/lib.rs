//! The veach viewer: eframe/egui on the renderer's own wgpu device, rendering progressively
//! with strategy toggles, contribution views and a live error plot. `veach view SCENE` runs it.
//!
//! Layout: `session` (the scene on the GPU and the accumulating image) → `display` (what each
//! view shows) → `app` (the window) with `orbit` (camera controls) and `curves` (error plot).

pub mod app;
pub mod curves;
pub mod display;
pub mod orbit;
pub mod session;

pub use app::{ViewerApp, ViewerOptions};

use std::sync::{Arc, Mutex};
use veach::{GpuContext, Renderer};

struct EframeApp(ViewerApp);

impl eframe::App for EframeApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.0.show(ui);
    }
}

/// Opens the window and runs until it is closed. `adapter` narrows the adapter by name (as
/// `VEACH_ADAPTER` does); the window and the renderer share the device eframe opens with the
/// limits and features `GpuContext::device_descriptor` asks for.
pub fn run(options: ViewerOptions, adapter: Option<String>) -> Result<(), String> {
    let mut setup = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    // Compute kernels need Vulkan, Metal or DX12.
    setup.instance_descriptor.backends = wgpu::Backends::PRIMARY;
    setup.device_descriptor = Arc::new(GpuContext::device_descriptor);
    let chooser_error = Arc::new(Mutex::new(None::<String>));
    let report = chooser_error.clone();
    setup.native_adapter_selector = Some(Arc::new(move |adapters, _surface| {
        GpuContext::choose_adapter(adapters.to_vec(), adapter.as_deref()).map_err(|e| {
            let message = e.to_string();
            *report.lock().expect("error slot") = Some(message.clone());
            message
        })
    }));
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title(format!("veach: {}", options.scene.display()))
            .with_inner_size([1100.0, 820.0]),
        renderer: eframe::Renderer::Wgpu,
        wgpu_options: egui_wgpu::WgpuConfiguration {
            wgpu_setup: egui_wgpu::WgpuSetup::CreateNew(setup),
            ..Default::default()
        },
        ..Default::default()
    };
    let result = eframe::run_native(
        "veach",
        native,
        Box::new(move |cc| {
            let state = cc.wgpu_render_state.as_ref().ok_or("eframe did not start its wgpu renderer")?;
            let gpu = GpuContext::from_device(&state.adapter, state.device.clone(), state.queue.clone())?;
            let renderer = Arc::new(Renderer::new(gpu)?);
            Ok(Box::new(EframeApp(ViewerApp::new(renderer, options)?)))
        }),
    );
    result.map_err(|e| match chooser_error.lock().expect("error slot").take() {
        Some(m) => m,
        None => e.to_string(),
    })
}
