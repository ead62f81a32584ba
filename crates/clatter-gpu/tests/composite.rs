//! Composite bodies (clumps) are not on the GPU pipeline yet: `--backend gpu` refuses a scene
//! with one, with a message that says so, and `--backend auto` runs it on the CPU.

use clatter::scene::Scene;
use clatter_gpu::{BackendChoice, BackendError, Device, GpuWorld, Stepper, choose};

const SCENE: &str = r#"[simulation]
steps = 10
[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4
[[shape]]
name = "ball"
sphere = { radius = 0.01 }
[[shape]]
name = "pair"
composite = [ { shape = "ball", offset = [-0.008, 0.0, 0.0] },
              { shape = "ball", offset = [0.008, 0.0, 0.0] } ]
[[body]]
shape = "pair"
material = "m"
position = [0.0, 0.0, 0.1]
"#;

#[test]
fn gpu_refuses_composites_and_auto_falls_back_to_the_cpu() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let world = Scene::parse(SCENE, "clumps.toml").unwrap().world();
    let e = GpuWorld::new(ctx.clone(), &world)
        .err()
        .expect("the GPU pipeline refuses composites");
    assert!(e.to_string().contains("composite"), "{e}");
    match choose(BackendChoice::Gpu, &world, Device::Shared(ctx.clone())) {
        Err(BackendError::Scene(e)) => assert!(e.to_string().contains("composite"), "{e}"),
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("--backend gpu accepted a composite scene"),
    }
    let auto = choose(BackendChoice::Auto, &world, Device::Shared(ctx)).expect("auto");
    assert!(matches!(auto.stepper, Stepper::Cpu));
}
