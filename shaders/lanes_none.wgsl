// lanes_none.wgsl: lanes.wgsl's functions for kernels without subgroup operations, each
// invocation deciding alone. The results are the same; only which passes lanes share differs.

// Whether `b` holds in this invocation (lanes.wgsl: in some invocation of its subgroup).
fn any_lane(b: bool) -> bool {
    return b;
}
