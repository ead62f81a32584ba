//! Shapes from mesh files (`[[shape]] mesh = { file = .. }`): the committed test meshes against
//! the exact volume and inertia of their Platonic solids, and the same solid written as OBJ,
//! ASCII STL, binary STL, ASCII PLY and binary PLY (by the helper below) giving the same shape.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clatter::scene::Scene;
use clatter_geom::{PreparedShape, RegularKind, Shape, convex_hull};
use glam::Vec3;

const PHI: f64 = 1.618_033_988_749_895;

/// A scene with one shape given by `shape_line` (a `mesh = ..` or other shape key), one body.
fn scene_with(shape_line: &str) -> String {
    format!(
        r#"[simulation]
steps = 1
[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4
[[shape]]
name = "s"
{shape_line}
[[body]]
shape = "s"
material = "m"
position = [0.0, 0.0, 1.0]
"#
    )
}

/// The prepared shape of `shape_line`, with mesh paths relative to `dir`.
fn load_shape(dir: &Path, shape_line: &str) -> PreparedShape {
    let file = dir.join("scene.toml");
    let scene = Scene::parse(&scene_with(shape_line), &file.display().to_string())
        .unwrap_or_else(|e| panic!("{e}"));
    scene.desc.shapes[0].clone()
}

fn scenes_meshes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/meshes")
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("clatter-meshes-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-30)
}

/// Checks volume and the (isotropic) principal moments against the analytic values.
fn check_solid(p: &PreparedShape, volume: f64, moment: f64, what: &str) {
    assert!(
        close(p.volume as f64, volume, 1e-5),
        "{what}: volume {} vs {volume}",
        p.volume
    );
    for k in 0..3 {
        assert!(
            close(p.unit_inertia[k] as f64, moment, 1e-4),
            "{what}: moment {k} {} vs {moment}",
            p.unit_inertia[k]
        );
    }
}

#[test]
fn committed_cube_obj_is_a_cube() {
    // Vertices (+-1)^3, edge a = 2: V = a^3, I = V a^2 / 6 at unit density.
    let p = load_shape(&scenes_meshes(), r#"mesh = { file = "cube.obj" }"#);
    check_solid(&p, 8.0, 8.0 * 4.0 / 6.0, "cube.obj");
    // Scaled by 0.5: V / 8, I / 32.
    let p = load_shape(
        &scenes_meshes(),
        r#"mesh = { file = "cube.obj", scale = 0.5 }"#,
    );
    check_solid(&p, 1.0, 8.0 * 4.0 / 6.0 / 32.0, "cube.obj x 0.5");
    // Anisotropic: a box of half extents (2, 1, 0.5).
    let p = load_shape(
        &scenes_meshes(),
        r#"mesh = { file = "cube.obj", scale = [2.0, 1.0, 0.5] }"#,
    );
    let b = load_shape(&scenes_meshes(), "box = { half_extents = [2.0, 1.0, 0.5] }");
    assert!(close(p.volume as f64, 8.0, 1e-6));
    for k in 0..3 {
        assert!(close(
            p.unit_inertia[k] as f64,
            b.unit_inertia[k] as f64,
            1e-5
        ));
    }
}

#[test]
fn committed_tetrahedron_ply_is_a_tetrahedron() {
    // Edge a = 2 sqrt 2: V = a^3 / (6 sqrt 2) = 8/3, I = V a^2 / 20.
    let a: f64 = 2.0 * 2f64.sqrt();
    let v = a.powi(3) / (6.0 * 2f64.sqrt());
    let p = load_shape(&scenes_meshes(), r#"mesh = { file = "tetrahedron.ply" }"#);
    check_solid(&p, v, v * a * a / 20.0, "tetrahedron.ply");
}

#[test]
fn committed_rock_is_a_valid_gpu_sized_hull() {
    let p = load_shape(&scenes_meshes(), r#"mesh = { file = "rock.obj" }"#);
    let Shape::Polyhedron(h) = &p.shape else {
        panic!("rock is a polyhedron")
    };
    assert!(h.vertices.len() <= clatter::scene::GPU_SHAPE_VERTICES);
    assert!(p.volume > 0.1 && p.volume < 1.0, "volume {}", p.volume);
    assert!(Scene::load(&scenes_meshes().join("../rocks.toml")).is_ok());
}

/// The faces of the Platonic solid `kind` (circumradius 1) as counter-clockwise loops.
fn solid(kind: RegularKind) -> (Vec<Vec3>, Vec<Vec<u32>>) {
    let hull = convex_hull(&kind.points(1.0)).unwrap();
    let loops = (0..hull.faces.len())
        .map(|f| hull.face_loop(f).to_vec())
        .collect();
    (hull.vertices.clone(), loops)
}

fn triangles(loops: &[Vec<u32>]) -> Vec<[u32; 3]> {
    loops
        .iter()
        .flat_map(|l| (1..l.len() - 1).map(move |i| [l[0], l[i], l[i + 1]]))
        .collect()
}

/// Writes `kind` as every supported file form; returns the file names.
fn write_all_forms(dir: &Path, kind: RegularKind) -> Vec<String> {
    let (v, loops) = solid(kind);
    let tris = triangles(&loops);
    let name = kind.name();
    let mut names = Vec::new();
    // OBJ, polygon faces, 1-based.
    let mut obj = String::new();
    for p in &v {
        writeln!(obj, "v {} {} {}", p.x, p.y, p.z).unwrap();
    }
    for l in &loops {
        let idx: Vec<String> = l.iter().map(|i| (i + 1).to_string()).collect();
        writeln!(obj, "f {}", idx.join(" ")).unwrap();
    }
    names.push(format!("{name}.obj"));
    std::fs::write(dir.join(&names[0]), obj).unwrap();
    // ASCII STL.
    let mut stl = format!("solid {name}\n");
    for t in &tris {
        stl += "facet normal 0 0 0\nouter loop\n";
        for &i in t {
            let p = v[i as usize];
            writeln!(stl, "vertex {} {} {}", p.x, p.y, p.z).unwrap();
        }
        stl += "endloop\nendfacet\n";
    }
    stl += &format!("endsolid {name}\n");
    names.push(format!("{name}_ascii.stl"));
    std::fs::write(dir.join(names.last().unwrap()), stl).unwrap();
    // Binary STL: 80-byte header (not starting with "solid"), count, 50 bytes per triangle.
    let mut bin = vec![0u8; 80];
    bin[..16].copy_from_slice(b"clatter test stl");
    bin.extend((tris.len() as u32).to_le_bytes());
    for t in &tris {
        bin.extend([0f32; 3].iter().flat_map(|x| x.to_le_bytes()));
        for &i in t {
            bin.extend(
                v[i as usize]
                    .to_array()
                    .iter()
                    .flat_map(|x| x.to_le_bytes()),
            );
        }
        bin.extend([0u8; 2]);
    }
    names.push(format!("{name}_binary.stl"));
    std::fs::write(dir.join(names.last().unwrap()), bin).unwrap();
    // PLY, ASCII and binary little endian, polygon faces.
    let header = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
            v.len(),
            loops.len()
        )
    };
    let mut ply = header("ascii");
    for p in &v {
        writeln!(ply, "{} {} {}", p.x, p.y, p.z).unwrap();
    }
    for l in &loops {
        let idx: Vec<String> = l.iter().map(u32::to_string).collect();
        writeln!(ply, "{} {}", l.len(), idx.join(" ")).unwrap();
    }
    names.push(format!("{name}_ascii.ply"));
    std::fs::write(dir.join(names.last().unwrap()), ply).unwrap();
    let mut ply = header("binary_little_endian").into_bytes();
    for p in &v {
        ply.extend(p.to_array().iter().flat_map(|x| x.to_le_bytes()));
    }
    for l in &loops {
        ply.push(l.len() as u8);
        ply.extend(l.iter().flat_map(|&i| (i as i32).to_le_bytes()));
    }
    names.push(format!("{name}_binary.ply"));
    std::fs::write(dir.join(names.last().unwrap()), ply).unwrap();
    names
}

/// Sorted vertices, for comparing hulls built from differently ordered inputs.
fn sorted_vertices(p: &PreparedShape) -> Vec<[f32; 3]> {
    let Shape::Polyhedron(h) = &p.shape else {
        panic!("a polyhedron")
    };
    let mut v: Vec<[f32; 3]> = h.vertices.iter().map(|v| v.to_array()).collect();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v
}

#[test]
fn every_format_of_a_solid_gives_the_same_shape() {
    let dir = tmp_dir("forms");
    // Analytic volume and moment at circumradius R (then scaled by 0.1 below: V x 1e-3,
    // I x 1e-5). Edges a: tetrahedron R sqrt(8/3), octahedron R sqrt 2, icosahedron
    // R / sin(2 pi / 5), dodecahedron 4 R / (sqrt 3 (1 + sqrt 5)).
    let s: f64 = 0.1;
    let cases: [(RegularKind, f64, f64); 4] = {
        let a_t = (8.0f64 / 3.0).sqrt();
        let v_t = a_t.powi(3) / (6.0 * 2f64.sqrt());
        let a_o = 2f64.sqrt();
        let v_o = 2f64.sqrt() / 3.0 * a_o.powi(3);
        let a_i = 1.0 / (2.0 * std::f64::consts::PI / 5.0).sin();
        let v_i = 5.0 / 12.0 * (3.0 + 5f64.sqrt()) * a_i.powi(3);
        let a_d = 4.0 / (3f64.sqrt() * (1.0 + 5f64.sqrt()));
        let v_d = (15.0 + 7.0 * 5f64.sqrt()) / 4.0 * a_d.powi(3);
        [
            (RegularKind::Tetrahedron, v_t, v_t * a_t * a_t / 20.0),
            (RegularKind::Octahedron, v_o, v_o * a_o * a_o / 10.0),
            (
                RegularKind::Icosahedron,
                v_i,
                v_i * PHI * PHI * a_i * a_i / 10.0,
            ),
            (
                RegularKind::Dodecahedron,
                v_d,
                v_d * (39.0 * PHI + 28.0) / 150.0 * a_d * a_d,
            ),
        ]
    };
    for (kind, volume, moment) in cases {
        let reference = load_shape(
            &dir,
            &format!(
                "polyhedron = {{ kind = \"{}\", radius = {s} }}",
                kind.name()
            ),
        );
        check_solid(
            &reference,
            volume * s.powi(3),
            moment * s.powi(5),
            kind.name(),
        );
        let expected = sorted_vertices(&reference);
        for file in write_all_forms(&dir, kind) {
            let p = load_shape(
                &dir,
                &format!("mesh = {{ file = \"{file}\", scale = {s} }}"),
            );
            let what = format!("{} from {file}", kind.name());
            check_solid(&p, volume * s.powi(3), moment * s.powi(5), &what);
            let got = sorted_vertices(&p);
            assert_eq!(got.len(), expected.len(), "{what}: vertex count");
            for (a, b) in got.iter().zip(&expected) {
                for k in 0..3 {
                    assert!(
                        (a[k] - b[k]).abs() < 1e-6,
                        "{what}: vertices {a:?} vs {b:?}"
                    );
                }
            }
        }
        // ASCII and binary STL store the same f32 triangles: the shapes are identical.
        let ascii = load_shape(
            &dir,
            &format!("mesh = {{ file = \"{}_ascii.stl\" }}", kind.name()),
        );
        let binary = load_shape(
            &dir,
            &format!("mesh = {{ file = \"{}_binary.stl\" }}", kind.name()),
        );
        assert_eq!(ascii, binary, "{}: ASCII and binary STL", kind.name());
        let ascii = load_shape(
            &dir,
            &format!("mesh = {{ file = \"{}_ascii.ply\" }}", kind.name()),
        );
        let binary = load_shape(
            &dir,
            &format!("mesh = {{ file = \"{}_binary.ply\" }}", kind.name()),
        );
        assert_eq!(ascii, binary, "{}: ASCII and binary PLY", kind.name());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn inside_out_and_open_meshes_are_fine_for_the_hull() {
    // The cube with every face reversed and one face missing: same hull, same shape.
    let dir = tmp_dir("inside-out");
    let text = std::fs::read_to_string(scenes_meshes().join("cube.obj")).unwrap();
    let mut out = String::new();
    let mut dropped = false;
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("f ") {
            if !dropped {
                dropped = true;
                continue;
            }
            let mut idx: Vec<&str> = rest.split_whitespace().collect();
            idx.reverse();
            writeln!(out, "f {}", idx.join(" ")).unwrap();
        } else {
            writeln!(out, "{line}").unwrap();
        }
    }
    std::fs::write(dir.join("odd.obj"), out).unwrap();
    let odd = load_shape(&dir, r#"mesh = { file = "odd.obj" }"#);
    let cube = load_shape(&scenes_meshes(), r#"mesh = { file = "cube.obj" }"#);
    assert!(close(odd.volume as f64, cube.volume as f64, 1e-6));
    assert_eq!(sorted_vertices(&odd), sorted_vertices(&cube));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn hull_too_large_for_the_gpu_is_a_warning() {
    // 400 points on a sphere (Fibonacci lattice), all on the hull, in faces that are not
    // those of the hull (the hull does not care).
    let dir = tmp_dir("large");
    let mut obj = String::new();
    let n = 400;
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let a = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
        writeln!(obj, "v {} {} {}", r * a.cos(), r * a.sin(), z).unwrap();
    }
    // (tobj keeps only the vertices that faces use: fan all of them.)
    for i in 2..n {
        writeln!(obj, "f 1 {} {}", i, i + 1).unwrap();
    }
    std::fs::write(dir.join("ball.obj"), obj).unwrap();
    let file = dir.join("scene.toml");
    let scene = Scene::parse(
        &scene_with(r#"mesh = { file = "ball.obj", scale = 0.01 }"#),
        &file.display().to_string(),
    )
    .unwrap();
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(
        scene.warnings[0].contains("400 hull vertices") && scene.warnings[0].contains("CPU"),
        "{}",
        scene.warnings[0]
    );
    let _ = std::fs::remove_dir_all(&dir);
}
