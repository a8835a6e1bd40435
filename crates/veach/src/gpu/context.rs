//! Adapter and device: a real GPU when there is one, otherwise a software rasteriser such as
//! lavapipe. `VEACH_ADAPTER` (a substring of the adapter name) picks one explicitly.

use crate::error::{Error, Result};

#[derive(Clone)]
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    /// Timestamp queries are available (used for timing renders without host overhead).
    pub has_timestamps: bool,
    /// `VEACH_WORKGROUP`: the workgroup of the kernels that take a pixel each, as (columns,
    /// rows), in place of `render_workgroup`'s choice.
    pub workgroup_override: Option<(u32, u32)>,
}

fn preference(info: &wgpu::AdapterInfo) -> u32 {
    match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

impl GpuContext {
    pub fn new(adapter_filter: Option<&str>) -> Result<GpuContext> {
        pollster::block_on(Self::new_async(adapter_filter))
    }

    async fn new_async(adapter_filter: Option<&str>) -> Result<GpuContext> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // Compute kernels need Vulkan, Metal or DX12; WGPU_BACKEND may still narrow this down.
        if std::env::var_os("WGPU_BACKEND").is_none() {
            desc.backends = wgpu::Backends::PRIMARY;
        }
        let instance = wgpu::Instance::new(desc);
        let adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
        let adapter = Self::choose_adapter(adapters, adapter_filter)?;
        let info = adapter.get_info();
        let (device, queue) = adapter
            .request_device(&Self::device_descriptor(&adapter))
            .await
            .map_err(|e| Error::Gpu(format!("cannot open device on {}: {e}", info.name)))?;
        Self::from_device(&adapter, device, queue)
    }

    /// What veach asks of a device: the adapter's own limits (the defaults allow only 8
    /// storage buffers per stage), and timestamp queries where there are any. The viewer asks
    /// eframe for a device with this, so that the window and the renderer share one.
    pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
        let mut required_features = wgpu::Features::empty();
        if adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            required_features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        wgpu::DeviceDescriptor {
            label: Some("veach"),
            required_features,
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }
    }

    /// A context on a device opened elsewhere (the viewer's window), checked against what the
    /// kernels bind.
    pub fn from_device(adapter: &wgpu::Adapter, device: wgpu::Device, queue: wgpu::Queue) -> Result<GpuContext> {
        let info = adapter.get_info();
        let storage = device.limits().max_storage_buffers_per_shader_stage;
        if storage < crate::gpu::bindings::STORAGE_BUFFERS_NEEDED {
            return Err(Error::Gpu(format!(
                "the device on {} allows {storage} storage buffers per shader stage; veach's kernels bind {}",
                info.name,
                crate::gpu::bindings::STORAGE_BUFFERS_NEEDED
            )));
        }
        let has_timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let workgroup_override = match std::env::var("VEACH_WORKGROUP") {
            Ok(text) => Some(parse_workgroup(&text, &device.limits())?),
            Err(_) => None,
        };
        Ok(GpuContext { device, queue, adapter_info: info, has_timestamps, workgroup_override })
    }

    /// Adapters in veach's order of preference (a discrete GPU first, a software one last),
    /// narrowed to those whose name contains `filter` (or `VEACH_ADAPTER`).
    pub fn choose_adapter(mut adapters: Vec<wgpu::Adapter>, filter: Option<&str>) -> Result<wgpu::Adapter> {
        let filter = filter.map(str::to_owned).or_else(|| std::env::var("VEACH_ADAPTER").ok());
        if let Some(f) = &filter {
            let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&f.to_lowercase()));
            if adapters.is_empty() {
                return Err(Error::Gpu(format!("no adapter matches '{f}'; available: {}", names.join(", "))));
            }
        }
        adapters.sort_by_key(|a| preference(&a.get_info()));
        adapters.into_iter().next().ok_or(Error::NoAdapter)
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)"
    pub fn describe(&self) -> String {
        format!("{} ({:?}, {:?})", self.adapter_info.name, self.adapter_info.backend, self.adapter_info.device_type)
    }

    /// Whether the adapter is a CPU (lavapipe): small arrays become uniform buffers and the frame's
    /// parameters a private copy there (`render.rs`, `KernelPlan::frame_copy`).
    pub fn is_cpu(&self) -> bool {
        self.adapter_info.device_type == wgpu::DeviceType::Cpu
    }

    /// Threads per workgroup of the kernels that take a pixel each (`render`, and
    /// `render_light_pass` where `wavefront`), as (columns, rows): what measured fastest on the
    /// driver. NVIDIA's (an H200, driver 580; docs/performance.md, "On a GPU"): 16×16 for the
    /// megakernel (0.92-0.98x 8×8's time), 32×8 for the wavefront (0.87-0.93x). Elsewhere 8×8;
    /// lavapipe runs 16×16 no faster. `VEACH_WORKGROUP` overrides both.
    pub fn render_workgroup(&self, wavefront: bool) -> (u32, u32) {
        if let Some(size) = self.workgroup_override {
            return size;
        }
        match (self.adapter_info.driver == crate::kernel_plan::NVIDIA_DRIVER, wavefront) {
            (true, false) => (16, 16),
            (true, true) => (32, 8),
            (false, _) => crate::gpu::layout::WORKGROUP_SIZE,
        }
    }

    /// What a kernel plan needs to know of this adapter (`KernelPlan::for_render`).
    pub fn profile(&self) -> crate::kernel_plan::AdapterProfile {
        let limits = self.device.limits();
        crate::kernel_plan::AdapterProfile {
            auto: self.auto_execution(),
            cpu: self.is_cpu(),
            storage_buffers_per_stage: limits.max_storage_buffers_per_shader_stage,
            max_binding: limits.max_storage_buffer_binding_size,
            workgroups: [self.render_workgroup(false), self.render_workgroup(true)],
        }
    }

    /// What `--execution auto` picks on this driver.
    pub fn auto_execution(&self) -> crate::kernel_plan::AutoExecution {
        crate::kernel_plan::AutoExecution::for_adapter(&self.adapter_info)
    }

    /// The driver and its version, e.g. "llvmpipe, Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)": lavapipe's
    /// adapter name ("llvmpipe (LLVM 15.0.6, 256 bits)") is the same across Mesa releases that
    /// differ 1.4-3x in speed.
    pub fn driver(&self) -> String {
        let info = &self.adapter_info;
        match (info.driver.is_empty(), info.driver_info.is_empty()) {
            (false, false) => format!("{}, {}", info.driver, info.driver_info),
            (false, true) => info.driver.clone(),
            (true, false) => info.driver_info.clone(),
            (true, true) => "driver unknown".to_string(),
        }
    }
}

