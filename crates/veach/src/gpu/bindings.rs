//! The bind group layout of the kernels, written out binding by binding as in
//! `shaders/layout.wgsl` (group 0) and `shaders/test_kernels.wgsl` (bindings 20–22).

use crate::features::SceneArrayMemory;

/// Binding of `frame` (FrameParams, read-only storage: see layout.wgsl for why not uniform).
pub const FRAME: u32 = 0;
/// Bindings 1..=7: the scene (bvh_nodes … light_picks), read-only storage buffers or storage
/// textures (`ExtraBindings::arrays`), and TRIANGLE_LIGHTS.
pub const SCENE_FIRST: u32 = 1;
pub const SCENE_COUNT: u32 = 7;
/// Bindings 8..=12: accum, accum_sq, counters, aov_light, aov_brdf (read-write storage).
pub const OUTPUT_FIRST: u32 = 8;
pub const OUTPUT_COUNT: u32 = 5;
/// Bindings 13..=15, only in kernels with textures.wgsl: vertex_uvs, texture_infos, texels
/// (read-only storage).
pub const TEXTURES_FIRST: u32 = 13;
pub const TEXTURES_COUNT: u32 = 3;
/// Wavefront kernels only: the deferred samples, their count and the indirect dispatch
/// arguments of the kernel that takes them (read-write storage).
pub const DEFERRED: u32 = 17;
pub const DEFERRED_HEADER: u32 = 18;
pub const DEFERRED_DISPATCH: u32 = 19;
/// Test kernels only: params (uniform), input (read-only storage), output (read-write).
pub const TEST_PARAMS: u32 = 20;
pub const TEST_INPUT: u32 = 21;
pub const TEST_OUTPUT: u32 = 22;
/// The scene's `triangle_lights` (as the arrays of bindings 1-7: `SceneArrayMemory`), after the
/// others.
pub const TRIANGLE_LIGHTS: u32 = 23;
/// Baked megakernels with camera footprint lists (`KernelPlan::footprint_slots`): the lists
/// (read-only storage).
pub const CAMERA_FOOTPRINTS: u32 = 24;
/// BVH kernels with the emitters' grid (`KernelPlan::emitter_grid`, `gpu::emitter_grid`): the grid
/// (read-only storage).
pub const EMITTER_GRID: u32 = 25;
/// The light tree (`crate::light_tree`; as the arrays of bindings 1-7: `SceneArrayMemory`), in
/// every kernel: SELECT_TREE is a setting of the frame, not of the kernel.
pub const LIGHT_TREE: u32 = 26;
/// Texels a row of a scene array's texture (`SceneArrayMemory::texels`): element i's word w
/// of an array of `words` 16-byte words an element is texel k = words * i + w, at
/// (k % TEXEL_ROW, k / TEXEL_ROW).
pub const TEXEL_ROW: u32 = 4096;
/// Storage buffers a render kernel binds (scene + outputs): a device must allow this many per stage.
pub const STORAGE_BUFFERS_NEEDED: u32 = 1 + SCENE_COUNT + 1 + OUTPUT_COUNT + TEXTURES_COUNT + 1;
/// Storage buffers of the largest kernel with the emitters' grid: the wavefront's three deferred
/// bindings and the grid besides.
pub const STORAGE_BUFFERS_WITH_EMITTER_GRID: u32 = STORAGE_BUFFERS_NEEDED + 3 + 1;

/// The scene arrays of bindings 1..=7 as the kernels name them: variable and element type.
pub const SCENE_ARRAYS: [(&str, &str); SCENE_COUNT as usize] = [
    ("bvh_nodes", "BvhNode"),
    ("vertices", "Vertex"),
    ("triangles", "IndexedTriangle"),
    ("materials", "Material"),
    ("lights", "Light"),
    ("emitter_tris", "EmitterTriangle"),
    ("light_picks", "LightPick"),
];

