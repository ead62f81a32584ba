//! Shapes from mesh files (missing, garbled, degenerate, badly scaled) and composite shapes.

use crate::harness::*;

// ---- Shapes from mesh files -------------------------------------------------------------

/// A closed cube as OBJ (vertices +-1).
const CUBE_OBJ: &str = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// `BASE` with its sphere replaced by `mesh = { .. }` (`mesh` is the inside of the braces).
fn mesh_scene(mesh: &str) -> String {
    edit(
        "sphere = { radius = 0.01 }",
        &format!("mesh = {{ {mesh} }}"),
    )
}

/// Checks a mesh case: the error is on the `mesh = ` line and names `field` and the mesh file.
fn check_mesh(case: &str, mesh: &str, files: &[(&str, &[u8])], needles: &[&str]) {
    let text = mesh_scene(mesh);
    check_with_files(case, &text, line_of(&text, "mesh = "), needles, files);
}

#[test]
fn mesh_scene_is_valid() {
    let dir = case_dir("mesh-valid");
    std::fs::write(dir.join("cube.obj"), CUBE_OBJ).unwrap();
    let scene = dir.join("ok.toml");
    std::fs::write(&scene, mesh_scene(r#"file = "cube.obj", scale = 0.01"#)).unwrap();
    let s = clatter::scene::Scene::load(&scene).unwrap_or_else(|e| panic!("{e}"));
    assert!((s.desc.shapes[0].volume - 8e-6).abs() < 1e-10);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mesh_file_missing() {
    check_mesh(
        "mesh-missing",
        r#"file = "rock.obj""#,
        &[],
        &[
            "shape[0].mesh.file",
            "rock.obj",
            "cannot read the mesh file",
        ],
    );
}

#[test]
fn mesh_unknown_extension() {
    check_mesh(
        "mesh-ext",
        r#"file = "rock.off""#,
        &[("rock.off", b"OFF\n")],
        &[
            "shape[0].mesh.file",
            "rock.off",
            "unknown mesh file extension `.off`",
        ],
    );
}

#[test]
fn mesh_garbled_files() {
    let garbage: Vec<u8> = (0..200u32).map(|i| (i * 7919 % 251) as u8).collect();
    check_mesh(
        "mesh-garbled-stl",
        r#"file = "rock.stl""#,
        &[("rock.stl", &garbage)],
        &[
            "shape[0].mesh.file",
            "rock.stl",
            "cannot parse the STL file",
        ],
    );
    check_mesh(
        "mesh-garbled-ply",
        r#"file = "rock.ply""#,
        &[(
            "rock.ply",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1 2\n",
        )],
        &[
            "shape[0].mesh.file",
            "rock.ply",
            "cannot parse the PLY file",
        ],
    );
    check_mesh(
        "mesh-garbled-obj",
        r#"file = "rock.obj""#,
        &[("rock.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 99\n")],
        &[
            "shape[0].mesh.file",
            "rock.obj",
            "cannot parse the OBJ file",
        ],
    );
}

#[test]
fn mesh_empty() {
    check_mesh(
        "mesh-empty",
        r#"file = "rock.obj""#,
        &[("rock.obj", b"# nothing here\nv 0 0 0\nv 1 0 0\n")],
        &["shape[0].mesh.file", "rock.obj", "empty mesh"],
    );
}

#[test]
fn mesh_non_finite_vertex() {
    let obj = CUBE_OBJ.replacen("v 1 1 1", "v 1 nan 1", 1);
    check_mesh(
        "mesh-nan",
        r#"file = "rock.obj""#,
        &[("rock.obj", obj.as_bytes())],
        &["shape[0].mesh.file", "rock.obj", "non-finite coordinate"],
    );
}

#[test]
fn mesh_degenerate() {
    check_mesh(
        "mesh-flat",
        r#"file = "flat.obj""#,
        &[(
            "flat.obj",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
        )],
        &["shape[0].mesh.file", "flat.obj", "degenerate hull"],
    );
}

#[test]
fn mesh_bad_scale() {
    for (case, scale) in [
        ("zero", "0.0"),
        ("negative", "-1.0"),
        ("nan", "nan"),
        ("axis", "[1.0, 0.0, 1.0]"),
    ] {
        check_mesh(
            &format!("mesh-scale-{case}"),
            &format!(r#"file = "cube.obj", scale = {scale}"#),
            &[("cube.obj", CUBE_OBJ.as_bytes())],
            &["shape[0].mesh.scale", "positive finite"],
        );
    }
}

#[test]
fn mesh_decompose_errors() {
    check_mesh(
        "mesh-decompose-flat",
        r#"file = "flat.obj", mode = "decompose""#,
        &[(
            "flat.obj",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
        )],
        &["shape[0].mesh.file", "flat.obj", "convex decomposition"],
    );
    check_mesh(
        "mesh-decompose-bad-index",
        r#"file = "bad.obj", mode = "decompose""#,
        &[("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")],
        &["shape[0].mesh.file", "bad.obj"],
    );
    check_mesh(
        "mesh-mode-unknown",
        r#"file = "cube.obj", mode = "shrinkwrap""#,
        &[("cube.obj", CUBE_OBJ.as_bytes())],
        &["shape[0].mesh.mode", "unknown mesh mode `shrinkwrap`"],
    );
}

#[test]
fn mesh_and_sphere_together() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "sphere = { radius = 0.01 }\nmesh = { file = \"cube.obj\" }",
    );
    check_with_files(
        "mesh-and-sphere",
        &text,
        line_of(&text, "[[shape]]"),
        &["shape[0]", "exactly one of"],
        &[("cube.obj", CUBE_OBJ.as_bytes())],
    );
}

/// `BASE` with a composite shape `clump` (pieces given by `pieces`) used by the body.
fn composite_scene(pieces: &str) -> String {
    edit(
        "[[body]]\nshape = \"ball\"",
        &format!(
            "[[shape]]\nname = \"clump\"\ncomposite = {pieces}\n\n[[body]]\nshape = \"clump\""
        ),
    )
}

#[test]
fn composite_without_pieces() {
    let text = composite_scene("[]");
    check(
        "composite-empty",
        &text,
        "composite = []",
        &["shape[1].composite", "at least one piece"],
    );
}

#[test]
fn composite_unknown_piece() {
    let text =
        composite_scene(r#"[ { shape = "ball" }, { shape = "rock", offset = [0.01, 0.0, 0.0] } ]"#);
    check(
        "composite-unknown",
        &text,
        "composite = ",
        &["shape[1].composite[1].shape", "unknown shape `rock`"],
    );
}

#[test]
fn composite_of_a_composite() {
    let text = composite_scene(r#"[ { shape = "ball" } ]"#).replace(
        "[[body]]",
        "[[shape]]\nname = \"outer\"\ncomposite = [ { shape = \"clump\" } ]\n\n[[body]]",
    );
    check(
        "composite-nested",
        &text,
        "{ shape = \"clump\" }",
        &["shape[2].composite[0].shape", "itself a composite"],
    );
}

#[test]
fn composite_nan_offset_and_bad_orientation() {
    let text = composite_scene(r#"[ { shape = "ball", offset = [nan, 0.0, 0.0] } ]"#);
    check(
        "composite-nan",
        &text,
        "composite = ",
        &["shape[1].composite[0].offset", "finite"],
    );
    let text = composite_scene(r#"[ { shape = "ball", orientation = [0.0, 0.0, 0.0, 0.0] } ]"#);
    check(
        "composite-quat",
        &text,
        "composite = ",
        &["shape[1].composite[0].orientation", "non-zero quaternion"],
    );
}

#[test]
fn composite_and_sphere_together() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "sphere = { radius = 0.01 }\ncomposite = [ { shape = \"ball\" } ]",
    );
    check_line(
        "composite-and-sphere",
        &text,
        line_of(&text, "[[shape]]"),
        &["shape[0]", "got `composite` and another"],
    );
}

#[test]
fn group_shapes_unknown_name() {
    let text = format!(
        "{BASE}\n[[group]]\nshapes = [\"ball\", \"pebble\"]\nmaterial = \"steel\"\nlattice = {{ min = [0.0, 0.0, 1.0], max = [0.1, 0.0, 1.0], spacing = 0.05 }}\n"
    );
    check(
        "group-shapes-unknown",
        &text,
        "shapes = [",
        &["group[0].shapes[1]", "pebble"],
    );
}

#[test]
fn group_shapes_empty_or_with_shape() {
    let text = format!(
        "{BASE}\n[[group]]\nshapes = []\nmaterial = \"steel\"\nlattice = {{ min = [0.0, 0.0, 1.0], max = [0.1, 0.0, 1.0], spacing = 0.05 }}\n"
    );
    check(
        "group-shapes-empty",
        &text,
        "shapes = [",
        &["group[0].shapes"],
    );
    let text = format!(
        "{BASE}\n[[group]]\nshape = \"ball\" # both\nshapes = [\"ball\"]\nmaterial = \"steel\"\nlattice = {{ min = [0.0, 0.0, 1.0], max = [0.1, 0.0, 1.0], spacing = 0.05 }}\n"
    );
    check(
        "group-shape-and-shapes",
        &text,
        "# both",
        &["group[0].shape", "not both"],
    );
}