/// `VEACH_WORKGROUP`, "COLUMNSxROWS" (e.g. "16x8"): the render kernels' workgroup, for measuring
/// which size a GPU runs fastest (scripts/gpu-rays.sh), checked against the device's limits.
fn parse_workgroup(text: &str, limits: &wgpu::Limits) -> Result<(u32, u32)> {
    let bad = |why: String| Error::Options(format!("VEACH_WORKGROUP={text:?}: {why}"));
    let (w, h) = text.split_once('x').ok_or_else(|| bad("expected COLUMNSxROWS, e.g. 16x8".into()))?;
    let parse = |s: &str| s.trim().parse::<u32>().ok().filter(|&n| n > 0);
    let (w, h) = parse(w).zip(parse(h)).ok_or_else(|| bad("expected two positive whole numbers".into()))?;
    if w > limits.max_compute_workgroup_size_x
        || h > limits.max_compute_workgroup_size_y
        || w * h > limits.max_compute_invocations_per_workgroup
    {
        return Err(bad(format!(
            "this device allows at most {}x{} and {} threads per workgroup",
            limits.max_compute_workgroup_size_x,
            limits.max_compute_workgroup_size_y,
            limits.max_compute_invocations_per_workgroup
        )));
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::parse_workgroup;

    #[test]
    fn workgroup_sizes_are_parsed_and_held_to_the_limits() {
        let limits = wgpu::Limits::default();
        assert_eq!(parse_workgroup("16x8", &limits).unwrap(), (16, 8));
        for bad in ["16", "0x8", "ax8", "32x32", "512x1"] {
            assert!(parse_workgroup(bad, &limits).is_err(), "{bad} was accepted");
        }
    }
}
