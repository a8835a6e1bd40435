//! The renderer: uploads a scene once and compiles the kernels a render needs (headless.rs renders
//! to completion, accumulation.rs runs the dispatches).

use crate::bvh::build_bvh;
use crate::error::{Error, Result};
use crate::features::{SceneArrayMemory, SceneFeatures};
use crate::gpu::baked_triangles::BakedTriangles;
use crate::gpu::bindings;
use crate::gpu::bvh_nodes::gpu_node_count;
use crate::gpu::context::GpuContext;
use crate::gpu::emitter_grid::EmitterGrid;
use crate::gpu::layout::{self, FrameParams};
use crate::gpu::scene_buffers::{SceneArrays, build_scene_arrays};
use crate::kernel_plan::{KernelPlan, runs_branches_masked};
use crate::scene::light_shape::rectangle_lights_seen_wide;

use crate::scene::{Camera, LightKind, Scene};
use crate::settings::{Heuristic, LightSampling, RenderSettings, Sampler, Strategy};
use crate::shaders;
use std::borrow::Cow;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// Timings and sizes of putting a scene on the GPU.
#[derive(Clone, Debug, Default)]
pub struct SceneUploadStats {
    pub bvh_build: Duration,
    /// BVH nodes on the GPU (inner nodes, each with its children's boxes).
    pub bvh_nodes: usize,
    pub bvh_sah_cost: f32,
    /// Triangles in the BVH's leaves, more than the scene's where triangles were split.
    pub bvh_triangle_references: usize,
    pub upload: Duration,
    pub gpu_scene_bytes: u64,
}

/// A scene on the GPU: its BVH, triangles, materials and lights, ready to render with any
/// settings and camera.
pub struct GpuScene {
    /// Where its kernels read the arrays from (see `BvhMemory`).
    pub(crate) arrays: SceneArrayMemory,
    /// bvh_nodes … light_picks (bindings 1-7), then the light tree and triangle_lights, each
    /// once: in a storage texture where `arrays.texels` (the materials excepted), else in a
    /// storage buffer.
    pub(crate) array_bindings: [SceneArray; 9],
    /// The triangles compiled into the kernel instead of a BVH, for small scenes on CPU adapters
    /// (`BvhMemory::Auto`).
    pub(crate) baked: Option<Arc<BakedTriangles>>,
    /// vertex_uvs, texture_infos, texels: only for scenes with textures.
    pub(crate) texture_buffers: Option<[wgpu::Buffer; 3]>,
    pub(crate) light_count: u32,
    pub(crate) emitter_bound: ([f32; 3], f32),
    pub(crate) emitter_box: ([f32; 3], [f32; 3]),
    /// The most entries the BVH's traversal can push (`gpu::bvh_nodes::stack_bound`).
    pub(crate) bvh_stack_bound: u32,
    /// Triangles of area lights (`emitter_tris` before any padding).
    pub(crate) emitter_triangles: u32,
    /// The emitters' grid, for BVH kernels where the driver branches around code no lane runs and
    /// the grid pays (`gpu::emitter_grid`; `KernelPlan::emitter_grid`).
    pub(crate) emitter_grid: Option<wgpu::Buffer>,
    /// The light tree's counts of slots and directional leaves (`crate::light_tree`; its array
    /// holds one zeroed slot where there is no light).
    pub(crate) light_tree_slots: u32,
    pub(crate) directional_lights: u32,
    /// Lights with a lit box (`LightTree::sealed_lights`): where any has one, the tree's array
    /// holds its slots' lit boxes (`LightTree::lit`).
    pub(crate) sealed_lights: u32,
    pub stats: SceneUploadStats,
    /// What the scene needs of the kernel.
    pub features: SceneFeatures,
}

impl GpuScene {
    /// How many triangles specialised kernels test directly instead of traversing the BVH
    /// (`shaders/traverse_baked.wgsl`); 0 where they traverse it.
    pub fn baked_triangles(&self) -> usize {
        self.baked.as_ref().map_or(0, |b| b.len())
    }

    /// Triangles of area lights.
    pub fn light_count(&self) -> u32 {
        self.light_count
    }

    pub fn emitter_triangles(&self) -> u32 {
        self.emitter_triangles
    }

    /// The light tree's slot count and the directional lights after them (FrameParams'
    /// light_tree_slots and directional_lights).
    pub fn light_tree_counts(&self) -> (u32, u32) {
        (self.light_tree_slots, self.directional_lights)
    }

