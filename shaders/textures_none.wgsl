// textures_none.wgsl: the functions of textures.wgsl for scenes without textures: no bindings,
// no lookups, factors as they are. The kernel source takes one of the two files.

fn surface_uvs(tri: u32, b1: f32, b2: f32) -> vec4f {
    return vec4f(0.0);
}

fn textured_material(m: Material, uvs: vec4f) -> Material {
    return m;
}

fn emission_texture(m: Material, uvs: vec4f) -> vec3f {
    return vec3f(1.0);
}

fn emitter_emission_texture(tri: u32, b1: f32, b2: f32) -> vec3f {
    return vec3f(1.0);
}

fn mapped_normal(m: Material, uvs: vec4f, tri: u32, ns: vec3f) -> vec3f {
    return ns;
}
