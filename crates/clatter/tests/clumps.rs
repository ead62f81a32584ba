//! Composite bodies (clumps) on the CPU pipeline, against closed forms and conservation laws:
//! - a two-sphere clump dropped on a floor comes to rest on both spheres, each sunk by the
//!   static overlap `m g / (2 k)` of the linear law;
//! - a dumbbell hit on one end spins at the rate the impulse predicts (`w = L J / I`);
//! - two clumps colliding (no walls, no gravity, friction on) conserve momentum and angular
//!   momentum to rounding, with one contact (and spring) per touching piece pair;
//! - a composite of one piece steps bitwise like the plain shape;
//! - a decomposed non-convex mesh (an L-shaped block) has the L's volume, not its hull's, and
//!   rests on a floor at the L's centre-of-mass height;
//! - restarts from checkpoints are bitwise exact, and results do not depend on the thread count.

use clatter::World;
use clatter::checkpoint::Checkpoint;
use clatter::geom::Shape;
use clatter::scene::Scene;
use glam::{DVec3, Vec3};
use std::path::Path;

const MATERIAL: &str = r#"
[[material]]
name = "m"
density = 2500.0
stiffness = 1.0e4
restitution = 0.3
friction = 0.5
"#;

fn parse(text: &str) -> Scene {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/test.toml");
    Scene::parse(text, &file.display().to_string()).unwrap_or_else(|e| panic!("{e}"))
}

fn run(w: &mut World, steps: u64) {
    for _ in 0..steps {
        w.step().expect("a stable run");
    }
}

/// Piece `k` of body `i`: its world centre.
fn piece_centre(w: &World, i: usize, k: usize) -> Vec3 {
    let Shape::Composite(c) = w.shape(i) else {
        panic!("body {i} is not a composite")
    };
    w.state.position_f32(i) + w.state.orientation[i] * c.pieces[k].position
}

