// camera.wgsl: primary rays of the pinhole camera, box-filtered over the pixel.

struct Ray {
    origin: vec3f,
    dir: vec3f,
}

fn camera_ray(pixel: vec2u, jitter: vec2f) -> Ray {
    let size = vec2f(f32(frame.width), f32(frame.height));
    let film = (vec2f(pixel) + jitter) / size;
    let sx = 2.0 * film.x - 1.0;
    let sy = 1.0 - 2.0 * film.y;
    let c = frame.camera;
    let dir = normalize(c.forward + sx * c.right + sy * c.up);
    return Ray(c.origin, dir);
}
