//! The WGSL kernel, composed at load time from one file per concept in `shaders/`.

use std::borrow::Cow;
use std::path::Path;

use crate::gpu::baked_triangles::{BakedList, BakedTriangles};
use crate::gpu::bindings::{DeclaredBindings, wgsl_declarations};

/// The shader files in the order they are joined. `BINDINGS` marks where the declarations of the
/// bindings a kernel's plan decides go (`gpu::bindings::wgsl_declarations`). `TRAVERSAL` marks where the traversal goes: `traverse_bvh.wgsl`, or `traverse_baked.wgsl` with a
/// small scene's triangles written in. `TEXTURES` marks where the texture module goes:
/// `textures.wgsl` for scenes with textures (and the generic kernel), `textures_none.wgsl` (same
/// functions, no bindings) otherwise.
pub const SHADER_FILES: &[(&str, &str)] = &[
    ("layout.wgsl", include_str!("../../../shaders/layout.wgsl")),
    BINDINGS,
    ("features.wgsl", include_str!("../../../shaders/features.wgsl")),
    ("rng.wgsl", include_str!("../../../shaders/rng.wgsl")),
    ("sampler.wgsl", include_str!("../../../shaders/sampler.wgsl")),
    ("sampling.wgsl", include_str!("../../../shaders/sampling.wgsl")),
    ("camera.wgsl", include_str!("../../../shaders/camera.wgsl")),
    ("traverse.wgsl", include_str!("../../../shaders/traverse.wgsl")),
    TRAVERSAL,
    TEXTURES,
    ("bsdf.wgsl", include_str!("../../../shaders/bsdf.wgsl")),
    ("lights.wgsl", include_str!("../../../shaders/lights.wgsl")),
    ("light_selection.wgsl", include_str!("../../../shaders/light_selection.wgsl")),
    ("light_tree.wgsl", include_str!("../../../shaders/light_tree.wgsl")),
    ("mis.wgsl", include_str!("../../../shaders/mis.wgsl")),
    ("control_variate.wgsl", include_str!("../../../shaders/control_variate.wgsl")),
    ("surface.wgsl", include_str!("../../../shaders/surface.wgsl")),
    ("sample_plan.wgsl", include_str!("../../../shaders/sample_plan.wgsl")),
    ("light_samples.wgsl", include_str!("../../../shaders/light_samples.wgsl")),
    ("direction_samples.wgsl", include_str!("../../../shaders/direction_samples.wgsl")),
    ("direct.wgsl", include_str!("../../../shaders/direct.wgsl")),
    ("deferred_rays.wgsl", include_str!("../../../shaders/deferred_rays.wgsl")),
    ("megakernel.wgsl", include_str!("../../../shaders/megakernel.wgsl")),
    ("wavefront.wgsl", include_str!("../../../shaders/wavefront.wgsl")),
];

const BINDINGS: (&str, &str) = ("bindings", "");
const TRAVERSAL: (&str, &str) = ("traversal", "");
const TRAVERSE_BVH: (&str, &str) = ("traverse_bvh.wgsl", include_str!("../../../shaders/traverse_bvh.wgsl"));
const TRAVERSE_BAKED: (&str, &str) = ("traverse_baked.wgsl", include_str!("../../../shaders/traverse_baked.wgsl"));
const TEXTURES: (&str, &str) = ("textures", "");
const TEXTURES_ON: (&str, &str) = ("textures.wgsl", include_str!("../../../shaders/textures.wgsl"));
const TEXTURES_OFF: (&str, &str) = ("textures_none.wgsl", include_str!("../../../shaders/textures_none.wgsl"));

/// The test kernels, joined after the render kernel's files.
pub const TEST_KERNELS: (&str, &str) = ("test_kernels.wgsl", include_str!("../../../shaders/test_kernels.wgsl"));
pub const TEST_ENTRY_POINT: &str = "run_test";

