//! `clatter run --format vtk` writes `shapes_NNNNNN.vtu`: every body as its real geometry.
//! Read back with an independent reader (meshio): each body's faces have their vertex
//! centroid at the body's position (to within the offset of a hull's vertex centroid from
//! its centre of mass, checked against clatter's own shape), and the volume enclosed by
//! each body's faces (divergence theorem) is its shape's volume; the cell data matches the
//! bodies file.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use clatter::scene::Scene;
use clatter_geom::Shape;

const SCRIPT: &str = r#"
import json, sys
import numpy as np
import meshio
m = meshio.read(sys.argv[1])
b = meshio.read(sys.argv[2])
pts = m.points.astype(float)
faces, ids = [], []
for block, bid in zip(m.cells, m.cell_data["id"]):
    assert block.type in ("polygon", "triangle", "quad") or block.type.startswith("polygon"), block.type
    for f, i in zip(block.data, bid):
        faces.append([int(k) for k in f])
        ids.append(int(np.ravel(i)[0]))
by_body = {}
for f, i in zip(faces, ids):
    by_body.setdefault(i, []).append(f)
res = {}
for i, fs in by_body.items():
    verts = sorted({k for f in fs for k in f})
    c = pts[verts].mean(axis=0)
    volume = 0.0
    for f in fs:
        # Divergence theorem, relative to the vertex centroid (well conditioned): fan each
        # face from its first vertex.
        p = pts[f] - c
        for k in range(1, len(f) - 1):
            volume += float(np.dot(p[0], np.cross(p[k], p[k + 1]))) / 6.0
    res[str(i)] = {"volume": volume, "centroid": c.tolist(), "faces": len(fs)}
vel = {}
for block, bid, v in zip(m.cells, m.cell_data["id"], m.cell_data["velocity"]):
    for i, vv in zip(bid, v):
        vel[str(int(np.ravel(i)[0]))] = [float(x) for x in vv]
print(json.dumps({"bodies": res, "velocity": vel, "time": float(m.field_data["TimeValue"][0]),
                  "positions": b.points.astype(float).tolist()}))
"#;

fn meshio_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import meshio, numpy"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        if std::env::var_os("CI").is_some() {
            panic!("python3 with meshio is required in CI (python3 -m pip install meshio)");
        }
        eprintln!(
            "\n*** SKIPPED: python3 with meshio is not available; the VTK shapes test did not run ***\n"
        );
    }
    ok
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("clatter-vtk-shapes-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Runs `scene` for `steps` with VTK output and checks the last shapes frame against the
/// bodies frame and the scene's shapes.
fn check_scene(scene: &Path, steps: u64) {
    let out = out_dir(scene.file_stem().unwrap().to_str().unwrap());
    let o = Command::new(env!("CARGO_BIN_EXE_clatter"))
        .arg("run")
        .arg(scene)
        .args([
            "--steps",
            &steps.to_string(),
            "--format",
            "vtk",
            "--backend",
            "cpu",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .output()
        .expect("run clatter");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let pvd = std::fs::read_to_string(out.join("shapes.pvd")).expect("shapes.pvd");
    let frame = format!("shapes_{steps:06}.vtu");
    assert!(pvd.contains(&frame), "{pvd}");
    let py = Command::new("python3")
        .arg("-c")
        .arg(SCRIPT)
        .arg(out.join(&frame))
        .arg(out.join(format!("bodies_{steps:06}.vtu")))
        .output()
        .expect("run python3");
    assert!(
        py.status.success(),
        "meshio read-back failed:\n{}",
        String::from_utf8_lossy(&py.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&py.stdout).expect("JSON");
    let s = Scene::load(scene).unwrap();
    let world = s.world();
    let bodies = json["bodies"].as_object().unwrap();
    assert_eq!(bodies.len(), s.desc.bodies.len(), "every body drawn");
    let positions = json["positions"].as_array().unwrap();
    let (mut total, mut expected_total) = (0.0, 0.0);
    for (i, b) in s.desc.bodies.iter().enumerate() {
        let got = &bodies[&i.to_string()];
        let prepared = &world.shapes[b.shape as usize];
        let volume = got["volume"].as_f64().unwrap();
        let (expected_volume, offset, faces) = match &prepared.shape {
            // The icosphere is scaled to the sphere's volume; its vertex centroid is the centre.
            Shape::Sphere { .. } => (prepared.volume as f64, 0.0, 80),
            Shape::Polyhedron(h) => {
                let c = h.vertices.iter().sum::<glam::Vec3>() / h.vertices.len() as f32;
                (prepared.volume as f64, c.length() as f64, h.faces.len())
            }
            // Drawn as its pieces: the faces enclose the sum of the pieces' volumes (overlaps
            // twice); the vertex centroid is that of all the pieces' vertices.
            Shape::Composite(c) => {
                let (mut volume, mut faces, mut sum, mut count) = (0.0, 0, glam::DVec3::ZERO, 0);
                for p in &c.pieces {
                    match &p.shape {
                        Shape::Sphere { radius } => {
                            volume +=
                                clatter_geom::MassProperties::of_sphere(*radius as f64).volume;
                            faces += 80;
                            sum += p.position.as_dvec3() * 42.0;
                            count += 42;
                        }
                        Shape::Polyhedron(h) => {
                            volume += clatter_geom::MassProperties::of_polyhedron(h).volume;
                            faces += h.faces.len();
                            for v in &h.vertices {
                                sum += (p.position + p.orientation * *v).as_dvec3();
                            }
                            count += h.vertices.len();
                        }
                        Shape::Composite(_) => unreachable!("pieces are convex"),
                    }
                }
                (volume, (sum / count as f64).length(), faces)
            }
        };
        assert!(
            (volume - expected_volume).abs() < 1e-4 * expected_volume,
            "body {i}: volume {volume} vs {expected_volume}"
        );
        assert_eq!(got["faces"].as_u64(), Some(faces as u64), "body {i}: faces");
        let p: Vec<f64> = positions[i]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let c: Vec<f64> = got["centroid"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let d = ((0..3).map(|k| (c[k] - p[k]).powi(2)).sum::<f64>()).sqrt();
        let r = prepared.shape.bounding_radius() as f64;
        assert!(
            (d - offset).abs() < 1e-4 * r,
            "body {i}: vertex centroid {c:?} is {d} from the position {p:?}, expected {offset}"
        );
        total += volume;
        expected_total += expected_volume;
    }
    assert!((total - expected_total).abs() < 1e-4 * expected_total);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn shapes_frame_reads_back_with_meshio() {
    if !meshio_available() {
        return;
    }
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    // Mesh-file rocks and dice (polyhedra), then spheres and Platonic solids.
    check_scene(&scenes.join("rocks.toml"), 40);
    check_scene(&scenes.join("dice-box.toml"), 40);
    check_scene(&scenes.join("default.toml"), 20);
    // Composites, drawn as their pieces.
    check_scene(&scenes.join("clumps.toml"), 20);
}
