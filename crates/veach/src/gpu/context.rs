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
        let mut adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
        let filter = adapter_filter.map(str::to_owned).or_else(|| std::env::var("VEACH_ADAPTER").ok());
        if let Some(f) = &filter {
            let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&f.to_lowercase()));
            if adapters.is_empty() {
                return Err(Error::Gpu(format!("no adapter matches '{f}'; available: {}", names.join(", "))));
            }
        }
        adapters.sort_by_key(|a| preference(&a.get_info()));
        let adapter = adapters.into_iter().next().ok_or(Error::NoAdapter)?;
        let info = adapter.get_info();
        let has_timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let mut required_features = wgpu::Features::empty();
        if has_timestamps {
            required_features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        // Ask for what the adapter offers: the defaults allow only 8 storage buffers per stage.
        let required_limits = adapter.limits();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("veach"),
                required_features,
                required_limits,
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| Error::Gpu(format!("cannot open device on {}: {e}", info.name)))?;
        Ok(GpuContext { device, queue, adapter_info: info, has_timestamps })
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)"
    pub fn describe(&self) -> String {
        format!("{} ({:?}, {:?})", self.adapter_info.name, self.adapter_info.backend, self.adapter_info.device_type)
    }
}
