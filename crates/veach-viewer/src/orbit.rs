//! Orbit, pan and zoom around a pivot in front of the scene's camera. Until the user moves it,
//! the scene's camera is used exactly (its own up vector and position).

use glam::Vec3;
use veach::scene::Camera;

#[derive(Clone, Debug)]
pub struct OrbitCamera {
    initial: Camera,
    initial_pivot: f32,
    target: Vec3,
    distance: f32,
    /// Direction from the target to the camera, as yaw about +Y and pitch above the XZ plane.
    yaw: f32,
    pitch: f32,
    moved: bool,
}

/// Pitch stays short of the poles, where yaw is undefined.
const MAX_PITCH: f32 = 1.55;

impl OrbitCamera {
    /// Orbits about the point `pivot_distance` in front of `camera`.
    pub fn new(camera: Camera, pivot_distance: f32) -> OrbitCamera {
        let mut orbit = OrbitCamera {
            initial: camera,
            initial_pivot: pivot_distance.max(1e-4),
            target: Vec3::ZERO,
            distance: 1.0,
            yaw: 0.0,
            pitch: 0.0,
            moved: false,
        };
        orbit.reset();
        orbit
    }

    pub fn reset(&mut self) {
        let c = &self.initial;
        self.distance = self.initial_pivot;
        self.target = c.position + c.forward * self.distance;
        let back = -c.forward;
        self.yaw = back.x.atan2(back.z);
        self.pitch = back.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH);
        self.moved = false;
    }

    fn back(&self) -> Vec3 {
        Vec3::new(self.pitch.cos() * self.yaw.sin(), self.pitch.sin(), self.pitch.cos() * self.yaw.cos())
    }

    /// Turns the camera about the target by `yaw` and `pitch` radians.
    pub fn orbit(&mut self, yaw: f32, pitch: f32) {
        self.yaw -= yaw;
        self.pitch = (self.pitch + pitch).clamp(-MAX_PITCH, MAX_PITCH);
        self.moved = true;
    }

    /// Moves camera and target right and up by fractions of the view's height.
    pub fn pan(&mut self, right: f32, up: f32) {
        let cam = self.camera();
        let side = cam.forward.cross(cam.up).normalize();
        let extent = 2.0 * self.distance * (0.5 * cam.yfov).tan();
        self.target += (side * right + cam.up * up) * extent;
        self.moved = true;
    }

    /// Scales the distance to the target (below 1 moves closer).
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance * factor).clamp(1e-4, 1e7);
            self.moved = true;
        }
    }

    pub fn camera(&self) -> Camera {
        if !self.moved {
            return self.initial.clone();
        }
        let position = self.target + self.back() * self.distance;
        Camera::look_at(&self.initial.name, position, self.target, Vec3::Y, self.initial.yfov)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::look_at("c", Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 0.8)
    }

    #[test]
    fn unmoved_is_the_scene_camera_and_reset_returns_to_it() {
        let mut o = OrbitCamera::new(camera(), 5.0);
        assert_eq!(o.camera().position, camera().position);
        o.orbit(0.3, 0.2);
        o.pan(0.1, 0.0);
        o.zoom(0.5);
        assert!(o.camera().position.distance(camera().position) > 0.1);
        o.reset();
        assert_eq!(o.camera().position, camera().position);
    }

    #[test]
    fn orbit_keeps_the_distance_to_the_pivot_and_looks_at_it() {
        let mut o = OrbitCamera::new(camera(), 5.0);
        o.orbit(std::f32::consts::FRAC_PI_2, 0.0);
        let c = o.camera();
        let pivot = Vec3::new(0.0, 1.0, 0.0);
        assert!((c.position.distance(pivot) - 5.0).abs() < 1e-4, "{:?}", c.position);
        assert!((c.forward - (pivot - c.position).normalize()).length() < 1e-5);
        // A quarter turn moves the camera from +Z to the ±X side.
        assert!(c.position.x.abs() > 4.99 && c.position.z.abs() < 1e-3, "{:?}", c.position);
    }

    #[test]
    fn zoom_scales_the_distance_and_pan_moves_across_the_view() {
        let mut o = OrbitCamera::new(camera(), 5.0);
        o.zoom(0.5);
        assert!((o.camera().position.z - 2.5).abs() < 1e-4);
        o.pan(0.0, 0.25);
        let c = o.camera();
        assert!(c.position.y > 1.0 && (c.forward - camera().forward).length() < 1e-5);
        // Pitch is clamped short of the pole: the view never flips.
        o.orbit(0.0, 10.0);
        assert!(o.camera().forward.y > -1.0 && o.camera().forward.y.is_finite());
    }
}
