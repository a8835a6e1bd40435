//! Runs `shaders/test_kernels.wgsl`: the renderer's own WGSL sampling routines on inputs a test
//! chooses, so that statistical tests check the code that renders rather than a copy of it.

use super::bindings::{self, DeclaredBindings};
use super::bvh_nodes::BVH_STACK_SIZE;
use super::layout::{FrameParams, TestParams};
use crate::error::{Error, Result};
use crate::features::SceneArrayMemory;
use crate::gpu::baked_triangles::BakedTriangles;
use crate::gpu::readback::read_buffer;
use crate::render::{GpuScene, Kernel, Renderer};
use crate::shaders;
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;

/// Routine codes of `test_kernels.wgsl`.
pub mod routine {
    pub const SAMPLE_UNIFORM: u32 = 0;
    pub const SAMPLE_COSINE: u32 = 1;
    pub const SAMPLE_GGX_VNDF: u32 = 2;
    pub const SAMPLE_BSDF: u32 = 3;
    pub const SAMPLE_LIGHT: u32 = 4;
    pub const SELECT_LIGHT: u32 = 5;
    pub const SAMPLE_STREAM: u32 = 6;
    pub const PDF_UNIFORM: u32 = 10;
    pub const PDF_COSINE: u32 = 11;
    pub const PDF_GGX_VNDF: u32 = 12;
    pub const PDF_BSDF: u32 = 13;
    pub const PDF_LIGHT: u32 = 14;
    pub const EVAL_BSDF: u32 = 20;
    pub const MIS_WEIGHTS: u32 = 21;
    pub const DECODE_NORMAL: u32 = 22;
    pub const TEXTURE_LOOKUP: u32 = 30;
    pub const TEXTURED_MATERIAL: u32 = 31;
    pub const TRACE: u32 = 40;
    pub const TRACE_CAMERA: u32 = 41;
}

/// The test kernels. They bind a scene's arrays as its render kernels do, so each is compiled
/// for where the arrays of the scenes it runs on are (`SceneArrayMemory`), at its first run on
/// one.
pub struct TestKernel<'a> {
    renderer: &'a Renderer,
    /// Triangles compiled in instead of the BVH (`for_baked_scene`).
    baked: Option<Arc<BakedTriangles>>,
    bvh_stack: u32,
    kernels: Mutex<Vec<(SceneArrayMemory, Arc<Kernel>)>>,
}

const WORKGROUP: u32 = 64;

impl<'a> TestKernel<'a> {
    /// The test kernels with the traversal stack of most scenes (`BVH_STACK_SIZE`). Nothing is
    /// compiled yet: `run` compiles a kernel for its scene's arrays and returns what fails.
    pub fn new(renderer: &'a Renderer) -> Result<Self> {
        Ok(TestKernel { renderer, baked: None, bvh_stack: BVH_STACK_SIZE, kernels: Mutex::default() })
    }

    /// The test kernels with the traversal stack `scene`'s BVH needs.
    pub fn for_scene(renderer: &'a Renderer, scene: &GpuScene) -> Result<Self> {
        Ok(TestKernel { bvh_stack: scene.bvh_stack(), ..Self::new(renderer)? })
    }

    /// The test kernels over `scene`'s triangles compiled in (traverse_baked.wgsl), camera list
    /// included where the scene has one; an error for a scene that traverses a BVH.
    pub fn for_baked_scene(renderer: &'a Renderer, scene: &GpuScene) -> Result<Self> {
        let baked = scene.baked.clone().ok_or_else(|| Error::Gpu("the scene's triangles are not baked".into()))?;
        Ok(TestKernel { baked: Some(baked), ..Self::new(renderer)? })
    }

    /// The kernel for scenes whose arrays are in `arrays`, compiled now if it is not yet.
    fn kernel(&self, arrays: SceneArrayMemory) -> Result<Arc<Kernel>> {
        let mut kernels = self.kernels.lock().expect("test kernels");
        if let Some((_, k)) = kernels.iter().find(|(a, _)| *a == arrays) {
            return Ok(k.clone());
        }
        let declared = DeclaredBindings { arrays, bvh_stack: self.bvh_stack, ..DeclaredBindings::plain() };
        let (mut pipelines, layout) = bindings::create_pipelines(
            &self.renderer.gpu.device,
            "veach test kernels",
            shaders::test_kernel_source(self.baked.as_deref(), &declared),
            &[shaders::TEST_ENTRY_POINT],
            bindings::ExtraBindings {
                arrays,
                textures: true,
                deferred: false,
                test_io: true,
                footprints: false,
                emitter_grid: false,
            },
            &[],
        )
        .map_err(Error::Gpu)?;
        let kernel = Arc::new(Kernel {
            textures: true,
            texel_arrays: arrays.texels,
            emitter_grid: false,
            pipeline: pipelines.remove(0),
            wavefront: None,
            layout,
        });
        kernels.push((arrays, kernel.clone()));
        Ok(kernel)
    }

    /// Runs `params.routine` over `params.count` items; returns `outputs_per_item` vec4s per item.
    pub fn run(
        &self,
        scene: &GpuScene,
        frame: &FrameParams,
        params: &TestParams,
        input: &[[f32; 4]],
        outputs_per_item: usize,
    ) -> Result<Vec<[f32; 4]>> {
        let device = &self.renderer.gpu.device;
        let queue = &self.renderer.gpu.queue;
        let uniform = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage })
        };
        let storage = |label: &str, bytes: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16),
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let frame_buffer = uniform("test frame", bytemuck::bytes_of(frame), wgpu::BufferUsages::STORAGE);
        let params_buffer = uniform("test params", bytemuck::bytes_of(params), wgpu::BufferUsages::UNIFORM);
        let input_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("test input"),
            contents: if input.is_empty() { &[0u8; 16] } else { bytemuck::cast_slice(input) },
            usage: wgpu::BufferUsages::STORAGE,
        });
        let out_bytes = params.count as u64 * outputs_per_item as u64 * 16;
        let output = storage("test output", out_bytes, wgpu::BufferUsages::COPY_SRC);
        let unused: Vec<wgpu::Buffer> =
            (0..bindings::OUTPUT_COUNT).map(|_| storage("unused", 16, wgpu::BufferUsages::empty())).collect();
        let outputs = [&unused[0], &unused[1], &unused[2], &unused[3], &unused[4]];
        let kernel = self.kernel(scene.arrays)?;
        let bind_group = self.renderer.bind_group(
            &kernel,
            &frame_buffer,
            scene,
            &outputs,
            &[
                (bindings::TEST_PARAMS, &params_buffer),
                (bindings::TEST_INPUT, &input_buffer),
                (bindings::TEST_OUTPUT, &output),
            ],
        );
        let groups = params.count.div_ceil(WORKGROUP);
        let max = device.limits().max_compute_workgroups_per_dimension;
        let (gx, gy) = if groups <= max { (groups, 1) } else { (max, groups.div_ceil(max)) };
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&kernel.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        queue.submit([encoder.finish()]);
        let mut out: Vec<[f32; 4]> = read_buffer(device, queue, &output)?;
        out.truncate(params.count as usize * outputs_per_item);
        Ok(out)
    }
}
