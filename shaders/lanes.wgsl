// lanes.wgsl: votes across the invocations that run side by side in one SIMD group (a subgroup),
// for kernels whose device has subgroup operations (wgpu's Features::SUBGROUP) and that use them
// (KernelKey::waiting_direction_rays). lanes_none.wgsl has the same functions without them.

// Whether `b` holds in some active invocation of this one's subgroup.
fn any_lane(b: bool) -> bool {
    return subgroupAny(b);
}
