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

/// A world too large for the device's limits is refused by `GpuWorld::new` with an error
/// naming the buffer, its size, the limit and about how many bodies fit, before anything is
/// allocated (a buffer over the limits would be invalid, and `create_buffer_init` panics on
/// one). On a device whose storage bindings are lowered to 1 MiB, 4,096 spheres need
/// 32,768 pair slots of 48-byte forces, 1,572,864 bytes; 384 bytes a body allow
/// floor(2^20 / 384) = 2,730 bodies. The world of 2,730 spheres is then built and stepped on
/// the same device: the estimate is one that fits. A device whose buffers (not bindings) are
/// lowered to 1 MiB refuses the 4,096 with the same error.
#[test]
fn a_world_too_large_for_the_device_is_an_error_not_a_panic() {
    use clatter::World;
    use clatter::pile::{PileParams, PileShape, pile};
    use clatter_gpu::{GpuContext, GpuWorld};
    use std::sync::Arc;
    // Skips (or fails under CI) as every GPU test does when there is no adapter.
    if clatter_gpu::test_context().is_none() {
        return;
    }
    let ctx = GpuContext::with_limits(|l| l.max_storage_buffer_binding_size = 1 << 20)
        .expect("a device with lower limits");
    let ctx = Arc::new(ctx);
    let params = PileParams::default();
    let world = World::new(pile(PileShape::Sphere, 4096, &params));
    let err = match GpuWorld::new(ctx.clone(), &world) {
        Ok(_) => panic!("4,096 spheres cannot fit 1 MiB bindings"),
        Err(e) => e,
    };
    match &err {
        GpuError::TooLarge {
            what,
            need,
            limit,
            advice,
            ..
        } => {
            assert!(what.contains("`forces`"), "{what}");
            assert_eq!(need, "1572864 bytes");
            assert_eq!(limit, "1048576 bytes");
            assert!(advice.contains("about 2730 bodies"), "{advice}");
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
    // The same with the largest buffer lowered instead of the largest binding (NVIDIA's
    // case: there the buffer itself is refused, and `create_buffer_init` panicked on it).
    let small = GpuContext::with_limits(|l| l.max_buffer_size = 1 << 20).expect("device");
    match GpuWorld::new(Arc::new(small), &world) {
        Ok(_) => panic!("4,096 spheres cannot fit 1 MiB buffers"),
        Err(e) => assert_eq!(e.to_string(), err.to_string()),
    }
    let world = World::new(pile(PileShape::Sphere, 2730, &params));
    let mut gpu = GpuWorld::new(ctx, &world).expect("the estimate fits");
    gpu.step(3).expect("steps");
    assert_eq!(gpu.steps_taken(), 3);
}
