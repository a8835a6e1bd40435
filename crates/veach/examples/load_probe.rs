//! Times dependent loads from a storage array, a uniform array, a sampled rgba32uint texture and
//! a read-only rgba32uint storage texture, at indices that differ per lane: how the driver gathers
//! scene data (the storage texture as `veach::render::texel_array` uploads a scene array on CPU
//! adapters).
//!
//!     cargo run --release -p veach --example load_probe -- [ELEMENTS]

use std::time::Instant;
use wgpu::util::DeviceExt;

const WIDTH: u32 = veach::gpu::bindings::TEXEL_ROW;

fn shader(kind: &str, elements: u32) -> String {
    let (decl, load) = match kind {
        "storage" => {
            ("@group(0) @binding(0) var<storage, read> data: array<vec4u>;".to_string(), "data[i]".to_string())
        }
        "uniform" => {
            (format!("@group(0) @binding(0) var<uniform> data: array<vec4u, {elements}>;"), "data[i]".to_string())
        }
        "storage-texture" => (
            "@group(0) @binding(0) var data: texture_storage_2d<rgba32uint, read>;".to_string(),
            format!("textureLoad(data, vec2u(i % {WIDTH}u, i / {WIDTH}u))"),
        ),
        _ => (
            "@group(0) @binding(0) var data: texture_2d<u32>;".to_string(),
            format!("textureLoad(data, vec2u(i % {WIDTH}u, i / {WIDTH}u), 0)"),
        ),
    };
    format!(
        "{decl}
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {{
    var i = (gid.x * 2654435761u) % {elements}u;
    var acc = 0u;
    for (var k = 0u; k < 500u; k++) {{
        let v = {load};
        acc += v.y ^ v.z ^ v.w;
        i = (v.x ^ (gid.x * 40503u)) % {elements}u;
    }}
    out[gid.x] = acc + i;
}}"
    )
}

fn main() {
    let elements: u32 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(1024);
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default())).unwrap();
    println!("{}", adapter.get_info().name);
    let (device, queue) = pollster::block_on(
        adapter.request_device(&wgpu::DeviceDescriptor { required_limits: adapter.limits(), ..Default::default() }),
    )
    .unwrap();
    let words: Vec<u32> = (0..elements * 4).map(|k| k.wrapping_mul(2246822519).rotate_left(13)).collect();
    let invocations = 65536u32;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: invocations as u64 * 4,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let kinds: Vec<&str> = if elements <= 4096 {
        vec!["storage", "uniform", "texture", "storage-texture"]
    } else {
        vec!["storage", "texture", "storage-texture"]
    };
    for kind in kinds {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: None,
            source: wgpu::ShaderSource::Wgsl(shader(kind, elements).into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: None,
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let bytes: &[u8] = bytemuck::cast_slice(&words);
        let buffer;
        let view;
        let resource = match kind {
            "storage-texture" => {
                view = veach::render::texel_array(&device, &queue, "probe texels", bytes);
                wgpu::BindingResource::TextureView(&view)
            }
            "texture" => {
                let rows = elements.div_ceil(WIDTH);
                let mut padded = bytes.to_vec();
                padded.resize((rows * WIDTH * 16) as usize, 0);
                let texture = device.create_texture_with_data(
                    &queue,
                    &wgpu::TextureDescriptor {
                        label: None,
                        size: wgpu::Extent3d { width: WIDTH, height: rows, depth_or_array_layers: 1 },
                        mip_level_count: 1,
                        sample_count: 1,
                        dimension: wgpu::TextureDimension::D2,
                        format: wgpu::TextureFormat::Rgba32Uint,
                        usage: wgpu::TextureUsages::TEXTURE_BINDING,
                        view_formats: &[],
                    },
                    wgpu::util::TextureDataOrder::LayerMajor,
                    &padded,
                );
                view = texture.create_view(&Default::default());
                wgpu::BindingResource::TextureView(&view)
            }
            _ => {
                let usage = if kind == "uniform" { wgpu::BufferUsages::UNIFORM } else { wgpu::BufferUsages::STORAGE };
                buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: None,
                    contents: bytes,
                    usage,
                });
                buffer.as_entire_binding()
            }
        };
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource },
                wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            ],
        });
        let mut times = vec![];
        for _ in 0..4 {
            let t = Instant::now();
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.dispatch_workgroups(invocations / 64, 1, 1);
            }
            queue.submit([encoder.finish()]);
            device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
            times.push(t.elapsed().as_secs_f64());
        }
        println!(
            "{kind:15} {elements:8} elements: {:?}",
            &times[1..].iter().map(|t| format!("{t:.3}")).collect::<Vec<_>>()
        );
    }
}
