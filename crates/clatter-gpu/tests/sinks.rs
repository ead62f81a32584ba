//! Sinks on the GPU against the CPU: a lattice of spheres falling onto a floor whose left
//! half is covered by a sink; the removed bodies, their count and their mass (what
//! `discharge.csv` writes) agree exactly at every sample, and the bodies outside the sink
//! land on the floor as on the CPU. The closed-form checks run on the GPU through
//! `tests/physics.rs` (which includes crates/clatter/tests/sinks.rs).

use clatter::scene::Scene;
use clatter_gpu::GpuWorld;

/// The sink scene of the CLI's discharge test (the test steps it itself).
const SCENE: &str = include_str!("../../../scenes/sink-floor.toml");

#[test]
fn discharge_rows_agree_with_the_cpu() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let scene = Scene::parse(SCENE, "sink.toml").expect("valid scene");
    let mut cpu = scene.world();
    let mut host = scene.world();
    let mut gpu = GpuWorld::new(ctx, &host).expect("the scene fits");
    let (chunk, chunks) = (50, 160);
    let mut rows_cpu = Vec::new();
    let mut rows_gpu = Vec::new();
    for _ in 0..chunks {
        for _ in 0..chunk {
            cpu.step().expect("CPU step");
        }
        gpu.step_into(chunk, &mut host).expect("GPU steps");
        assert_eq!(host.step_count, cpu.step_count);
        let (dc, dg) = (cpu.discharged(), host.discharged());
        rows_cpu.push((cpu.step_count, dc.count, dc.mass));
        rows_gpu.push((host.step_count, dg.count, dg.mass));
        assert_eq!(
            cpu.state.removed, host.state.removed,
            "removed bodies differ at step {}",
            cpu.step_count
        );
    }
    assert_eq!(rows_cpu, rows_gpu);
    // 50 bodies, the 3 x 5 x 2 = 30 left of x = 0.06 (x = 0.01, 0.03, 0.05) fall in the sink.
    let last = rows_cpu.last().unwrap();
    assert_eq!(last.1, 30, "{rows_cpu:?}");
    // The others rest on the floor (two high) on both backends.
    for i in 0..cpu.len() {
        if !cpu.is_removed(i) {
            let (a, b) = (cpu.state.position[i], host.state.position[i]);
            assert!((a - b).length() < 1e-4, "body {i}: {a} vs {b}");
            assert!(a.z < 0.0151 && a.x > 0.06, "body {i} is on the floor: {a}");
        }
    }
}
