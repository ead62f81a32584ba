//! Boundary meshes as users have them, on the GPU: the awkward meshes of
//! `crates/clatter/tests/common/awkward.rs` (inverted closed drum, mixed winding,
//! duplicates/slivers/gaps, a T-junction, a non-manifold fin, a binary STL with a bogus
//! header, an OBJ with quads and negative indices) run on the GPU with the same physics as
//! their clean twins run on the GPU: bit for bit where the cleaned mesh is the twin's, else
//! within the case's tolerance. (The cleaning is the host's, shared with the CPU; this shows
//! that the GPU's mesh contacts take the cleaned adjacency as the CPU's do.)

use std::path::Path;

use clatter::World;
use clatter::scene::Scene;
use clatter_gpu::GpuWorld;

#[path = "../../clatter/tests/common/meshes.rs"]
mod meshes;

#[path = "../../clatter/tests/common/awkward.rs"]
mod awkward;
use awkward::Expect;

/// Steps between compared states.
const CHUNK: u64 = 200;

/// The states of a scene's GPU run every [`CHUNK`] steps, and how many had a touching
/// contact.
fn trajectory(scene: &Scene) -> (Vec<World>, usize) {
    let ctx = clatter_gpu::test_context().expect("a GPU adapter (lavapipe)");
    let mut host = scene.world();
    let steps = scene.steps(host.dt);
    let mut gpu = GpuWorld::new(ctx, &host).expect("the scene runs on the GPU");
    let (mut states, mut touching) = (Vec::new(), 0);
    for _ in 0..steps / CHUNK {
        let rep = gpu.step_into(CHUNK, &mut host).expect("GPU steps");
        assert_eq!(rep.bad_body, None);
        touching += (rep.touching > 0) as usize;
        states.push(host.clone());
    }
    (states, touching)
}

fn load(p: &Path) -> Scene {
    Scene::load(p).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn awkward_meshes_run_as_their_clean_twins_on_the_gpu() {
    let d = awkward::dir("gpu");
    for case in awkward::cases(&d) {
        let ((ta, touch_a), (tc, touch_c)) = (
            trajectory(&load(&case.awkward)),
            trajectory(&load(&case.clean)),
        );
        assert!(
            touch_c > 0 && touch_a == touch_c,
            "{}: touching states {touch_a} vs {touch_c}",
            case.name
        );
        let mut worst = 0.0f32;
        for (k, (x, y)) in ta.iter().zip(&tc).enumerate() {
            for i in 0..x.len() {
                let dx = (x.state.position[i] - y.state.position[i]).length() as f32;
                worst = worst.max(dx);
                match case.expect {
                    Expect::Bitwise => {
                        assert_eq!(
                            (x.state.position[i], x.state.velocity[i]),
                            (y.state.position[i], y.state.velocity[i]),
                            "{} chunk {k} body {i}",
                            case.name
                        );
                        assert_eq!(
                            x.state.angular_momentum[i], y.state.angular_momentum[i],
                            "{} chunk {k} body {i}",
                            case.name
                        );
                    }
                    Expect::Within(tol) => {
                        assert!(
                            dx <= tol,
                            "{} chunk {k} body {i}: {dx:e} m apart",
                            case.name
                        )
                    }
                }
            }
        }
        eprintln!(
            "GPU {}: {} compared states, {touch_a} touching, largest difference {worst:e} m",
            case.name,
            ta.len()
        );
    }
}