    /// Whether the light tree's array holds lit boxes (FrameParams' light_tree_lit_boxes).
    pub fn light_tree_lit_boxes(&self) -> bool {
        self.sealed_lights > 0
    }

    /// Lights sealed in closed surfaces, which the tree gives no samples outside them
    /// (`crate::lit_boxes`).
    pub fn sealed_lights(&self) -> u32 {
        self.sealed_lights
    }

    /// The most entries the BVH's traversal can push on its stack.
    pub fn bvh_stack_bound(&self) -> u32 {
        self.bvh_stack_bound
    }

    /// What a kernel plan needs to know of it (`KernelPlan::for_render`).
    pub fn uploaded(&self) -> crate::kernel_plan::UploadedScene<'_> {
        crate::kernel_plan::UploadedScene {
            features: &self.features,
            bvh_stack: self.bvh_stack(),
            arrays: self.arrays,
            baked: self.baked.as_ref(),
            emitter_grid: self.emitter_grid.is_some(),
            lit_boxes: self.light_tree_lit_boxes(),
        }
    }

    /// The traversal stack its kernels need (`KernelPlan::bvh_stack`).
    pub fn bvh_stack(&self) -> u32 {
        crate::gpu::bvh_nodes::stack_size_for(self.bvh_stack_bound)
    }
}

/// A compiled kernel and its bind group layout. Creating one includes the driver's compile,
/// which lavapipe does at the first dispatch; `Renderer::render` reports it as
/// `RenderOutput::kernel_creation`, outside the render time.
pub(crate) struct Kernel {
    pub(crate) textures: bool,
    /// It reads the scene's arrays from storage textures (`SceneArray::Texels`).
    pub(crate) texel_arrays: bool,
    /// It reads the emitters' grid (`KernelPlan::emitter_grid`).
    pub(crate) emitter_grid: bool,
    /// `render`, or the wavefront's first kernel (`render_light_pass`)...
    pub(crate) pipeline: wgpu::ComputePipeline,
    /// ...followed by `prepare_direction_pass` and `render_direction_pass`.
    pub(crate) wavefront: Option<(wgpu::ComputePipeline, wgpu::ComputePipeline)>,
    pub(crate) layout: wgpu::BindGroupLayout,
}

/// The kernels on a device: the generic one, compiled up front, and the ones specialised to a
/// scene's features and a strategy (`kernel_plan::KernelPlan`), compiled at first use and cached,
/// so that switching back to a strategy used before compiles nothing.
pub struct Renderer {
    pub gpu: GpuContext,
    kernels: Mutex<HashMap<KernelPlan, Arc<Kernel>>>,
}

fn storage_buffer<T: bytemuck::Pod + Default>(device: &wgpu::Device, label: &str, data: &[T]) -> wgpu::Buffer {
    storage_bytes(device, label, &array_bytes(data), wgpu::BufferUsages::empty())
}

/// A storage buffer of `bytes` that may also be bound as `also`.
fn storage_bytes(device: &wgpu::Device, label: &str, bytes: &[u8], also: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage: wgpu::BufferUsages::STORAGE | also,
    })
}

/// An array's bytes, or one zeroed element's where it is empty (bindings may not be empty).
fn array_bytes<T: bytemuck::Pod + Default>(data: &[T]) -> Cow<'_, [u8]> {
    match data.is_empty() {
        true => Cow::Owned(bytemuck::bytes_of(&T::default()).to_vec()),
        false => Cow::Borrowed(bytemuck::cast_slice(data)),
    }
}

/// One scene array as the kernels bind it.
pub(crate) enum SceneArray {
    Buffer(wgpu::Buffer),
    /// On CPU adapters (`SceneArrayMemory::texels`): the array's 16-byte words as texels.
    Texels {
        view: wgpu::TextureView,
        bytes: u64,
    },
}

impl SceneArray {
    fn resource(&self) -> wgpu::BindingResource<'_> {
        match self {
            SceneArray::Buffer(b) => b.as_entire_binding(),
            SceneArray::Texels { view, .. } => wgpu::BindingResource::TextureView(view),
        }
    }

    fn bytes(&self) -> u64 {
        match self {
            SceneArray::Buffer(b) => b.size(),
            SceneArray::Texels { bytes, .. } => *bytes,
        }
    }
}

