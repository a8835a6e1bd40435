// textures.wgsl: glTF textures (glTF 2.0 §3.9 and §5.26), joined into kernels for scenes that
// use any; scenes without textures get textures_none.wgsl instead, which has the same functions
// without bindings or lookups. Texels are RGBA8 in one storage buffer, filtered here by hand:
// bilinear (or nearest for magFilter NEAREST), wrap modes per axis, colour textures decoded
// from sRGB before filtering. The host's copy is `Texture::sample` in scene/texture.rs.

// Which kinds of texture the scene uses: a lookup of a kind no material has is compiled out.
override HAS_BASE_COLOR_TEXTURE: bool = true;
override HAS_METALLIC_ROUGHNESS_TEXTURE: bool = true;
override HAS_EMISSIVE_TEXTURE: bool = true;
override HAS_NORMAL_TEXTURE: bool = true;

const WRAP_REPEAT: u32 = 0u;
const WRAP_CLAMP_TO_EDGE: u32 = 1u;
const WRAP_MIRRORED_REPEAT: u32 = 2u;
const UV_LIMIT: f32 = 1.0e5;

// Texture coordinates of each vertex (TEXCOORD_0.xy, TEXCOORD_1.xy), indexed like `vertices`.
@group(0) @binding(13) var<storage, read> vertex_uvs: array<vec4f>;
@group(0) @binding(14) var<storage, read> texture_infos: array<TextureInfo>;
@group(0) @binding(15) var<storage, read> texels: array<u32>;

fn srgb_to_linear(c: vec3f) -> vec3f {
    // IEC 61966-2-1.
    return select(pow((c + 0.055) / 1.055, vec3f(2.4)), c / 12.92, c <= vec3f(0.04045));
}

fn wrap_index(i: i32, n: i32, mode: u32) -> i32 {
    switch mode {
        case WRAP_CLAMP_TO_EDGE: {
            return clamp(i, 0, n - 1);
        }
        case WRAP_MIRRORED_REPEAT: {
            let m = ((i % (2 * n)) + 2 * n) % (2 * n);
            return select(2 * n - 1 - m, m, m < n);
        }
        default: {
            return ((i % n) + n) % n;
        }
    }
}

fn texel(t: TextureInfo, x: i32, y: i32, srgb: bool) -> vec4f {
    let w = i32(t.width);
    let h = i32(t.height);
    let xi = wrap_index(x, w, t.sampling & 3u);
    let yi = wrap_index(y, h, (t.sampling >> 2u) & 3u);
    let v = unpack4x8unorm(texels[t.offset + u32(yi * w + xi)]);
    return select(v, vec4f(srgb_to_linear(v.rgb), v.a), srgb);
}

// The filtered texture value at uv; texel centres lie at (i + 1/2) / width.
fn texture_lookup(index: u32, uv: vec2f, srgb: bool) -> vec4f {
    let t = texture_infos[index];
    // Keeps texel indices within i32 (the host clamps the same way).
    let p = clamp(uv, vec2f(-UV_LIMIT), vec2f(UV_LIMIT)) * vec2f(f32(t.width), f32(t.height));
    if (t.sampling & 16u) != 0u {
        let i = vec2i(floor(p));
        return texel(t, i.x, i.y, srgb);
    }
    let q = p - 0.5;
    let i = vec2i(floor(q));
    let f = q - floor(q);
    let top = mix(texel(t, i.x, i.y, srgb), texel(t, i.x + 1, i.y, srgb), f.x);
    let bottom = mix(texel(t, i.x, i.y + 1, srgb), texel(t, i.x + 1, i.y + 1, srgb), f.x);
    return mix(top, bottom, f.y);
}

// Both texture-coordinate sets at barycentrics (b1, b2) of a triangle.
fn surface_uvs(tri: u32, b1: f32, b2: f32) -> vec4f {
    let t = triangle_at(tri);
    return (1.0 - b1 - b2) * vertex_uvs[t.v0] + b1 * vertex_uvs[t.v1] + b2 * vertex_uvs[t.v2];
}