/// The bindings whose WGSL declaration a kernel's plan decides, written by `wgsl_declarations`
/// (the others are declared in the shader files themselves).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeclaredBindings {
    /// Where the scene arrays are read from.
    pub arrays: SceneArrayMemory,
    /// Each entry point copies the frame's parameters into a private variable (`load_frame`).
    pub frame_copy: bool,
    /// The emitters' grid is bound and read (`emitter_grid_word`).
    pub emitter_grid: bool,
    /// Entries of the BVH traversal's stack (`BVH_STACK_SIZE`, traverse_bvh.wgsl).
    pub bvh_stack: u32,
}

impl DeclaredBindings {
    /// Every array in storage, no copy of the frame, no emitters' grid, the default stack: the
    /// generic kernel's declarations.
    pub fn plain() -> DeclaredBindings {
        DeclaredBindings {
            arrays: SceneArrayMemory::default(),
            frame_copy: false,
            emitter_grid: false,
            bvh_stack: crate::gpu::bvh_nodes::BVH_STACK_SIZE,
        }
    }
}

/// A scene array read through a function: a storage texture or storage buffer of 16-byte words,
/// `words` of them an element, which `from_words` (over `w0`, `w1`, ...) makes into the struct.
struct ArrayReader {
    binding: u32,
    name: &'static str,
    element: &'static str,
    reader: &'static str,
    words: u32,
    from_words: &'static str,
}