/// `GpuScene::array_bindings`' entries after the arrays of bindings 1-7.
const LIGHT_TREE_ARRAY: usize = 7;
const TRIANGLE_LIGHTS_ARRAY: usize = 8;

/// Rows of TEXEL_ROW 16-byte texels that `bytes` take (at least one).
fn texel_rows(bytes: usize) -> u32 {
    (bytes.div_ceil(16).div_ceil(bindings::TEXEL_ROW as usize)).max(1) as u32
}

/// The bytes of `texel_array`'s texture for an array of `bytes`: whole rows.
fn texel_array_bytes(bytes: usize) -> usize {
    texel_rows(bytes) as usize * bindings::TEXEL_ROW as usize * 16
}

/// An `rgba32uint` storage texture of `bytes` (a multiple of 16), TEXEL_ROW texels a row, the last
/// row padded with zeros: how CPU adapters read a scene array (`SceneArrayMemory::texels`).
pub fn texel_array(device: &wgpu::Device, queue: &wgpu::Queue, label: &str, bytes: &[u8]) -> wgpu::TextureView {
    let rows = texel_rows(bytes.len());
    let mut padded = bytes.to_vec();
    padded.resize(texel_array_bytes(bytes.len()), 0);
    let texture = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: bindings::TEXEL_ROW, height: rows, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Uint,
            usage: wgpu::TextureUsages::STORAGE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        &padded,
    );
    texture.create_view(&Default::default())
}

/// Where the kernels read the scene's arrays (BVH, vertices, triangles, materials, lights,
/// emitter triangles, light picks) from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BvhMemory {
    /// On CPU adapters, every array read through a reader function in a read-only storage
    /// texture, and the materials in a uniform buffer where they fit: Mesa 22.3's lavapipe loads a
    /// storage buffer's word lane by lane, each through the stack, and gathers a storage texture's
    /// texels, faster than a uniform array's elements (docs/performance.md, "Scene arrays in
    /// storage textures"). GPUs keep storage buffers.
    Auto,
    /// A storage buffer, whatever its size and adapter (`veach scale`, so that its sizes compare
    /// like for like; tests of the path GPUs take).
    Storage,
    /// `Auto`, with a baked scene's compact groups of triangles behind boxes and its emitter list
    /// whatever the driver (`BakedTriangles`): for tests, which Mesa 22.3 would otherwise run
    /// without them.
    AutoWithBoxes,
    /// `Storage`, with the emitters' grid whatever the driver and wherever the scene has area
    /// lights, paying or not (`gpu::emitter_grid`): for tests.
    StorageWithEmitterGrid,
}

/// The largest uniform array: 64 KiB, the common `maxUniformBufferRange` (1024 materials).
const UNIFORM_ARRAY_MAX_BYTES: u64 = 64 << 10;

/// The length of an array of `len` elements as a uniform array where it has at most `capacity`,
/// or 0 (it stays in storage). A power of two of at least 64, so that scenes of similar size share
/// a kernel.
fn uniform_length(len: usize, capacity: usize) -> usize {
    if len > capacity {
        return 0;
    }
    len.next_power_of_two().max(64).min(capacity)
}

/// `array` padded with default elements to its `uniform_length`, which is returned (0: storage,
/// unpadded).
fn pad_for_uniform<T: Default + Clone>(array: &mut Vec<T>, capacity: usize) -> u32 {
    let n = uniform_length(array.len(), capacity);
    if n > 0 {
        array.resize(n, T::default());
    }
    n as u32
}

/// `triangle_lights` padded with NO_LIGHT to whole vec4u, four triangles' lights each, as
/// `triangle_light` reads them (`gpu::bindings::wgsl_declarations`).
fn pad_triangle_lights(lights: &mut Vec<u32>) {
    lights.resize(lights.len().div_ceil(4).max(1) * 4, layout::NO_LIGHT);
}

impl Renderer {
    /// A renderer on `gpu`. Kernels are compiled when a render first needs them.
    pub fn new(gpu: GpuContext) -> Result<Renderer> {
        Ok(Renderer { gpu, kernels: Mutex::new(HashMap::new()) })
    }

