// camera.wgsl: primary rays of the pinhole camera, box-filtered over the pixel.

struct Ray {
    origin: vec3f,
    dir: vec3f,
}

// `pixel` in the pixel buffers' rows; the film is the whole image's (frame.tile_row).
fn camera_ray(pixel: vec2u, jitter: vec2f) -> Ray {
    let size = vec2f(f32(frame.width), f32(frame.image_height));
    let film = (vec2f(f32(pixel.x), f32(pixel.y + frame.tile_row)) + jitter) / size;
    let sx = 2.0 * film.x - 1.0;
    let sy = 1.0 - 2.0 * film.y;
    let c = frame.camera;
    let dir = normalize(c.forward + sx * c.right + sy * c.up);
    return Ray(c.origin, dir);
}