/// The WGSL declarations of the bindings a plan decides, from the same table as `layout_entries`:
/// - `frame` (binding 0) is a read-only storage buffer, not a uniform: lavapipe (Mesa 22.3) folds
///   uniform values into the shader and compiles a new variant whenever they change, as row_start
///   and sample_start do on every dispatch (~12 ms and 0.7-7.6 MiB never freed per dispatch).
///   Every entry point calls `load_frame` first; with `frame_copy` the binding is `frame_in` and
///   `load_frame` copies it into a private `frame` once per invocation, since Mesa 22.3 loads a
///   storage word lane by lane at every read (Cornell box 0.75x; docs/performance.md, "The frame's
///   parameters copied once per invocation").
/// - the materials (4) are a uniform array where they fit on CPU adapters, else storage;
/// - `bvh_node`, `vertex_at`, `triangle_at`, `light_record`, `emitter_tri_at`, `light_pick_at`,
///   `light_tree_slot` and `triangle_light` read an element of their arrays (bindings 1-7 but the
///   materials, the light tree (26) and `triangle_lights` (23), four triangles' lights a word
///   each to a texel): on CPU adapters from a read-only `rgba32uint` storage texture
///   (`SceneArrayMemory::texels`: Mesa 22.3 loads storage lane by lane, each word through the
///   stack, and gathers texels; "Scene arrays in storage textures"), else from storage declared
///   as `vec4u` words, 16 bytes a load ("Scene arrays in storage as vec4u loads");
/// - the emitters' grid (25) is read by `emitter_grid_word`, which returns 0 in kernels without
///   one (EMITTER_LIST is then false and it is never read);
/// - `BVH_STACK_SIZE` sizes the traversal's stack.
pub fn wgsl_declarations(d: &DeclaredBindings) -> String {
    let mut out = String::new();
    let mut line = |text: String| {
        out.push_str(&text);
        out.push('\n');
    };
    if d.frame_copy {
        line(format!("@group(0) @binding({FRAME}) var<storage, read> frame_in: FrameParams;"));
        line("var<private> frame: FrameParams;".into());
        line("fn load_frame() {\n    frame = frame_in;\n}".into());
    } else {
        line(format!("@group(0) @binding({FRAME}) var<storage, read> frame: FrameParams;"));
        line("fn load_frame() {}".into());
    }
    // The materials; the other scene arrays are declared below with their readers.
    let (name, element) = SCENE_ARRAYS[MATERIALS];
    let binding = SCENE_FIRST + MATERIALS as u32;
    line(match d.arrays.uniform_materials {
        0 => format!("@group(0) @binding({binding}) var<storage, read> {name}: array<{element}>;"),
        n => format!("@group(0) @binding({binding}) var<uniform> {name}: array<{element}, {n}>;"),
    });
    // Word w of element i: texel (or vec4u) k = words * i + w.
    let shift = TEXEL_ROW.trailing_zeros();
    let mask = TEXEL_ROW - 1;
    let declare = |binding: u32, name: &str| match d.arrays.texels {
        true => format!("@group(0) @binding({binding}) var {name}: texture_storage_2d<rgba32uint, read>;"),
        false => format!("@group(0) @binding({binding}) var<storage, read> {name}: array<vec4u>;"),
    };
    let word = |name: &str, k: &str| match d.arrays.texels {
        true => format!("textureLoad({name}, vec2u({k} & {mask}u, {k} >> {shift}u))"),
        false => format!("{name}[{k}]"),
    };
    let mut array_with_reader = |array: ArrayReader| {
        let ArrayReader { binding, name, element, reader, words, from_words } = array;
        line(declare(binding, name));
        let loads: String = (0..words)
            .map(|w| format!("    let k{w} = {words}u * i + {w}u;\n    let w{w} = {};\n", word(name, &format!("k{w}"))))
            .collect();
        line(format!("fn {reader}(i: u32) -> {element} {{\n{loads}    return {from_words};\n}}"));
    };
    // Bindings 1-7 but the materials: (reader, words an element, the element from its words).
    let readers = [
        ("bvh_node", 4, "BvhNode(bitcast<vec3f>(w0.xyz), w0.w, w1.xyz, w1.w, w2.xyz, w2.w, w3)"),
        ("vertex_at", 1, "Vertex(bitcast<vec3f>(w0.xyz), w0.w)"),
        ("triangle_at", 1, "IndexedTriangle(w0.x, w0.y, w0.z, w0.w)"),
        ("", 0, ""),
        (
            "light_record",
            5,
            "Light(w0.x, w0.y, w0.z, w0.w, bitcast<vec3f>(w1.xyz), bitcast<f32>(w1.w), bitcast<vec3f>(w2.xyz), \
             bitcast<f32>(w2.w), bitcast<vec3f>(w3.xyz), bitcast<f32>(w3.w), bitcast<f32>(w4.x), w4.y, w4.z, w4.w)",
        ),
        ("emitter_tri_at", 1, "EmitterTriangle(bitcast<f32>(w0.x), w0.y, w0.z, w0.w)"),
        ("light_pick_at", 1, "LightPick(bitcast<f32>(w0.x), bitcast<f32>(w0.y), w0.z, w0.w)"),
    ];
    for (k, (reader, words, from_words)) in readers.into_iter().enumerate() {
        if k == MATERIALS {
            continue;
        }
        let (name, element) = SCENE_ARRAYS[k];
        let binding = SCENE_FIRST + k as u32;
        array_with_reader(ArrayReader { binding, name, element, reader, words, from_words });
    }
    array_with_reader(ArrayReader {
        binding: LIGHT_TREE,
        name: "light_tree",
        element: "LightTreeSlot",
        reader: "light_tree_slot",
        words: 2,
        from_words: "LightTreeSlot(w0.x, w0.y, w0.z, w0.w, w1.x, w1.y, w1.z, w1.w)",
    });
    // Four triangles' lights to a word of four.
    line(declare(TRIANGLE_LIGHTS, "triangle_lights"));
    line(format!(
        "fn triangle_light(tri: u32) -> u32 {{\n    let k = tri >> 2u;\n    return {}[tri & 3u];\n}}",
        word("triangle_lights", "k")
    ));
    if d.emitter_grid {
        line(format!("@group(0) @binding({EMITTER_GRID}) var<storage, read> emitter_grid: array<u32>;"));
        line("fn emitter_grid_word(i: u32) -> u32 {\n    return emitter_grid[i];\n}".into());
    } else {
        line("fn emitter_grid_word(i: u32) -> u32 {\n    return 0u;\n}".into());
    }
    line(format!("const BVH_STACK_SIZE: u32 = {}u;", d.bvh_stack));
    out
}

