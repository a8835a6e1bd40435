//! veach: direct illumination on the GPU, with every classic Monte Carlo strategy.
//!
//! Pipeline: `scene` (glTF → triangles, materials, lights, cameras) → `bvh` → `gpu`
//! (buffers in the layout of `shaders/layout.wgsl`) → `render` (WGSL compute kernels composed
//! by `shaders`) → `image_io`.

pub mod accumulation;
pub mod alias;
pub mod bvh;
pub mod control_variate;
pub mod error;
pub mod features;
pub mod gpu;
pub mod headless;
pub mod image_io;
pub mod kernel_plan;
pub mod light_tree;
pub mod lit_boxes;
pub mod output;
pub mod render;
pub mod scene;
pub mod settings;
pub mod shaders;
pub mod stats;

pub use accumulation::Accumulation;
pub use error::{Error, Result};
pub use gpu::context::GpuContext;
pub use output::RenderOutput;
pub use render::{BvhMemory, GpuScene, Renderer};
pub use scene::{Scene, load_gltf};
pub use settings::{Execution, Heuristic, LightSampling, LightSelection, RenderSettings, Sampler, Strategy};