fn texture_uv(r: TextureRef, uvs: vec4f) -> vec2f {
    let uv = select(uvs.xy, uvs.zw, r.tex_coord == 1u);
    let h = vec3f(uv, 1.0);
    return vec2f(dot(r.row0, h), dot(r.row1, h));
}

// The material at a point: factors multiplied by their textures (glTF 2.0 §3.9.2: base colour
// by the sRGB texture's rgb; metallic by the blue, roughness by the green channel).
fn textured_material(m: Material, uvs: vec4f) -> Material {
    var out = m;
    if HAS_BASE_COLOR_TEXTURE && m.base_color_texture.index != NO_TEXTURE {
        out.base_color *= texture_lookup(m.base_color_texture.index, texture_uv(m.base_color_texture, uvs), true).rgb;
    }
    if HAS_METALLIC_ROUGHNESS_TEXTURE && m.metallic_roughness_texture.index != NO_TEXTURE {
        let r = m.metallic_roughness_texture;
        let mr = texture_lookup(r.index, texture_uv(r, uvs), false);
        out.metallic *= mr.b;
        out.roughness *= mr.g;
    }
    return out;
}

// Emitted radiance scale at a point: the emissive texture's rgb (sRGB), or 1.
fn emission_texture(m: Material, uvs: vec4f) -> vec3f {
    if HAS_EMISSIVE_TEXTURE && m.emissive_texture.index != NO_TEXTURE {
        return texture_lookup(m.emissive_texture.index, texture_uv(m.emissive_texture, uvs), true).rgb;
    }
    return vec3f(1.0);
}

// The emissive texture at barycentrics (b1, b2) of triangle `tri`, a light sample's.
fn emitter_emission_texture(tri: u32, b1: f32, b2: f32) -> vec3f {
    if !HAS_EMISSIVE_TEXTURE {
        return vec3f(1.0);
    }
    return emission_texture(materials[triangle_at(tri).material], surface_uvs(tri, b1, b2));
}

// The shading normal with the normal texture applied (glTF 2.0 §3.9.3: tangent-space normal,
// x and y scaled by normalTexture.scale). The tangent is the triangle's dp/du for the normal
// texture's (transformed) coordinates and the bitangent cross(n, t), as the glTF Sample Viewer
// does without TANGENT attributes; veach reads no TANGENT attributes.
fn mapped_normal(m: Material, uvs: vec4f, tri: u32, ns: vec3f) -> vec3f {
    if !HAS_NORMAL_TEXTURE || m.normal_texture.index == NO_TEXTURE {
        return ns;
    }
    let r = m.normal_texture;
    let t = triangle_at(tri);
    let v = triangle_positions(t);
    let uv0 = texture_uv(r, vertex_uvs[t.v0]);
    let d1 = texture_uv(r, vertex_uvs[t.v1]) - uv0;
    let d2 = texture_uv(r, vertex_uvs[t.v2]) - uv0;
    let det = d1.x * d2.y - d1.y * d2.x;
    if abs(det) < 1.0e-20 {
        return ns;
    }
    let dp_du = ((v.p1 - v.p0) * d2.y - (v.p2 - v.p0) * d1.y) / det;
    let tangent_raw = dp_du - ns * dot(dp_du, ns);
    let len_sq = dot(tangent_raw, tangent_raw);
    if !(len_sq > 0.0) {
        return ns;
    }
    let tangent = tangent_raw * inverseSqrt(len_sq);
    let bitangent = cross(ns, tangent);
    var n = texture_lookup(r.index, texture_uv(r, uvs), false).xyz * 2.0 - 1.0;
    n = vec3f(n.xy * m.normal_scale, n.z);
    let mapped = n.x * tangent + n.y * bitangent + n.z * ns;
    let mapped_len_sq = dot(mapped, mapped);
    return select(ns, mapped * inverseSqrt(mapped_len_sq), mapped_len_sq > 0.0);
}