fn entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    entry(binding, wgpu::BufferBindingType::Storage { read_only })
}

/// The one scene array of SCENE_ARRAYS read directly, not through a function (a scene has few
/// materials): every other may be a texture, as may the light tree.
pub const MATERIALS: usize = 3;

fn texels(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::ReadOnly,
            format: wgpu::TextureFormat::Rgba32Uint,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    }
}

/// Which optional bindings a kernel's layout has besides the frame, scene and outputs, and
/// where the scene arrays are read from.
#[derive(Clone, Copy, Debug, Default)]
pub struct ExtraBindings {
    /// Where the scene arrays are read from.
    pub arrays: SceneArrayMemory,
    /// The texture module's bindings (13..=16).
    pub textures: bool,
    /// The wavefront kernels' deferred samples (17..=19).
    pub deferred: bool,
    /// The test kernels' bindings (20..=22).
    pub test_io: bool,
    /// The camera footprint lists (24).
    pub footprints: bool,
    /// The emitters' grid (25).
    pub emitter_grid: bool,
}

/// Layout entries of a render or test kernel.
pub fn layout_entries(extra: ExtraBindings) -> Vec<wgpu::BindGroupLayoutEntry> {
    let ExtraBindings {
        arrays,
        textures: with_textures,
        deferred: with_deferred,
        test_io: with_test_io,
        footprints,
        emitter_grid,
    } = extra;
    let mut entries = vec![storage(FRAME, true)];
    let array = |b: u32| if arrays.texels { texels(b) } else { storage(b, true) };
    entries.extend((SCENE_FIRST..SCENE_FIRST + SCENE_COUNT).map(|b| match b - SCENE_FIRST {
        k if k as usize == MATERIALS && arrays.uniform_materials > 0 => entry(b, wgpu::BufferBindingType::Uniform),
        k if k as usize == MATERIALS => storage(b, true),
        _ => array(b),
    }));
    entries.push(array(TRIANGLE_LIGHTS));
    entries.push(array(LIGHT_TREE));
    entries.extend((OUTPUT_FIRST..OUTPUT_FIRST + OUTPUT_COUNT).map(|b| storage(b, false)));
    if with_textures {
        entries.extend((TEXTURES_FIRST..TEXTURES_FIRST + TEXTURES_COUNT).map(|b| storage(b, true)));
    }
    if with_deferred {
        entries.push(storage(DEFERRED, false));
        entries.push(storage(DEFERRED_HEADER, false));
        entries.push(storage(DEFERRED_DISPATCH, false));
    }
    if footprints {
        entries.push(storage(CAMERA_FOOTPRINTS, true));
    }
    if emitter_grid {
        entries.push(storage(EMITTER_GRID, true));
    }
    if with_test_io {
        entries.push(entry(TEST_PARAMS, wgpu::BufferBindingType::Uniform));
        entries.push(storage(TEST_INPUT, true));
        entries.push(storage(TEST_OUTPUT, false));
    }
    entries
}

/// Compute pipelines for `entry_points` of `source`, sharing one explicit layout (above).
/// Validation errors are returned, not raised as device errors.
pub fn create_pipelines(
    device: &wgpu::Device,
    label: &str,
    source: String,
    entry_points: &[&str],
    extra: ExtraBindings,
    constants: &[(&str, f64)],
) -> Result<(Vec<wgpu::ComputePipeline>, wgpu::BindGroupLayout), String> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &layout_entries(extra),
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(&bind_group_layout)],
        immediate_size: 0,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipelines = entry_points
        .iter()
        .map(|entry_point| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry_point),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
                cache: None,
            })
        })
        .collect();
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(format!("{label}: kernel creation failed: {e}"));
    }
    Ok((pipelines, bind_group_layout))
}
