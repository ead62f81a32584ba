//! Sinks ([`clatter::sink`]) against closed forms: bodies dropped from known heights are
//! removed when their centre enters the box, at `t = sqrt(2 h / g)` (within one step of the
//! integrator), one at a time, with the exact mass; removed bodies stay frozen and never
//! come back; a body resting on one that is removed falls freely from the next step on
//! (through the removed body's place, into the same sink).
//! Also run on the GPU by clatter-gpu's `tests/physics.rs` (the same file, GPU steps).

#[path = "common/step.rs"]
mod step_backend;
use clatter::World;
use clatter::scene::Scene;
use step_backend::{step, step_n};

const G: f64 = 9.81;
const DT: f64 = 2.0e-4;
const R: f64 = 0.01;
/// Drop heights of the body centres above the sink's top face (z = 0).
const HEIGHTS: [f64; 5] = [0.013, 0.05, 0.1, 0.17, 0.23];

/// Five spheres far apart (no contacts) above a sink box whose top face is z = 0.
fn drop_scene() -> Scene {
    let mut text = format!(
        r#"
[simulation]
steps = 1
dt = {DT}
gravity = [0.0, 0.0, -{G}]

[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4
restitution = 0.5
friction = 0.5

[[shape]]
name = "ball"
sphere = {{ radius = {R} }}

[[sink]]
min = [-1.0, -1.0, -1.0]
max = [1.0, 1.0, 0.0]
"#
    );
    for (k, h) in HEIGHTS.iter().enumerate() {
        text += &format!(
            "\n[[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [{}, 0.0, {h}]\n",
            0.1 * k as f64 - 0.2
        );
    }
    Scene::parse(&text, "drop.toml").expect("the drop scene is valid")
}

#[test]
fn dropped_bodies_enter_the_sink_at_the_free_fall_time() {
    let mut w = drop_scene().world();
    let n = w.len();
    let mut removed_at = vec![None; n];
    let mut frozen = vec![None; n];
    let steps = ((2.0 * HEIGHTS[4] / G).sqrt() / DT) as u64 + 20;
    let mut last = 0;
    for s in 1..=steps {
        step(&mut w).expect("free fall does not blow up");
        let d = w.discharged();
        assert!(d.count >= last, "the count never decreases");
        last = d.count;
        let mut expect_mass = 0.0;
        for i in 0..n {
            if w.is_removed(i) {
                expect_mass += w.consts.mass[i] as f64;
                match frozen[i] {
                    None => {
                        removed_at[i] = Some(s);
                        frozen[i] = Some((w.state.position[i], w.state.velocity[i]));
                        // Its centre is in the box [-1, 1]^2 x [-1, 0].
                        assert!(w.state.position[i].z <= 0.0, "body {i}");
                    }
                    Some(f) => assert_eq!(
                        f,
                        (w.state.position[i], w.state.velocity[i]),
                        "removed body {i} must stay frozen"
                    ),
                }
            } else {
                assert!(frozen[i].is_none(), "body {i} came back at step {s}");
                assert!(
                    w.state.position[i].z > 0.0,
                    "body {i} is below the sink's top"
                );
            }
        }
        assert_eq!(
            d.count,
            removed_at.iter().filter(|r| r.is_some()).count() as u64
        );
        assert_eq!(
            d.mass, expect_mass,
            "the mass is the sum of the removed masses"
        );
    }
    for (i, h) in HEIGHTS.iter().enumerate() {
        let t = (2.0 * h / G).sqrt();
        let s = removed_at[i].unwrap_or_else(|| panic!("body {i} (h = {h}) was never removed"));
        let t_removed = s as f64 * DT;
        assert!(
            (t_removed - t).abs() <= DT * 1.0001,
            "body {i}: removed at t = {t_removed}, free fall reaches the sink at {t}"
        );
    }
    let d = w.discharged();
    assert_eq!(d.count, n as u64);
    // Removed bodies count in no kinetic energy or momentum.
    assert_eq!(w.kinetic_energy(), 0.0);
    assert_eq!(w.momentum(), [0.0; 3]);
}

/// Ball A rests on ball B, which rests on the floor; `sink` puts a box around B's centre.
fn stack(sink: bool) -> World {
    let k = 1.0e3f64;
    let m = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    // Static overlaps of the linear springs: the floor carries 2 m g, the contact m g.
    let zb = R - 2.0 * m * G / k;
    let za = zb + 2.0 * R - m * G / k;
    let sink = if sink {
        format!(
            "[[sink]]\nmin = [-{R}, -{R}, 0.0]\nmax = [{R}, {R}, {}]\n",
            1.5 * R
        )
    } else {
        String::new()
    };
    let text = format!(
        r#"
[simulation]
steps = 1
dt = 5.0e-5
gravity = [0.0, 0.0, -{G}]

[[material]]
name = "m"
density = 1000.0
stiffness = {k}
restitution = 0.3
friction = 0.5

[[shape]]
name = "ball"
sphere = {{ radius = {R} }}

[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "m"

[[body]]
shape = "ball"
material = "m"
position = [0.0, 0.0, {zb}]

[[body]]
shape = "ball"
material = "m"
position = [0.0, 0.0, {za}]

{sink}
"#
    );
    Scene::parse(&text, "stack.toml")
        .expect("the stack scene is valid")
        .world()
}

#[test]
fn a_body_resting_on_a_removed_one_falls_freely() {
    // Without the sink, A stays where it is.
    let mut still = stack(false);
    let za = still.state.position[1].z;
    step_n(&mut still, 200).expect("steps");
    assert!(
        (still.state.position[1].z - za).abs() < 1e-5,
        "A rests on B: {} vs {za}",
        still.state.position[1].z
    );
    // With it, B goes in the first step; A's contact force of that step is the last.
    let mut w = stack(true);
    step(&mut w).expect("step");
    assert!(w.is_removed(0) && !w.is_removed(1));
    let b = (w.state.position[0], w.state.velocity[0]);
    let (z1, v1) = (w.state.position[1].z, w.state.velocity[1].z as f64);
    let k = 100u64;
    step_n(&mut w, k).expect("steps");
    let dt = w.dt as f64;
    let v = w.state.velocity[1].z as f64;
    let z = w.state.position[1].z;
    // Semi-implicit Euler in free fall: v_k = v_1 - g k dt, z_k = z_1 + k v_1 dt - g dt^2 k(k+1)/2.
    let kf = k as f64;
    assert!(
        (v - (v1 - G * kf * dt)).abs() < 1e-4 * G * kf * dt,
        "v = {v}"
    );
    let z_free = z1 + kf * v1 * dt - G * dt * dt * kf * (kf + 1.0) / 2.0;
    assert!((z - z_free).abs() < 1e-6, "z = {z}, free fall {z_free}");
    // A falls freely through B's frozen place (B exerts no force) into the same sink: at the
    // first step whose free-fall height is inside the box (top at 1.5 R), within one step.
    let top = 1.5 * R;
    let expected = (1u64..)
        .find(|&k| z1 + k as f64 * v1 * dt - G * dt * dt * (k * (k + 1)) as f64 / 2.0 <= top)
        .unwrap();
    let mut k_removed = k;
    while !w.is_removed(1) {
        step(&mut w).expect("step");
        k_removed += 1;
        assert!(k_removed < 10 * expected, "A never reached the sink");
    }
    assert!(
        k_removed.abs_diff(expected) <= 1,
        "A removed {k_removed} steps after B, free fall says {expected}"
    );
    assert_eq!(w.discharged().count, 2);
    assert_eq!(
        b,
        (w.state.position[0], w.state.velocity[0]),
        "B stays frozen"
    );
}