    /// The kernel for `key`, compiled now if it is not cached (and then also dispatched once,
    /// empty, since drivers such as lavapipe compile at the first dispatch).
    pub(crate) fn kernel(&self, key: &KernelPlan) -> Result<(Arc<Kernel>, bool)> {
        if let Some(k) = self.kernels.lock().expect("kernel cache").get(key) {
            return Ok((k.clone(), false));
        }
        let entry_points: &[&str] =
            if key.wavefront { &shaders::WAVEFRONT_ENTRY_POINTS } else { &[shaders::RENDER_ENTRY_POINT] };
        let extra = bindings::ExtraBindings {
            arrays: key.driver.arrays,
            textures: key.textures.module,
            deferred: key.wavefront,
            test_io: false,
            footprints: key.driver.footprint_slots > 0,
            emitter_grid: key.driver.emitter_grid,
        };
        let source = shaders::render_kernel_source(
            key.textures.module,
            &key.declared_bindings(),
            key.driver.baked.as_deref(),
            key.driver.footprint_slots,
        );
        let constants = shaders::pipeline_constants(&source, &key.constants());
        let (pipelines, layout) = bindings::create_pipelines(
            &self.gpu.device,
            "veach render kernel",
            source,
            entry_points,
            extra,
            &constants,
        )
        .map_err(Error::Gpu)?;
        let mut pipelines = pipelines.into_iter();
        let pipeline = pipelines.next().expect("one pipeline per entry point");
        let wavefront = pipelines.next().zip(pipelines.next());
        let kernel = Arc::new(Kernel {
            textures: key.textures.module,
            texel_arrays: key.driver.arrays.texels,
            emitter_grid: key.driver.emitter_grid,
            pipeline,
            wavefront,
            layout,
        });
        self.kernels.lock().expect("kernel cache").insert(key.clone(), kernel.clone());
        Ok((kernel, true))
    }

    /// Kernels compiled so far.
    pub fn cached_kernels(&self) -> usize {
        self.kernels.lock().expect("kernel cache").len()
    }

    /// Builds the BVH and uploads the scene, its arrays where this adapter reads them best
    /// (`BvhMemory::Auto`).
    pub fn upload_scene(&self, scene: &Scene) -> Result<GpuScene> {
        self.upload_scene_with(scene, BvhMemory::Auto)
    }

    /// Whether the scene's arrays are storage textures (and a small scene's triangles compiled
    /// into the kernel): on a CPU adapter, unless `memory` asks for storage buffers.
    fn cpu_arrays(&self, memory: BvhMemory) -> bool {
        self.gpu.is_cpu() && !matches!(memory, BvhMemory::Storage | BvhMemory::StorageWithEmitterGrid)
    }

    /// Elements of type T a uniform buffer may hold on this adapter, 0 where the arrays stay in
    /// storage buffers (`cpu_arrays`).
    fn uniform_capacity<T>(&self, memory: BvhMemory) -> usize {
        if !self.cpu_arrays(memory) {
            return 0;
        }
        let bytes = self.gpu.device.limits().max_uniform_buffer_binding_size.min(UNIFORM_ARRAY_MAX_BYTES);
        bytes as usize / std::mem::size_of::<T>()
    }

