// surface.wgsl: what a ray hits, as the estimator sees it: the surface (point, normals, material),
// its emission, and the shading context at a camera hit.

struct SurfaceHit {
    p: vec3f,
    // Geometric and shading normals, both on the side the viewer is on.
    ng: vec3f,
    ns: vec3f,
    front_face: bool,
    material: u32,
    light: u32,
    // Texture coordinates (TEXCOORD_0.xy, TEXCOORD_1.xy); zero without textures.
    uvs: vec4f,
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite3(v: vec3f) -> bool {
    return is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
}

fn triangle_normal(v: TrianglePositions) -> vec3f {
    let c = cross(v.p1 - v.p0, v.p2 - v.p0);
    let len_sq = dot(c, c);
    return select(vec3f(0.0, 0.0, 1.0), c * inverseSqrt(len_sq), len_sq > 0.0);
}

fn surface_at(hit: Hit, ray_dir: vec3f) -> SurfaceHit {
    let t = triangle_at(hit.tri);
    // Each corner read once, for its position and its normal.
    let c0 = vertex_at(t.v0);
    let c1 = vertex_at(t.v1);
    let c2 = vertex_at(t.v2);
    let v = TrianglePositions(c0.p, c1.p, c2.p);
    let b0 = 1.0 - hit.b1 - hit.b2;
    let p = b0 * v.p0 + hit.b1 * v.p1 + hit.b2 * v.p2;
    var ng = triangle_normal(v);
    // Front face: counter-clockwise winding seen from the ray's origin (glTF's convention).
    let front = dot(ng, ray_dir) < 0.0;
    if !front {
        ng = -ng;
    }
    let n0 = decode_normal(c0.normal);
    let n1 = decode_normal(c1.normal);
    let n2 = decode_normal(c2.normal);
    let n_interp = b0 * n0 + hit.b1 * n1 + hit.b2 * n2;
    let len_sq = dot(n_interp, n_interp);
    var ns = select(ng, n_interp * inverseSqrt(len_sq), len_sq > 0.0);
    if dot(ns, ng) < 0.0 {
        ns = -ns;
    }
    let uvs = surface_uvs(hit.tri, hit.b1, hit.b2);
    ns = mapped_normal(materials[t.material], uvs, hit.tri, ns);
    // A shading normal that faces away from the viewer would make the BRDF vanish: fall back.
    if dot(ns, -ray_dir) <= 0.0 {
        ns = ng;
    }
    return SurfaceHit(p, ng, ns, front, t.material, triangle_light(hit.tri), uvs);
}

// Radiance a hit surface emits back along the ray: one-sided unless the material is doubleSided.
fn emitted_radiance(s: SurfaceHit) -> vec3f {
    if !HAS_AREA_LIGHTS {
        return vec3f(0.0);
    }
    let m = materials[s.material];
    if s.front_face || m.double_sided != 0u {
        return m.emission * emission_texture(m, s.uvs);
    }
    return vec3f(0.0);
}

// A camera ray's closest hit: by the camera list's edge planes where the kernel has one
// (CAMERA_LIST), else by the closest-hit traversal.
fn trace_camera_ray(ray: Ray) -> Hit {
    if FOOTPRINT_SLOTS > 0u {
        return trace_camera_slots(ray.dir);
    }
    if CAMERA_LIST {
        return trace_camera(ray.dir);
    }
    return trace_closest(ray.origin, ray.dir, RAY_INF);
}

struct ShadingContext {
    s: SurfaceHit,
    frame: Frame,
    wo: vec3f,
    bsdf: BsdfParams,
}

// The shading frame, the direction to the viewer in it and the BSDF at a surface the camera
// sees; with SELECT_BSDF also the point's light-choice table (prepare_point_selection).
fn shading_context(s: SurfaceHit, ray_dir: vec3f) -> ShadingContext {
    let f = frame_from_normal(s.ns);
    let c = ShadingContext(s, f, frame_to_local(f, -ray_dir), bsdf_params(textured_material(materials[s.material], s.uvs)));
    prepare_point_selection(s.p, f, c.wo, c.bsdf);
    return c;
}
