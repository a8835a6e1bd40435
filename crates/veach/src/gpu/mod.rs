//! Everything that talks to wgpu: the shared data layout, the device, and the scene's buffers.

pub mod baked_triangles;
pub mod bindings;
pub mod bvh_nodes;
pub mod camera_footprints;
pub mod context;
pub mod emitter_grid;
pub mod layout;
pub mod light_subtrees;
pub mod readback;
pub mod scene_buffers;
pub mod shadow_blockers;
pub mod test_kernel;