#[test]
fn two_sphere_clump_rests_on_both_spheres() {
    let r = 0.01f32;
    let text = format!(
        r#"[simulation]
duration = 1.5
gravity = [0.0, 0.0, -9.81]
{MATERIAL}
[[shape]]
name = "ball"
sphere = {{ radius = {r} }}
[[shape]]
name = "pair"
composite = [ {{ shape = "ball", offset = [-0.008, 0.0, 0.0] }},
              {{ shape = "ball", offset = [0.008, 0.0, 0.0] }} ]
[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "m"
[[body]]
shape = "pair"
material = "m"
position = [0.0, 0.0, 0.03]
orientation = [0.9848078, 0.0, 0.1736482, 0.0]   # 20 degrees about y: lands on one end
"#
    );
    let scene = parse(&text);
    let mut w = scene.world();
    let steps = scene.steps(w.dt);
    run(&mut w, steps);
    assert!(
        w.state.velocity[0].length() < 1e-4,
        "{}",
        w.state.velocity[0]
    );
    assert!(w.state.omega[0].length() < 1e-2, "{}", w.state.omega[0]);
    // Two wall contacts, one per sphere, both touching.
    assert_eq!(w.contact_count(), 2);
    // Each sphere carries half the weight: sunk by m g / (2 k).
    let delta = w.consts.mass[0] * 9.81 / (2.0 * 1.0e4);
    for k in 0..2 {
        let z = piece_centre(&w, 0, k).z;
        assert!(
            (z - (r - delta)).abs() < 0.02 * delta + 1e-7,
            "sphere {k} at {z}, expected {}",
            r - delta
        );
    }
}

#[test]
fn dumbbell_hit_on_one_end_spins_as_the_impulse_predicts() {
    // Dumbbell: spheres r at +-L on x (disjoint, joined rigidly); a free sphere moving along
    // +y hits the +L end head on. Frictionless: the impulse J is along the line of centres.
    let (r, l, v0) = (0.01f32, 0.03f32, 0.5f32);
    let text = format!(
        r#"[simulation]
steps = 1
gravity = [0.0, 0.0, 0.0]
[[material]]
name = "m"
density = 2500.0
stiffness = 1.0e5
restitution = 0.8
friction = 0.0
[[shape]]
name = "ball"
sphere = {{ radius = {r} }}
[[shape]]
name = "dumbbell"
composite = [ {{ shape = "ball", offset = [{l}, 0.0, 0.0] }},
              {{ shape = "ball", offset = [-{l}, 0.0, 0.0] }} ]
[[body]]
shape = "dumbbell"
material = "m"
position = [0.0, 0.0, 0.0]
[[body]]
shape = "ball"
material = "m"
position = [{l}, -0.025, 0.0]
velocity = [0.0, {v0}, 0.0]
"#
    );
    let scene = parse(&text);
    let mut w = scene.world();
    let m_ball = w.consts.mass[1];
    let m_db = w.consts.mass[0];
    // Disjoint pieces: I_zz = 2 (2/5 m r^2 + m L^2) with m = M / 2 (parallel axes).
    let izz = 2.0 * (0.4 * (m_db / 2.0) * r * r + (m_db / 2.0) * l * l);
    assert!((w.consts.inertia[0].max_element() - izz).abs() < 1e-5 * izz);
    // Until the contact is over and the bodies are apart.
    let mut touched = false;
    for _ in 0..200_000 {
        w.step().unwrap();
        let t = w.contact_count() > 0;
        touched |= t;
        if touched && !t {
            break;
        }
    }
    assert!(touched);
    // The impulse on the dumbbell is the ball's momentum change.
    let j = (Vec3::new(0.0, v0, 0.0) - w.state.velocity[1]) * m_ball;
    let v = w.state.velocity[0];
    assert!(
        (v - j / m_db).length() < 1e-4 * j.length() / m_db,
        "{v} vs {}",
        j / m_db
    );
    // Angular momentum about the dumbbell's centre: the ball's line of motion at x = L.
    let wz = w.state.omega[0].z;
    let predicted = l * j.y / izz;
    assert!(
        (wz - predicted).abs() < 0.01 * predicted.abs(),
        "spin {wz} vs L J / I = {predicted}"
    );
    // And the impulse is the one of a collision with restitution 0.8 at the end's effective
    // mass 1 / (1/M + L^2/I) (within the small turn of the dumbbell during contact).
    let m_end = 1.0 / (1.0 / m_db + l * l / izz);
    let j_pred = (1.0 + 0.8) * v0 / (1.0 / m_ball + 1.0 / m_end);
    assert!(
        (j.y - j_pred).abs() < 0.02 * j_pred,
        "J {} vs {j_pred}",
        j.y
    );
}

/// Total momentum and angular momentum about the origin (f64 sums), and the sums of their
/// terms' magnitudes (the scale of their rounding).
fn momenta(w: &World) -> (DVec3, DVec3, f64, f64) {
    let (mut p, mut l, mut sp, mut sl) = (DVec3::ZERO, DVec3::ZERO, 0.0, 0.0);
    for i in 0..w.len() {
        let m = w.consts.mass[i] as f64;
        let x = w.state.position[i];
        let v = w.state.velocity[i].as_dvec3() * m;
        let spin = w.state.angular_momentum[i].as_dvec3();
        p += v;
        l += x.cross(v) + spin;
        sp += v.length();
        sl += x.cross(v).length() + spin.length();
    }
    (p, l, sp, sl)
}

const TWO_CLUMPS: &str = r#"[simulation]
steps = 3000
gravity = [0.0, 0.0, 0.0]
[[material]]
name = "m"
density = 2500.0
stiffness = 1.0e4
restitution = 0.5
friction = 0.5
[[shape]]
name = "ball"
sphere = { radius = 0.01 }
[[shape]]
name = "cube"
box = { half_extents = [0.006, 0.006, 0.006] }
[[shape]]
name = "rod"
composite = [ { shape = "ball", offset = [-0.015, 0.0, 0.0] },
              { shape = "ball", offset = [0.0, 0.0, 0.0] },
              { shape = "ball", offset = [0.015, 0.0, 0.0] } ]
[[shape]]
name = "mixed"
composite = [ { shape = "ball", offset = [-0.012, 0.0, 0.0] },
              { shape = "cube", offset = [0.012, 0.0, 0.0], orientation = [0.9238795, 0.0, 0.0, 0.3826834] } ]
# Two parallel rods approaching side by side: two and more sphere pairs touch at once.
[[body]]
shape = "rod"
material = "m"
position = [0.0, 0.0, 0.0]
velocity = [0.0, 0.2, 0.0]
angular_velocity = [0.0, 0.0, 1.0]
[[body]]
shape = "rod"
material = "m"
position = [0.003, 0.025, 0.0]
velocity = [0.0, -0.2, 0.0]
[[body]]
shape = "mixed"
material = "m"
position = [0.0, -0.035, 0.004]
velocity = [0.05, 0.3, 0.0]
angular_velocity = [3.0, 0.0, 2.0]
"#;

#[test]
fn clump_collisions_conserve_momentum_and_angular_momentum() {
    let scene = parse(TWO_CLUMPS);
    let mut w = scene.world();
    let (p0, l0, sp, sl) = momenta(&w);
    let mut most_piece_contacts = 0;
    let mut touched_mixed = false;
    // As in conservation.rs: `x += v dt` rounds in f32, which moves `sum x x m v` in free
    // flight; that share is summed exactly here so that the contacts' share can be checked.
    let mut rounding = DVec3::ZERO;
    let (mut worst_p, mut worst_l) = (0.0f64, 0.0f64);
    for _ in 0..scene.steps(w.dt) {
        let x_prev = w.state.position.clone();
        w.step().unwrap();
        for (i, &x0) in x_prev.iter().enumerate() {
            let v = w.state.velocity[i].as_dvec3();
            let ideal = x0 + v * w.dt as f64;
            rounding += (w.state.position[i] - ideal).cross(v * w.consts.mass[i] as f64);
        }
        // Touching piece contacts between the two rods (body pair 0-1).
        let c = &w.contacts;
        let n = c
            .pairs()
            .iter()
            .zip(&c.springs().touching)
            .filter(|(p, t)| **t && **p == [0, 1])
            .count();
        most_piece_contacts = most_piece_contacts.max(n);
        touched_mixed |= w.touching_pairs().iter().any(|p| p[1] == 2);
        let (p, l, _, _) = momenta(&w);
        worst_p = worst_p.max((p - p0).length() / sp);
        worst_l = worst_l.max((l - l0 - rounding).length() / sl);
    }
    eprintln!("worst drift: momentum {worst_p:.2e}, angular momentum (contacts) {worst_l:.2e}");
    // f32 rounding of the forces only.
    assert!(worst_p < 1e-6, "momentum drifted by {worst_p} of sum m|v|");
    assert!(
        worst_l < 1e-6,
        "contacts changed the angular momentum by {worst_l} of its scale"
    );
    assert!(
        most_piece_contacts >= 2,
        "the rods should touch at two or more places at once ({most_piece_contacts})"
    );
    assert!(touched_mixed, "the mixed clump should hit a rod");
}

#[test]
fn one_piece_composite_steps_like_the_plain_shape() {
    let base = r#"[simulation]
steps = 3000
gravity = [0.0, 0.0, -9.81]
[[material]]
name = "m"
density = 2500.0
stiffness = 1.0e4
restitution = 0.3
friction = 0.5
[[shape]]
name = "brick"
box = { half_extents = [0.01, 0.006, 0.004] }
[[shape]]
name = "ball"
sphere = { radius = 0.005 }
[[shape]]
name = "one"
composite = [ { shape = "brick" } ]
[[shape]]
name = "oneball"
composite = [ { shape = "ball" } ]
[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "m"
[[body]]
shape = "BRICK"
material = "m"
position = [0.0, 0.0, 0.02]
orientation = [0.9659258, 0.2588190, 0.0, 0.0]
angular_velocity = [1.0, 2.0, 0.5]
[[body]]
shape = "BALL"
material = "m"
position = [0.004, 0.002, 0.04]
[[body]]
shape = "brick"
material = "m"
position = [0.05, 0.0, 0.01]
"#;
    let plain = parse(&base.replace("BRICK", "brick").replace("BALL", "ball"));
    let clump = parse(&base.replace("BRICK", "one").replace("BALL", "oneball"));
    let (mut a, mut b) = (plain.world(), clump.world());
    assert!(b.has_composites() && !a.has_composites());
    assert_eq!(a.dt.to_bits(), b.dt.to_bits());
    for step in 0..3000 {
        a.step().unwrap();
        b.step().unwrap();
        for i in 0..a.len() {
            assert!(
                a.state.position[i].to_array().map(f64::to_bits)
                    == b.state.position[i].to_array().map(f64::to_bits)
                    && a.state.orientation[i].to_array().map(f32::to_bits)
                        == b.state.orientation[i].to_array().map(f32::to_bits)
                    && a.state.angular_momentum[i].to_array().map(f32::to_bits)
                        == b.state.angular_momentum[i].to_array().map(f32::to_bits),
                "body {i} differs at step {step}"
            );
        }
    }
    assert!(a.contact_count() > 0);
}

#[test]
fn decomposed_l_block_has_the_l_volume_and_rests_on_a_floor() {
    let s = 0.01f32;
    let text = format!(
        r#"[simulation]
duration = 1.0
gravity = [0.0, 0.0, -9.81]
{MATERIAL}
[[shape]]
name = "l"
mesh = {{ file = "meshes/l-block.obj", scale = {s}, mode = "decompose" }}
[[shape]]
name = "hull"
mesh = {{ file = "meshes/l-block.obj", scale = {s} }}
[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "m"
[[body]]
shape = "l"
material = "m"
position = [0.0, 0.0, 0.012]
"#
    );
    let scene = parse(&text);
    let (l, hull) = (&scene.desc.shapes[0], &scene.desc.shapes[1]);
    let Shape::Composite(c) = &l.shape else {
        panic!("decompose gives a composite")
    };
    assert!(c.pieces.len() >= 2, "{} pieces", c.pieces.len());
    // The L: 3 unit cubes; its hull 3.5. VHACD's hulls are within a few percent.
    let unit = (s as f64).powi(3);
    let v = l.volume as f64 / unit;
    assert!((hull.volume as f64 / unit - 3.5).abs() < 1e-5);
    assert!((v - 3.0).abs() < 0.05 * 3.0, "decomposed volume {v} (L: 3)");
    // Centre of mass of the L (authored frame): (5/6, 1/2, 5/6).
    let com = l.com / s;
    assert!(
        (com - Vec3::new(5.0 / 6.0, 0.5, 5.0 / 6.0)).length() < 0.03,
        "{com}"
    );
    // Dropped with its long side down, it comes to rest with its centre at 5/6 of the unit
    // above the floor (the authored frame has the long side down at z = 0).
    let mut w = scene.world();
    let steps = scene.steps(w.dt);
    run(&mut w, steps);
    assert!(
        w.state.velocity[0].length() < 1e-3,
        "{}",
        w.state.velocity[0]
    );
    let z = w.state.position_f32(0).z / s;
    assert!(
        (z - 5.0 / 6.0).abs() < 0.04,
        "rests at {z} units (L: 0.833)"
    );
    assert!(w.contact_count() >= 2);
}

/// Clumps tumbling in a box: for the restart and thread-count tests.
const TUMBLE: &str = r#"[simulation]
steps = 600
dt = 2.0e-5
gravity = [0.0, 0.0, -9.81]
[[material]]
name = "m"
density = 1200.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.5
[container]
min = [0.0, 0.0, 0.0]
max = [0.06, 0.06, 0.08]
material = "m"
[[shape]]
name = "ball"
sphere = { radius = 0.004 }
[[shape]]
name = "cube"
box = { half_extents = [0.003, 0.003, 0.003] }
[[shape]]
name = "tri"
composite = [ { shape = "ball", offset = [0.004, 0.0, 0.0] },
              { shape = "ball", offset = [-0.002, 0.0035, 0.0] },
              { shape = "ball", offset = [-0.002, -0.0035, 0.0] } ]
[[shape]]
name = "hammer"
composite = [ { shape = "ball", offset = [-0.005, 0.0, 0.0] },
              { shape = "cube", offset = [0.004, 0.0, 0.0] } ]
[[group]]
shape = "tri"
material = "m"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 15, seed = 3 }
random_orientation = true
velocity = [0.4, -0.3, -0.5]
angular_velocity = [20.0, 5.0, -10.0]
[[group]]
shape = "hammer"
material = "m"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 6, seed = 4 }
random_orientation = true
velocity = [-0.4, 0.3, -0.2]
[[group]]
shape = "ball"
material = "m"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 8, seed = 5 }
"#;

