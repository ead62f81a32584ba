//! Sinks as state: a pile draining through a sink gives bitwise the same states and the same
//! removed bodies whatever the thread count; a restart from a checkpoint (also one written
//! right after a removal, while the contact list still holds the removed body) continues
//! bitwise; and bad `[[sink]]` tables are refused with the file, line and field.

use clatter::World;
use clatter::checkpoint::Checkpoint;
use clatter::scene::Scene;

/// Spheres and cubes falling into a box whose floor's left half is a sink.
const SCENE: &str = r#"
[simulation]
steps = 1
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
name = "cube"
polyhedron = { kind = "cube", radius = 0.006 }

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

[[group]]
shape = "cube"
material = "m"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.05], count = 15, seed = 3 }
random_orientation = true
velocity = [0.0, 0.0, -0.8]

[[group]]
shape = "ball"
material = "m"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.05], count = 20, seed = 5 }
velocity = [0.0, 0.0, -0.8]

[[sink]]
min = [0.0, 0.0, 0.0]
max = [0.03, 0.06, 0.012]
"#;

fn world() -> World {
    Scene::parse(SCENE, "drain.toml")
        .expect("the drain scene is valid")
        .world()
}

/// Every state bit and removed flag, in body order.
fn bits(w: &World) -> Vec<u32> {
    let s = &w.state;
    let mut out = Vec::new();
    for i in 0..w.len() {
        out.extend(s.position[i].to_array().into_iter().flat_map(|v| {
            let b = v.to_bits();
            [b as u32, (b >> 32) as u32]
        }));
        out.extend(s.velocity[i].to_array().map(f32::to_bits));
        out.extend(s.orientation[i].to_array().map(f32::to_bits));
        out.extend(s.orientation_residual[i].to_array().map(f32::to_bits));
        out.extend(s.angular_momentum[i].to_array().map(f32::to_bits));
        out.push(s.removed[i] as u32);
    }
    out
}

fn run(threads: usize, steps: u64) -> (Vec<u32>, Vec<(u64, u64, f64)>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut w = world();
        let mut rows = Vec::new();
        for s in 1..=steps {
            w.step().expect("no blow-up");
            if s % 100 == 0 {
                let d = w.discharged();
                rows.push((s, d.count, d.mass));
            }
        }
        (bits(&w), rows)
    })
}

#[test]
fn draining_is_independent_of_the_thread_count() {
    let (a, rows_a) = run(1, 3000);
    let (b, rows_b) = run(3, 3000);
    assert_eq!(rows_a, rows_b);
    assert!(a == b, "states differ between 1 and 3 threads");
    let last = rows_a.last().unwrap();
    assert!(last.1 > 0, "some bodies must have been removed: {rows_a:?}");
    assert!(last.1 < 35, "not all bodies are above the sink: {rows_a:?}");
}

#[test]
fn restart_with_removed_bodies_is_bitwise() {
    let mut w = world();
    // Up to the step that removes the first body: its pairs are still in the list and the
    // next step rebuilds without them.
    while w.discharged().count == 0 {
        w.step().expect("no blow-up");
        assert!(w.step_count < 5000, "nothing entered the sink");
    }
    assert!(w.needs_rebuild());
    let at_removal = w.checkpoint_bytes("drain.toml", SCENE, b"");
    // And a checkpoint some steps later.
    let mut later = w.clone();
    for _ in 0..300 {
        later.step().expect("no blow-up");
    }
    let at_later = later.checkpoint_bytes("drain.toml", SCENE, b"");
    for (bytes, mut original) in [(at_removal, w), (at_later, later)] {
        let ckpt = Checkpoint::from_bytes(&bytes).expect("parses");
        let (_, mut restored) = ckpt.world().expect("restores");
        assert_eq!(restored.state.removed, original.state.removed);
        assert_eq!(restored.discharged(), original.discharged());
        for _ in 0..600 {
            original.step().expect("no blow-up");
            restored.step().expect("no blow-up");
        }
        assert!(bits(&original) == bits(&restored), "restart diverged");
        assert_eq!(
            original.checkpoint_bytes("drain.toml", SCENE, b""),
            restored.checkpoint_bytes("drain.toml", SCENE, b"")
        );
        assert!(original.discharged().count > 0);
    }
}

/// The error of `SCENE` with its `[[sink]]` table replaced by `sink`.
fn sink_error(sink: &str, periodic: bool) -> String {
    let base = SCENE.split("[[sink]]").next().unwrap();
    let mut text = base.to_string();
    if periodic {
        text = text.replace(
            "gravity = [0.0, 0.0, -9.81]",
            "gravity = [0.0, 0.0, -9.81]\nperiodic = { min = [0.0, 0.0, 0.0], max = [0.06, 0.06, 0.08], axes = \"xy\" }",
        );
        text = text.replace("[container]", "[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nmaterial = \"m\"\n\n[unused]");
        let cut = text.find("[unused]").unwrap();
        let rest = &text[cut..];
        let next = rest.find("[[shape]]").unwrap();
        text = format!("{}{}", &text[..cut], &rest[next..]);
    }
    text += sink;
    match Scene::parse(&text, "bad.toml") {
        Ok(_) => panic!("accepted: {sink}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_sinks_are_refused_with_file_line_and_field() {
    let line_of =
        |needle: &str, text: &str| text[..text.find(needle).unwrap()].matches('\n').count() + 1;
    let cases = [
        (
            "[[sink]]\nmin = [0.0, 0.0, 0.02]\nmax = [0.03, 0.06, 0.01]\n",
            "`sink[0].max`",
            "max = [0.03",
            "below sink[0].min along z",
        ),
        (
            "[[sink]]\nmin = [0.0, nan, 0.0]\nmax = [0.03, 0.06, 0.01]\n",
            "`sink[0].min`",
            "min = [0.0, nan",
            "finite",
        ),
        (
            // Entirely below the container's floor.
            "[[sink]]\nmin = [0.0, 0.0, -0.5]\nmax = [0.06, 0.06, -0.1]\n",
            "`sink[0]`",
            "min = [0.0, 0.0, -0.5]",
            "entirely behind wall",
        ),
        (
            "[[sink]]\nmin = [0.0, 0.0]\nmax = [0.03, 0.06, 0.01]\n",
            "",
            "min = [0.0, 0.0]",
            "",
        ),
    ];
    for (sink, field, at, what) in cases {
        let msg = sink_error(sink, false);
        let text = format!("{}{sink}", SCENE.split("[[sink]]").next().unwrap());
        let line = line_of(at, &text);
        assert!(msg.starts_with(&format!("bad.toml:{line}:")), "{msg}");
        assert!(msg.contains(field) && msg.contains(what), "{msg}");
    }
    // Outside the periodic box along a periodic axis: positions are wrapped into it.
    let msg = sink_error(
        "[[sink]]\nmin = [0.07, 0.0, 0.0]\nmax = [0.09, 0.06, 0.01]\n",
        true,
    );
    assert!(
        msg.starts_with("bad.toml:")
            && msg.contains("`sink[0]`")
            && msg.contains("periodic box along x"),
        "{msg}"
    );
}
