//! Textures as veach samples them: RGBA8 texels, a glTF sampler's wrap modes and magnification
//! filter, and texture references with a texture-coordinate set and a KHR_texture_transform.
//! `Texture::sample` is the host's copy of `texture_lookup` in `shaders/textures.wgsl`: the
//! tests compare the GPU against it.

use glam::{Vec2, Vec3, Vec4};

/// glTF sampler wrap modes (glTF 2.0 §5.26, sampler.wrapS / wrapT).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat = 0,
    ClampToEdge = 1,
    MirroredRepeat = 2,
}

#[derive(Clone, Debug)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first (glTF's uv (0, 0) is the image's top-left corner).
    pub texels: Vec<[u8; 4]>,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    /// magFilter NEAREST; otherwise bilinear. Minification has no mip-maps: camera samples
    /// jittered over the pixel average the texture over its footprint as they accumulate.
    pub nearest: bool,
}

/// Which kind of texture a lookup reads: colour textures (base colour, emissive) are sRGB
/// encoded and decoded before filtering; data textures (metallic-roughness, normal) are linear.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Srgb,
    Linear,
}

/// The sRGB transfer function's inverse (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Index `i` of a row or column of `n` texels under a wrap mode.
pub fn wrap_index(i: i64, n: u32, wrap: Wrap) -> u32 {
    let n = n as i64;
    let j = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    };
    j as u32
}

/// Texture coordinates are clamped to ±UV_LIMIT so that texel indices fit an i32 on the GPU.
pub const UV_LIMIT: f32 = 1.0e5;

impl Texture {
    fn texel(&self, x: i64, y: i64, encoding: Encoding) -> Vec4 {
        let (x, y) = (wrap_index(x, self.width, self.wrap_s), wrap_index(y, self.height, self.wrap_t));
        let t = self.texels[(y * self.width + x) as usize];
        let v = Vec4::new(t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32) / 255.0;
        match encoding {
            Encoding::Srgb => Vec4::new(srgb_to_linear(v.x), srgb_to_linear(v.y), srgb_to_linear(v.z), v.w),
            Encoding::Linear => v,
        }
    }

    /// The filtered value at `uv`: texel centres at (i + ½) / width, bilinear between the four
    /// nearest (or the nearest one), each decoded before filtering.
    pub fn sample(&self, uv: Vec2, encoding: Encoding) -> Vec4 {
        let p =
            uv.clamp(Vec2::splat(-UV_LIMIT), Vec2::splat(UV_LIMIT)) * Vec2::new(self.width as f32, self.height as f32);
        if self.nearest {
            return self.texel(p.x.floor() as i64, p.y.floor() as i64, encoding);
        }
        let q = p - 0.5;
        let (x0, y0) = (q.x.floor(), q.y.floor());
        let (fx, fy) = (q.x - x0, q.y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0, encoding).lerp(self.texel(x0 + 1, y0, encoding), fx);
        let bottom = self.texel(x0, y0 + 1, encoding).lerp(self.texel(x0 + 1, y0 + 1, encoding), fx);
        top.lerp(bottom, fy)
    }
}

/// A material's use of a texture (glTF textureInfo).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: u32,
    /// TEXCOORD_n set (0 or 1), after KHR_texture_transform's texCoord override.
    pub tex_coord: u32,
    /// Rows of the 2×3 affine map uv' = M (u, v, 1).
    pub transform: [Vec3; 2],
}

impl TextureRef {
    pub fn new(texture: u32, tex_coord: u32) -> TextureRef {
        TextureRef { texture, tex_coord, transform: [Vec3::X, Vec3::Y] }
    }

    /// KHR_texture_transform: M = T · R · S with the rotation of the extension's reference
    /// GLSL (its README, "Overview"): columns (cos, sin) and (−sin, cos).
    pub fn with_transform(mut self, offset: Vec2, rotation: f32, scale: Vec2) -> TextureRef {
        let (s, c) = rotation.sin_cos();
        self.transform =
            [Vec3::new(c * scale.x, -s * scale.y, offset.x), Vec3::new(s * scale.x, c * scale.y, offset.y)];
        self
    }

    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let h = uv.extend(1.0);
        Vec2::new(self.transform[0].dot(h), self.transform[1].dot(h))
    }
}
