//! Boundary meshes as users have them (CPU): each awkward mesh of `common/awkward.rs`
//! (inverted closed drum, mixed winding, duplicates/slivers/gaps, a T-junction, a
//! non-manifold fin, a binary STL with a bogus header, an OBJ with quads and negative
//! indices) runs with the same physics as its clean twin (bit for bit where the cleaned mesh
//! is the twin's, else within a stated tolerance), says what was repaired in one warning or
//! note line, and the meshes that cannot be surfaces are refused naming the triangle.

use std::path::Path;

use clatter::World;
use clatter::scene::Scene;

#[path = "common/meshes.rs"]
mod meshes;

#[path = "common/awkward.rs"]
mod awkward;
use awkward::Expect;

/// Steps between compared states.
const CHUNK: u64 = 100;

/// The states of a scene's run, every [`CHUNK`] steps, and how many of those had a mesh
/// contact.
fn trajectory(scene: &Scene) -> (Vec<World>, usize) {
    let mut w = scene.world();
    let steps = scene.steps(w.dt);
    let mut states = Vec::new();
    let mut touching = 0;
    for _ in 0..steps / CHUNK {
        for _ in 0..CHUNK {
            w.step().expect("step");
        }
        touching += w.mesh_slots().iter().any(|s| s.touching) as usize;
        states.push(w.clone());
    }
    (states, touching)
}

