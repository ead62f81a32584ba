//! Scenes too large for an adapter are refused before any allocation, with an error that
//! names the limit, the need and what to do.

use clatter_gpu::GpuError;
use clatter_gpu::world::check_fits;

#[test]
fn too_many_bodies_for_the_binding_limit_is_a_clear_error() {
    // WebGPU's default limits: 128 MiB per storage binding.
    let limits = wgpu::Limits::default();
    let n = 2_000_000u64; // 112 bytes of state each: 224 MB
    let err = check_fits(&limits, "test adapter", n, 8 * n, 6).unwrap_err();
    match &err {
        GpuError::TooLarge {
            adapter,
            what,
            need,
            limit,
            advice,
        } => {
            assert_eq!(adapter, "test adapter");
            assert!(what.contains("body state"), "{what}");
            assert_eq!(need, &format!("{} bytes", 112 * n));
            assert_eq!(
                limit,
                &format!("{} bytes", limits.max_storage_buffer_binding_size)
            );
            assert!(advice.contains("--backend cpu"), "{advice}");
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("224000000 bytes") && msg.contains("134217728 bytes"),
        "{msg}"
    );
}

#[test]
fn scenes_within_the_limits_are_accepted() {
    let limits = wgpu::Limits::default();
    // 100k bodies: the largest buffer is the contact forces, 48 B x 800k pairs = 38 MB.
    check_fits(&limits, "test adapter", 100_000, 800_000, 6).expect("fits");
    // The pair list is what overflows next: 48 B x 3M pairs = 144 MB > 128 MiB.
    let err = check_fits(&limits, "test adapter", 100_000, 3_000_000, 6).unwrap_err();
    assert!(err.to_string().contains("contact forces"), "{err}");
}