/// The render kernel's source (with textures, and `baked` triangles or the traversal declared by
/// `declared`) followed by the test kernels (see `gpu::test_kernel`).
pub fn test_kernel_source(baked: Option<&BakedTriangles>, declared: &DeclaredBindings) -> String {
    let (name, text) = TEST_KERNELS;
    let render = render_kernel_source(true, declared, baked, 0);
    format!("{render}// ---- shaders/{name} ----\n{}\n", shader_text(name, text))
}

/// Name of the compute entry point in `megakernel.wgsl`.
pub const RENDER_ENTRY_POINT: &str = "render";
/// The wavefront kernels' entry points in `wavefront.wgsl`, in dispatch order.
pub const WAVEFRONT_ENTRY_POINTS: [&str; 3] = ["render_light_pass", "prepare_direction_pass", "render_direction_pass"];

/// The whole kernel source. Each file is preceded by a marker comment so that a line number in
/// a WGSL error can be traced back to its file. `declared` says how the frame, the scene arrays,
/// the emitters' grid and the traversal's stack are declared (`KernelPlan`'s uniform arrays,
/// frame copy, emitters' grid and stack). With `baked` triangles, rays test those instead of
/// traversing the BVH (`KernelPlan::baked`), and camera rays test footprint lists of
/// `footprint_slots` triangles (0: none).
pub fn render_kernel_source(
    textures: bool,
    declared: &DeclaredBindings,
    baked: Option<&BakedTriangles>,
    footprint_slots: u32,
) -> String {
    let mut source = String::new();
    for &file in SHADER_FILES {
        source.push_str(&format!("// ---- shaders/{} ----\n", file.0));
        if file == BINDINGS {
            source.push_str(&wgsl_declarations(declared));
            continue;
        }
        let (name, text) = match file {
            TRAVERSAL if baked.is_some() => TRAVERSE_BAKED,
            TRAVERSAL => TRAVERSE_BVH,
            TEXTURES if textures => TEXTURES_ON,
            TEXTURES => TEXTURES_OFF,
            other => other,
        };
        let text = shader_text(name, text);
        match baked.filter(|_| file == TRAVERSAL) {
            Some(triangles) => source.push_str(&bake_triangles(&text, triangles, footprint_slots)),
            None => source.push_str(&text),
        }
        source.push('\n');
    }
    source
}

/// The environment variable naming a folder whose WGSL files replace the built-in ones: for trying
/// a shader change (on a lent GPU, say) with one built binary, never for rendering.
pub const SHADER_DIR_VARIABLE: &str = "VEACH_SHADER_DIR";

/// Shader file `name`: from `VEACH_SHADER_DIR` where that is set (said once on stderr, since the
/// images are then that folder's), else the text built in.
fn shader_text(name: &str, built_in: &'static str) -> Cow<'static, str> {
    let dir = std::env::var_os(SHADER_DIR_VARIABLE);
    if let Some(dir) = &dir {
        static NOTICE: std::sync::Once = std::sync::Once::new();
        NOTICE.call_once(|| eprintln!("note: shaders read from {SHADER_DIR_VARIABLE}={}", Path::new(dir).display()));
    }
    shader_text_in(dir.as_deref().map(Path::new), name, built_in)
}

/// Override constants by name, as `KernelPlan::constants` gives them.
pub type Constants<'a> = Vec<(&'a str, f64)>;

/// The override constants of `constants` that `source` declares, and those it does not. The
/// built-in shaders declare every one; a `VEACH_SHADER_DIR` folder written before a constant was
/// added does not, and wgpu refuses a pipeline given a constant its module lacks.
pub fn split_declared_constants<'a>(source: &str, constants: &[(&'a str, f64)]) -> (Constants<'a>, Constants<'a>) {
    let declared = |name: &str| {
        source.match_indices(&format!("override {name}")).any(|(at, m)| {
            let next = source[at + m.len()..].chars().next();
            !next.is_some_and(|c| c.is_alphanumeric() || c == '_')
        })
    };
    constants.iter().copied().partition(|(name, _)| declared(name))
}

