//! The GPU adapter is found (lavapipe in CI) and reports a usable device.

#[test]
fn adapter_is_found_with_usable_limits() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    eprintln!("adapter: {}", ctx.adapter_name());
    assert!(ctx.limits.max_storage_buffers_per_shader_stage >= 8);
    assert!(ctx.limits.max_compute_workgroup_size_x >= 256);
    ctx.wait().expect("no errors on an idle device");
}