    /// `upload_scene`, with the BVH's memory chosen by the caller.
    pub fn upload_scene_with(&self, scene: &Scene, memory: BvhMemory) -> Result<GpuScene> {
        let max_triangles = crate::gpu::bvh_nodes::MAX_FIRST_TRIANGLE as usize + 1;
        if scene.triangles.len() > max_triangles {
            return Err(Error::Gpu(format!(
                "the scene has {} triangles; BVH leaves can address at most {max_triangles}",
                scene.triangles.len()
            )));
        }
        let cpu_arrays = self.cpu_arrays(memory);
        let bvh = build_bvh(&scene.triangles);
        let mut stats = SceneUploadStats {
            bvh_build: bvh.build_time,
            bvh_nodes: gpu_node_count(&bvh),
            bvh_sah_cost: bvh.sah_cost,
            bvh_triangle_references: bvh.order.len(),
            ..Default::default()
        };
        let upload_start = Instant::now();
        let mut features = SceneFeatures::detect(scene);
        features.rectangle_lights = features.rectangle_lights && rectangle_lights_seen_wide(scene, &bvh);
        let mut arrays: SceneArrays = build_scene_arrays(scene, &features, &bvh);
        // On a CPU adapter (`BvhMemory::Auto`), a small scene's triangles are compiled into the
        // kernel instead.
        // Where the driver branches around untaken code, its compact groups go behind boxes
        // and direction samples search the emitters' list (BakedTriangles::emitter_list).
        let info = &self.gpu.adapter_info;
        let masked = runs_branches_masked(&info.driver, &info.driver_info);
        let branches = memory == BvhMemory::AutoWithBoxes || !masked;
        let group_nodes = if branches { &bvh.nodes[..] } else { &[] };
        let baked =
            if cpu_arrays { BakedTriangles::new(&arrays.vertices, &arrays.triangles, group_nodes) } else { None };
        let baked = baked.map(|mut baked| {
            let directional = scene.lights.iter().any(|l| matches!(l.kind, LightKind::Directional { .. }));
            let delta: Vec<glam::Vec3> = scene
                .lights
                .iter()
                .filter_map(|l| match l.kind {
                    LightKind::Point { position, .. } | LightKind::Spot { position, .. } => Some(position),
                    _ => None,
                })
                .collect();
            baked.mark_blockers(&arrays.triangle_lights, (!directional).then_some(&delta[..]));
            baked.set_emitter_list(branches);
            // For camera rays from the scene's first camera (a render from another, or the
            // viewer's once it moves, takes the closest-hit list: `KernelPlan::camera_list`).
            baked.set_camera_eye(scene.camera(None).ok().map(|c| c.position));
            Arc::new(baked)
        });
        // BVH kernels' direction samples search the emitters' grid where the driver branches
        // around code no lane runs and the grid pays: as baked kernels search their emitters'
        // list, and not on Mesa 22.3 for the same reason (BakedTriangles::set_emitter_list; there
        // it made both ends of `veach scale`'s light sweep slower). Only CPU adapters, where it was
        // measured (docs/performance.md, "The emitters' grid"). Built before the arrays are
        // padded.
        let forced_grid = memory == BvhMemory::StorageWithEmitterGrid;
        let grid_pays_here = self.gpu.is_cpu() && !masked;
        let emitter_grid = (baked.is_none() && (forced_grid || grid_pays_here))
            .then(|| EmitterGrid::build(&arrays.vertices, &arrays.triangles, &arrays.triangle_lights))
            .flatten()
            .filter(|g| forced_grid || g.pays());
        let bvh_stack_bound = crate::gpu::bvh_nodes::stack_bound(&arrays.bvh_nodes);
        let emitter_triangles = arrays.emitter_tris.len() as u32;
        pad_triangle_lights(&mut arrays.triangle_lights);
        let uniform_materials =
            pad_for_uniform(&mut arrays.materials, self.uniform_capacity::<layout::Material>(memory));
        let device = &self.gpu.device;
        // The scene arrays in binding order (bindings 1-7, then the light tree and
        // triangle_lights): label, words. Each is uploaded once: on CPU adapters as a storage
        // texture if every one fits a texture (the materials excepted: bindings::MATERIALS),
        // else as a storage buffer.
        let sources: [(&str, Cow<[u8]>); 9] = [
            ("bvh_nodes", array_bytes(&arrays.bvh_nodes)),
            ("vertices", array_bytes(&arrays.vertices)),
            ("triangles", array_bytes(&arrays.triangles)),
            ("materials", array_bytes(&arrays.materials)),
            ("lights", array_bytes(&arrays.lights)),
            ("emitter_tris", array_bytes(&arrays.emitter_tris)),
            ("light_picks", array_bytes(&arrays.light_picks)),
            ("light tree", array_bytes(&arrays.light_tree.slots)),
            ("triangle_lights", array_bytes(&arrays.triangle_lights)),
        ];
        let max_rows = device.limits().max_texture_dimension_2d;
        let texels = cpu_arrays && sources.iter().all(|(_, bytes)| texel_rows(bytes.len()) <= max_rows);
        let scene_arrays = SceneArrayMemory { uniform_materials, texels };
        let max_binding = device.limits().max_storage_buffer_binding_size;
        let too_big = sources
            .iter()
            .enumerate()
            .filter(|&(k, _)| !texels || k == bindings::MATERIALS)
            .map(|(_, (_, bytes))| bytes.len())
            .find(|&b| b as u64 > max_binding);
        if let Some(bytes) = too_big {
            return Err(Error::Gpu(format!(
                "the scene needs a {} MiB buffer but the adapter allows {} MiB per binding",
                bytes >> 20,
                max_binding >> 20
            )));
        }
        if let Some(t) = &arrays.textures {
            let bytes = std::mem::size_of_val(t.texels.as_slice()) as u64;
            if bytes > max_binding {
                return Err(Error::Gpu(format!(
                    "the scene's {} textures need {} MiB of texels together but the adapter allows {} MiB per \
                     binding; scale the textures down",
                    scene.textures.len(),
                    bytes >> 20,
                    max_binding >> 20
                )));
            }
        }
        let materials_usage =
            if uniform_materials > 0 { wgpu::BufferUsages::UNIFORM } else { wgpu::BufferUsages::empty() };
        let array_bindings = std::array::from_fn(|k| {
            let (label, bytes) = &sources[k];
            if texels && k != bindings::MATERIALS {
                let view = texel_array(device, &self.gpu.queue, label, bytes);
                SceneArray::Texels { view, bytes: texel_array_bytes(bytes.len()) as u64 }
            } else {
                let usage = if k == bindings::MATERIALS { materials_usage } else { wgpu::BufferUsages::empty() };
                SceneArray::Buffer(storage_bytes(device, label, bytes, usage))
            }
        });
        // Scenes without textures upload none: their kernels do not bind any.
        let texture_buffers = arrays.textures.as_ref().map(|t| {
            [
                storage_buffer(device, "vertex_uvs", &t.vertex_uvs),
                storage_buffer(device, "texture_infos", &t.texture_infos),
                storage_buffer(device, "texels", &t.texels),
            ]
        });
        let emitter_grid = emitter_grid
            .filter(|g| (g.words.len() as u64 * 4) <= max_binding)
            .map(|g| storage_buffer(device, "emitter grid", &g.words));
        stats.gpu_scene_bytes = array_bindings.iter().map(SceneArray::bytes).sum::<u64>()
            + texture_buffers.iter().flatten().chain(emitter_grid.iter()).map(|b| b.size()).sum::<u64>();
        stats.upload = upload_start.elapsed();
        Ok(GpuScene {
            arrays: scene_arrays,
            array_bindings,
            baked,
            texture_buffers,
            light_count: scene.lights.len() as u32,
            light_tree_slots: arrays.light_tree.tree_slots,
            directional_lights: arrays.light_tree.directional,
            sealed_lights: arrays.light_tree.sealed_lights,
            emitter_bound: arrays.emitter_bound,
            emitter_box: arrays.emitter_box,
            bvh_stack_bound,
            emitter_triangles,
            emitter_grid,
            stats,
            features,
        })
    }