fn load(p: &Path) -> Scene {
    Scene::load(p).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn awkward_meshes_run_as_their_clean_twins() {
    let d = awkward::dir("cpu");
    for case in awkward::cases(&d) {
        let (a, c) = (load(&case.awkward), load(&case.clean));
        // What was repaired is said once; the twin says nothing.
        let said = |s: &Scene| {
            s.warnings
                .iter()
                .chain(&s.notes)
                .filter(|l| l.contains("mesh `"))
                .count()
        };
        assert_eq!(said(&c), 0, "{}: clean twin {:?}", case.name, c.warnings);
        match case.warning {
            Some(p) => assert!(
                a.warnings.iter().filter(|w| w.contains(p)).count() == 1,
                "{}: warnings {:?}",
                case.name,
                a.warnings
            ),
            None => assert!(
                a.warnings.iter().all(|w| !w.contains("mesh `")),
                "{}: {:?}",
                case.name,
                a.warnings
            ),
        }
        match case.note {
            Some(p) => assert!(
                a.notes.len() == 1 && a.notes[0].contains(p),
                "{}: notes {:?}",
                case.name,
                a.notes
            ),
            None => assert!(a.notes.is_empty(), "{}: {:?}", case.name, a.notes),
        }
        let ((ta, touch_a), (tc, touch_c)) = (trajectory(&a), trajectory(&c));
        assert!(
            touch_c > 0 && touch_a == touch_c,
            "{}: mesh contacts {touch_a} vs {touch_c}",
            case.name
        );
        let mut worst = 0.0f32;
        for (k, (x, y)) in ta.iter().zip(&tc).enumerate() {
            match case.expect {
                Expect::Bitwise => {
                    assert_eq!(
                        x.state.position, y.state.position,
                        "{} chunk {k}",
                        case.name
                    );
                    assert_eq!(
                        x.state.velocity, y.state.velocity,
                        "{} chunk {k}",
                        case.name
                    );
                    assert_eq!(
                        x.state.angular_momentum, y.state.angular_momentum,
                        "{} chunk {k}",
                        case.name
                    );
                }
                Expect::Within(tol) => {
                    for i in 0..x.len() {
                        let dx = (x.state.position[i] - y.state.position[i]).length() as f32;
                        worst = worst.max(dx);
                        assert!(
                            dx <= tol,
                            "{} chunk {k} body {i}: {dx:e} m apart",
                            case.name
                        );
                    }
                }
            }
        }
        eprintln!(
            "{}: {} compared states, {touch_a} with mesh contacts, largest difference {worst:e} m",
            case.name,
            ta.len()
        );
    }
}

#[test]
fn meshes_that_cannot_be_surfaces_are_refused_naming_the_triangle() {
    let d = awkward::dir("cpu-refused");
    for (scene, phrase) in awkward::refused(&d) {
        let e = Scene::load(&scene).expect_err("refused");
        let msg = e.to_string();
        assert!(msg.contains(phrase), "{msg}");
        assert!(
            e.field.as_deref().is_some_and(|f| f.ends_with("mesh.file")),
            "{msg}"
        );
    }
}

#[test]
fn the_weld_tolerance_is_the_scene_s_to_set() {
    // Two triangles 1 mm apart at a shared edge: the default tolerance (1e-6 of the mesh's
    // size) keeps the gap, `weld = 2e-3` closes it.
    let d = awkward::dir("cpu-weld");
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 1.001 0 0\nv 2 0 0\nv 1.001 1 0\nf 1 2 3\nf 4 5 6\n";
    std::fs::write(d.join("gap.obj"), obj).unwrap();
    let scene = |weld: &str| {
        format!(
            "[simulation]\nsteps = 1\n[[material]]\nname = \"m\"\ndensity = 1000.0\nstiffness = 1e4\n[[shape]]\nname = \"b\"\nsphere = {{ radius = 0.1 }}\n[[body]]\nshape = \"b\"\nmaterial = \"m\"\nposition = [0.5, 0.3, 0.5]\n[[boundary]]\nmesh = {{ file = \"gap.obj\"{weld} }}\nmaterial = \"m\"\n"
        )
    };
    let path = d.join("s.toml").display().to_string();
    let plain = Scene::parse(&scene(""), &path).unwrap();
    assert_eq!(plain.boundaries[0].vertices.len(), 6);
    let welded = Scene::parse(&scene(", weld = 2e-3"), &path).unwrap();
    assert_eq!(welded.boundaries[0].vertices.len(), 4);
    assert!(
        welded
            .warnings
            .iter()
            .any(|w| w.contains("welded 2 vertices")),
        "{:?}",
        welded.warnings
    );
    let bad = Scene::parse(&scene(", weld = -1.0"), &path).unwrap_err();
    assert_eq!(bad.field.as_deref(), Some("boundary[0].mesh.weld"));
}

#[test]
fn mesh_shapes_read_awkward_files_like_their_clean_twins() {
    // Bodies' `mesh = { file }` shapes take the hull of the vertices, which no winding,
    // duplicate or header changes: a drum (scaled down to a grain) from a binary STL whose
    // header starts with `solid` and whose face count field is 0, wound inwards, has the
    // hull of the same drum from an OBJ; and the prism's volume, pi r^2 l sin(2 pi / n) n / (2 pi).
    let d = awkward::dir("cpu-shapes");
    let n = 144;
    let (v, t) = awkward::closed_drum(0.05, 0.04, n);
    let inward: Vec<[u32; 3]> = t.iter().map(|f| [f[0], f[2], f[1]]).collect();
    std::fs::write(
        d.join("bogus.stl"),
        awkward::binary_stl(&v, &inward, "solid cad", 0),
    )
    .unwrap();
    let mut obj = String::new();
    for p in &v {
        obj.push_str(&format!(
            "v {} {} {}\n",
            p[0] as f32, p[1] as f32, p[2] as f32
        ));
    }
    for f in &t {
        obj.push_str(&format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1));
    }
    std::fs::write(d.join("drum.obj"), obj).unwrap();
    let volume = |file: &str| {
        let text = format!(
            "[simulation]\nsteps = 1\n[[material]]\nname = \"m\"\ndensity = 1000.0\nstiffness = 1e4\n[[shape]]\nname = \"s\"\nmesh = {{ file = \"{file}\", scale = 0.1 }}\n[[body]]\nshape = \"s\"\nmaterial = \"m\"\nposition = [0.0, 0.0, 0.0]\n"
        );
        let s = Scene::parse(&text, &d.join("s.toml").display().to_string())
            .unwrap_or_else(|e| panic!("{e}"));
        s.desc.shapes[0].volume as f64
    };
    let (a, b) = (volume("bogus.stl"), volume("drum.obj"));
    let (r, l) = (0.005, 0.004);
    let tau = std::f64::consts::TAU;
    let prism = 0.5 * n as f64 * r * r * (tau / n as f64).sin() * l;
    assert!((a - b).abs() <= 1e-6 * b, "{a} vs {b}");
    assert!((a - prism).abs() <= 1e-5 * prism, "{a} vs {prism}");
}
