use super::Bounds;
use glam::Vec3;

/// A perspective pinhole camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    pub position: Vec3,
    /// Unit vectors: viewing direction and up (orthogonal to forward).
    pub forward: Vec3,
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
}

impl Camera {
    /// A camera that sees the whole of `bounds`: from the +Z side, slightly above, 45° fov.
    pub fn framing(bounds: &Bounds) -> Camera {
        let yfov = 45f32.to_radians();
        let center = bounds.center();
        let radius = bounds.radius().max(1e-3);
        let distance = radius / (0.5 * yfov).sin() * 1.05;
        let back = Vec3::new(0.0, 0.25, 1.0).normalize();
        let forward = -back;
        let right = forward.cross(Vec3::Y).normalize();
        Camera {
            name: "default framing".into(),
            position: center + back * distance,
            forward,
            up: right.cross(forward).normalize(),
            yfov,
        }
    }

    pub fn look_at(name: &str, position: Vec3, target: Vec3, up: Vec3, yfov: f32) -> Camera {
        let forward = (target - position).normalize();
        let right = forward.cross(up).normalize();
        Camera { name: name.into(), position, forward, up: right.cross(forward), yfov }
    }

    /// The GPU camera for an image of `width` × `height` pixels (square pixels).
    pub fn to_gpu(&self, width: u32, height: u32) -> crate::gpu::layout::Camera {
        let aspect = width as f32 / height as f32;
        let tan_half = (0.5 * self.yfov).tan();
        let right = self.forward.cross(self.up).normalize();
        crate::gpu::layout::Camera {
            origin: self.position.to_array(),
            forward: self.forward.to_array(),
            right: (right * tan_half * aspect).to_array(),
            up: (self.up * tan_half).to_array(),
            ..Default::default()
        }
    }
}