    /// The bind group of a dispatch, in the binding order of `gpu::bindings`: frame parameters,
    /// the scene, the five output buffers and `extra` (the wavefront's queue, or the test kernels' bindings).
    pub(crate) fn bind_group(
        &self,
        kernel: &Kernel,
        frame: &wgpu::Buffer,
        scene: &GpuScene,
        outputs: &[&wgpu::Buffer; 5],
        extra: &[(u32, &wgpu::Buffer)],
    ) -> wgpu::BindGroup {
        let layout = &kernel.layout;
        let mut entries = vec![wgpu::BindGroupEntry { binding: bindings::FRAME, resource: frame.as_entire_binding() }];
        // Every kernel is planned for where its scene's arrays are (`KernelPlan::for_render`,
        // `TestKernel::run`).
        assert_eq!(kernel.texel_arrays, scene.arrays.texels, "a kernel bound to a scene whose arrays it does not read");
        let arrays = &scene.array_bindings;
        for (i, array) in arrays[..bindings::SCENE_COUNT as usize].iter().enumerate() {
            entries
                .push(wgpu::BindGroupEntry { binding: bindings::SCENE_FIRST + i as u32, resource: array.resource() });
        }
        entries.push(wgpu::BindGroupEntry {
            binding: bindings::LIGHT_TREE,
            resource: arrays[LIGHT_TREE_ARRAY].resource(),
        });
        entries.push(wgpu::BindGroupEntry {
            binding: bindings::TRIANGLE_LIGHTS,
            resource: arrays[TRIANGLE_LIGHTS_ARRAY].resource(),
        });
        for (i, b) in outputs.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: bindings::OUTPUT_FIRST + i as u32,
                resource: b.as_entire_binding(),
            });
        }
        // The generic kernel reads textures only where a material has one: a scene without
        // textures binds one-element placeholders there.
        let placeholders;
        let texture_buffers = match (&scene.texture_buffers, kernel.textures) {
            (_, false) => None,
            (Some(t), true) => Some(t),
            (None, true) => {
                // One zeroed element of the largest of the three element types (16 bytes).
                placeholders =
                    [0u32; 3].map(|_| storage_buffer::<layout::TextureInfo>(&self.gpu.device, "no textures", &[]));
                Some(&placeholders)
            }
        };
        for (i, b) in texture_buffers.into_iter().flatten().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: bindings::TEXTURES_FIRST + i as u32,
                resource: b.as_entire_binding(),
            });
        }
        if kernel.emitter_grid {
            let grid = scene.emitter_grid.as_ref().expect("a kernel with the emitters' grid renders a scene with one");
            entries.push(wgpu::BindGroupEntry { binding: bindings::EMITTER_GRID, resource: grid.as_entire_binding() });
        }
        for (binding, b) in extra {
            entries.push(wgpu::BindGroupEntry { binding: *binding, resource: b.as_entire_binding() });
        }
        self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("veach"),
            layout,
            entries: &entries,
        })
    }

    pub(crate) fn frame_params(&self, scene: &GpuScene, s: &RenderSettings, camera: &Camera) -> FrameParams {
        let (strategy, light_samples, brdf_samples) = crate::kernel_plan::effective_strategy(&scene.features, s);
        FrameParams {
            camera: camera.to_gpu(s.width, s.height),
            width: s.width,
            height: s.height,
            image_height: s.height,
            seed: s.seed,
            first_sample: s.first_sample,
            strategy: strategy.gpu_code(),
            light_samples: if strategy.samples_lights() { light_samples } else { 0 },
            brdf_samples: if strategy == Strategy::Light { 0 } else { brdf_samples },
            heuristic: match s.heuristic {
                Heuristic::Balance => layout::HEURISTIC_BALANCE,
                Heuristic::Power => layout::HEURISTIC_POWER,
            },
            light_selection: s.light_selection.gpu_code(),
            light_count: scene.light_count,
            light_tree_slots: scene.light_tree_slots,
            directional_lights: scene.directional_lights,
            light_tree_lit_boxes: scene.light_tree_lit_boxes() as u32,
            _pad: [0; 3],
            emitter_centre: scene.emitter_bound.0,
            emitter_radius: scene.emitter_bound.1,
            emitter_min: scene.emitter_box.0,
            emitter_max: scene.emitter_box.1,
            light_sampling: match s.light_sampling {
                LightSampling::Area => layout::LIGHT_SAMPLING_AREA,
                LightSampling::SolidAngle => layout::LIGHT_SAMPLING_SOLID_ANGLE,
                LightSampling::Cone => layout::LIGHT_SAMPLING_CONE,
                LightSampling::Auto => layout::LIGHT_SAMPLING_AUTO,
            },
            sampler: match s.sampler {
                Sampler::Sobol => layout::SAMPLER_SOBOL,
                Sampler::Independent => layout::SAMPLER_INDEPENDENT,
            },
            write_aovs: s.write_aovs as u32,
            hide_emitters: s.hide_emitters as u32,
            loop_check: 2,
            control_variate: s.control_variate as u32,
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{layout, pad_triangle_lights};

    /// Triangle t's light is word t % 4 of vec4u t / 4 (`triangle_light`): the array padded with
    /// NO_LIGHT to whole vec4u, at least one.
    #[test]
    fn triangle_lights_pack_four_to_a_vec4u() {
        let lights: Vec<u32> = (0..10).map(|t| if t % 3 == 0 { layout::NO_LIGHT } else { t * 7 }).collect();
        let mut packed = lights.clone();
        pad_triangle_lights(&mut packed);
        assert_eq!(packed.len(), 12);
        assert_eq!(&packed[..10], &lights[..]);
        assert!(packed[10..].iter().all(|&l| l == layout::NO_LIGHT));
        let mut whole = vec![1u32; 8];
        pad_triangle_lights(&mut whole);
        assert_eq!(whole, vec![1u32; 8]);
        let mut none = vec![];
        pad_triangle_lights(&mut none);
        assert_eq!(none, vec![layout::NO_LIGHT; 4]);
    }
}