fn bytes(w: &World) -> Vec<u8> {
    w.checkpoint_bytes("tumble.toml", TUMBLE, b"")
}

#[test]
fn clump_restart_is_bitwise_exact() {
    const TOTAL: u64 = 600;
    let mut straight = parse(TUMBLE).world();
    run(&mut straight, TOTAL);
    assert!(straight.rebuilds > 2, "rebuilds: {}", straight.rebuilds);
    assert!(straight.contact_count() > 0);
    for split in [0, 1, 131, 377] {
        let mut first = parse(TUMBLE).world();
        run(&mut first, split);
        let ckpt = Checkpoint::from_bytes(&bytes(&first)).expect("parses");
        let (_, mut resumed) = ckpt.world().expect("restores");
        assert_eq!(bytes(&resumed), bytes(&first), "restored state at {split}");
        run(&mut resumed, TOTAL - split);
        assert!(
            bytes(&resumed) == bytes(&straight),
            "state differs after a restart at step {split}"
        );
    }
}

#[test]
fn clumps_do_not_depend_on_the_thread_count() {
    let result = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut w = parse(TUMBLE).world();
            run(&mut w, 300);
            bytes(&w)
        })
    };
    let one = result(1);
    assert!(one == result(3), "1 and 3 threads differ");
}