/// The constants a kernel is created with: all of them, or with `VEACH_SHADER_DIR` set those its
/// folder's shaders declare, the others named once on stderr (the folder then runs its own code
/// where they would have specialised it), so that an older folder stays measurable with a newer
/// binary.
pub fn pipeline_constants<'a>(source: &str, constants: &[(&'a str, f64)]) -> Constants<'a> {
    if std::env::var_os(SHADER_DIR_VARIABLE).is_none() {
        return constants.to_vec();
    }
    let (kept, left_out) = split_declared_constants(source, constants);
    if !left_out.is_empty() {
        static NOTICE: std::sync::Once = std::sync::Once::new();
        NOTICE.call_once(|| {
            let names: Vec<String> = left_out.iter().map(|(n, v)| format!("{n} = {v}")).collect();
            eprintln!("note: {SHADER_DIR_VARIABLE}: its shaders do not declare {}; left out", names.join(", "))
        });
    }
    kept
}

/// Shader file `name` from `dir`, or the text built in. A file that cannot be read there is a
/// warning and the built-in text, so that a misspelt folder shows in the output.
fn shader_text_in(dir: Option<&Path>, name: &str, built_in: &'static str) -> Cow<'static, str> {
    let Some(dir) = dir else {
        return built_in.into();
    };
    let path = dir.join(name);
    match std::fs::read_to_string(&path) {
        Ok(text) => text.into(),
        Err(e) => {
            eprintln!("warning: {SHADER_DIR_VARIABLE}: cannot read {}: {e}; using the built-in {name}", path.display());
            built_in.into()
        }
    }
}

/// traverse_baked.wgsl with each `{baked STATEMENT | BOX_TEST}` line written out once per triangle,
/// each `{baked blockers: STATEMENT | BOX_TEST}` line once per triangle that can block a shadow
/// ray, and each `{baked emitters: STATEMENT | BOX_TEST}` line once per emitting triangle where
/// direction samples search them (`BakedTriangles::emitter_list`), each `{baked camera: STATEMENT |
/// BOX_TEST}` line once per triangle with edge planes through the camera's eye (n0, n1, n2 and
/// volume, `BakedTriangles::set_camera_eye`); BOX_TEST (naming the box's corners lo and hi) guards each group of nearby triangles
/// (`BakedTriangles::expand`).
fn bake_triangles(template: &str, triangles: &BakedTriangles, footprint_slots: u32) -> String {
    let mut out = String::new();
    for line in template.lines() {
        let trimmed = line.trim_start();
        if trimmed == "{footprint declarations}" {
            out.push_str(&footprint_declarations(triangles.len() as u32, footprint_slots));
            continue;
        }
        match trimmed.strip_prefix("{baked ").and_then(|rest| rest.strip_suffix('}')) {
            Some(statement) => {
                let indent = &line[..line.len() - trimmed.len()];
                let (statement, which) = if let Some(s) = statement.strip_prefix("blockers: ") {
                    (s, BakedList::Blockers)
                } else if let Some(s) = statement.strip_prefix("emitters: ") {
                    (s, BakedList::Emitters)
                } else if let Some(s) = statement.strip_prefix("camera: ") {
                    (s, BakedList::Camera)
                } else {
                    (statement, BakedList::All)
                };
                let (statement, box_test) = statement.rsplit_once(" | ").expect("a baked line names its box test");
                out.push_str(indent);
                out.push_str(&triangles.expand(statement, box_test, indent, which));
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// The constants and the binding of traverse_baked.wgsl's footprint lists (`gpu::camera_footprints`):
/// the buffer holds each triangle's camera planes (12 words: n0 and the volume, n1, n2; then one
/// entry of zeros), then each pixel's list, `FOOTPRINT_WORDS` words of four one-byte slots. With
/// no slots the kernel has no binding and the reads are never made.
fn footprint_declarations(triangles: u32, slots: u32) -> String {
    let words = slots.div_ceil(4);
    let read = if slots > 0 {
        format!(
            "@group(0) @binding({}) var<storage, read> camera_footprints: array<u32>;\n\
             fn footprint_word(i: u32) -> u32 {{ return camera_footprints[i]; }}\n",
            crate::gpu::bindings::CAMERA_FOOTPRINTS
        )
    } else {
        "fn footprint_word(i: u32) -> u32 { return 0u; }\n".to_string()
    };
    format!(
        "const FOOTPRINT_SLOTS: u32 = {slots}u;\nconst FOOTPRINT_WORDS: u32 = {words}u;\n\
         const FOOTPRINT_TRIANGLES: u32 = {triangles}u;\nconst FOOTPRINT_LISTS_OFFSET: u32 = {}u;\n{read}",
        12 * (triangles + 1)
    )
}

/// Parses and validates WGSL with naga, returning a readable error that names the file and line.
pub fn validate_wgsl(source: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
        .validate(&module)
        .map_err(|e| e.emit_to_string(source))?;
    Ok(module)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::SceneArrayMemory;
    use crate::gpu::bvh_nodes::BVH_STACK_SIZE;

    #[test]
    fn a_shader_folder_replaces_the_files_it_has() {
        let dir = std::env::temp_dir().join(format!("veach-shader-dir-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("mis.wgsl"), "// replaced\n").unwrap();
        let (name, built_in) = SHADER_FILES.iter().copied().find(|(n, _)| *n == "mis.wgsl").unwrap();
        assert_eq!(shader_text_in(Some(&dir), name, built_in), "// replaced\n");
        // A file the folder lacks, and no folder at all: the built-in text.
        assert_eq!(shader_text_in(Some(&dir), "rng.wgsl", "built in"), "built in");
        assert_eq!(shader_text_in(None, name, built_in), built_in);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn constants_a_shader_folder_does_not_declare_are_left_out() {
        let source = "override HAS_GLOSSY: bool = true;\noverride HAS_GLOSSY_X: bool = true;\n";
        let (kept, left_out) =
            split_declared_constants(source, &[("HAS_GLOSSY", 1.0), ("HAS_MIRRORS", 0.0), ("HAS_GLOSSY_X", 0.0)]);
        assert_eq!(kept, vec![("HAS_GLOSSY", 1.0), ("HAS_GLOSSY_X", 0.0)]);
        assert_eq!(left_out, vec![("HAS_MIRRORS", 0.0)]);
        // A name that only begins a declared one is not declared.
        let (kept, _) =
            split_declared_constants("override STRAIGHT_LINE_SAMPLE_X: bool;", &[("STRAIGHT_LINE_SAMPLE", 1.0)]);
        assert!(kept.is_empty());
        // The built-in shaders declare every constant a kernel is given.
        let source = render_kernel_source(true, &DeclaredBindings::plain(), None, 0);
        let (_, left_out) = split_declared_constants(&source, &crate::kernel_plan::KernelPlan::generic().constants());
        assert!(left_out.is_empty(), "{left_out:?}");
    }

    #[test]
    fn all_wgsl_validates_with_naga() {
        // A CPU adapter: the materials uniform, every other array a storage texture.
        let texels = SceneArrayMemory { uniform_materials: 256, texels: true };
        // Two triangles with extreme corners: the largest f32, a subnormal, a negative zero.
        let vertices = [[f32::MAX, 0.0, -0.0], [1.0e-45, -1.0, 2.5], [0.1, -f32::MAX, 1.0]]
            .map(|p| crate::gpu::layout::Vertex { p, normal: 0 });
        let t = crate::gpu::layout::IndexedTriangle { v0: 0, v1: 1, v2: 2, material: 0 };
        // Eight of them, the last four behind a box (a BVH whose second leaf is small).
        let leaf = |first, min, max| crate::bvh::BvhNode { min, first, max, count: 4 };
        let nodes = [
            crate::bvh::BvhNode { min: [-1.0e3; 3], first: 1, max: [1.0e3; 3], count: 0 },
            leaf(0, [-1.0e3; 3], [1.0e3; 3]),
            leaf(4, [0.0; 3], [1.0; 3]),
        ];
        let baked = BakedTriangles::new(&vertices, &[t; 8], &nodes).unwrap();
        for (textures, arrays, frame_copy, baked) in [
            (false, SceneArrayMemory::default(), false, None),
            (true, SceneArrayMemory::default(), false, None),
            (false, texels, true, None),
            (false, texels, true, Some(&baked)),
            (true, texels, true, None),
        ] {
            let declared = DeclaredBindings { arrays, frame_copy, ..DeclaredBindings::plain() };
            let source = render_kernel_source(textures, &declared, baked, 0);
            if frame_copy {
                assert!(source.contains("var<private> frame: FrameParams;") && source.contains("frame = frame_in;"));
                // Every entry point fills the copy before anything reads it.
                for entry in std::iter::once(RENDER_ENTRY_POINT).chain(WAVEFRONT_ENTRY_POINTS) {
                    let body = source.split(&format!("fn {entry}(")).nth(1).expect("an entry point");
                    let first = body.split('{').nth(1).and_then(|b| b.lines().nth(1)).map(str::trim);
                    assert_eq!(first, Some("load_frame();"), "{entry} does not start with load_frame()");
                }
            }
            if baked.is_some() {
                assert!(!source.lines().any(|l| l.trim_start().starts_with("{baked")), "a template line left in");
                assert!(!source.contains("var<private> bvh_stack"), "a baked kernel with the BVH's traversal");
                assert_eq!(source.matches("closest_candidate(&hit").count(), 8);
                assert_eq!(source.matches("if intersect_aabb(").count(), 2, "one boxed group in each trace");
            }
            let module = validate_wgsl(&source).unwrap_or_else(|e| panic!("WGSL invalid (textures {textures}):\n{e}"));
            assert!(
                module
                    .entry_points
                    .iter()
                    .any(|e| e.name == RENDER_ENTRY_POINT && e.stage == naga::ShaderStage::Compute),
                "no compute entry point `{RENDER_ENTRY_POINT}`"
            );
        }
    }

    #[test]
    fn test_kernels_validate_with_naga() {
        let source = test_kernel_source(None, &DeclaredBindings::plain());
        validate_wgsl(&source).unwrap_or_else(|e| panic!("WGSL invalid:\n{e}"));
    }

    #[test]
    fn a_deeper_trees_kernel_gets_a_larger_stack() {
        let declares = |n: u32| format!("const BVH_STACK_SIZE: u32 = {n}u;");
        let default = render_kernel_source(false, &DeclaredBindings::plain(), None, 0);
        assert!(default.contains(&declares(BVH_STACK_SIZE)), "the stack is not BVH_STACK_SIZE");
        let deeper = DeclaredBindings { bvh_stack: 160, ..DeclaredBindings::plain() };
        let deeper = render_kernel_source(false, &deeper, None, 0);
        assert!(deeper.contains(&declares(160)) && !deeper.contains(&declares(BVH_STACK_SIZE)));
        validate_wgsl(&deeper).unwrap_or_else(|e| panic!("WGSL invalid:\n{e}"));
    }

    #[test]
    fn layout_matches_wgsl() {
        let source = SHADER_FILES[0].1;
        let module = validate_wgsl(source).unwrap_or_else(|e| panic!("layout.wgsl invalid:\n{e}"));
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        for (name, size, fields) in crate::gpu::layout::rust_layouts() {
            let (handle, ty) = module
                .types
                .iter()
                .find(|(_, t)| t.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("struct {name} missing from layout.wgsl"));
            let naga::TypeInner::Struct { members, span } = &ty.inner else {
                panic!("{name} is not a struct in WGSL");
            };
            assert_eq!(*span as usize, size, "size of {name}: WGSL {span}, Rust {size}");
            assert_eq!(layouter[handle].size as usize, size);
            for (field, offset) in fields {
                let m = members
                    .iter()
                    .find(|m| m.name.as_deref() == Some(field))
                    .unwrap_or_else(|| panic!("{name}.{field} missing in WGSL"));
                assert_eq!(m.offset as usize, offset, "offset of {name}.{field}");
            }
        }
    }
}
