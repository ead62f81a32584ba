//! Awkward boundary meshes as users have them, each with its clean twin, for the CPU
//! (`crates/clatter/tests/awkward_meshes.rs`) and GPU (`crates/clatter-gpu/tests/awkward_meshes.rs`)
//! suites (included by `#[path]`). The files are written by the tests.
//!
//! Each [`Case`] is a scene whose `[[boundary]]` mesh is awkward (inverted closed drum, mixed
//! winding, duplicates, slivers and gaps, a T-junction, a non-manifold fin, a binary STL with
//! a bogus header, an OBJ with quads and negative indices) and the same scene with a clean
//! mesh of the same surface. The suites run both and compare the bodies' trajectories.

#![allow(dead_code)] // each suite uses its part

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::meshes::{floor_mesh, obj_text as obj};

/// How an awkward run must compare with its clean twin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Expect {
    /// Bit for bit: the cleaned mesh is the clean twin's.
    Bitwise,
    /// Positions within this many metres at every compared step (a different triangulation
    /// of the same surface, or the same surface split between boundaries).
    Within(f32),
}

/// One awkward mesh and its twin.
pub struct Case {
    pub name: &'static str,
    /// The scene with the awkward mesh, and the one with the clean twin.
    pub awkward: PathBuf,
    pub clean: PathBuf,
    pub expect: Expect,
    /// A phrase the scene's warning (or note, for `note`) must contain, if any.
    pub warning: Option<&'static str>,
    pub note: Option<&'static str>,
}

/// A fresh directory for the files of `suite`.
pub fn dir(suite: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("clatter-awkward-{}-{suite}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A binary STL of the triangles (f32 coordinates, each facet's normal from its winding),
/// with the given 80-byte header text and face count field.
pub fn binary_stl(v: &[[f64; 3]], t: &[[u32; 3]], header: &str, count: u32) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b[..header.len()].copy_from_slice(header.as_bytes());
    b.extend_from_slice(&count.to_le_bytes());
    for f in t {
        let p = f.map(|i| v[i as usize].map(|c| c as f32));
        let e1 = [0, 1, 2].map(|k| p[1][k] - p[0][k]);
        let e2 = [0, 1, 2].map(|k| p[2][k] - p[0][k]);
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-30);
        for c in n.iter().map(|c| c / len).chain(p.iter().flatten().copied()) {
            b.extend_from_slice(&c.to_le_bytes());
        }
        b.extend_from_slice(&0u16.to_le_bytes());
    }
    b
}

/// A closed drum about the y axis (radius `r`, length `l`, `n` facets around, end caps
/// fanned from their centres): `4 n` triangles, all wound outwards.
pub fn closed_drum(r: f64, l: f64, n: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        v.push([r * a.cos(), -0.5 * l, r * a.sin()]);
        v.push([r * a.cos(), 0.5 * l, r * a.sin()]);
    }
    let (c0, c1) = (v.len() as u32, v.len() as u32 + 1);
    v.push([0.0, -0.5 * l, 0.0]);
    v.push([0.0, 0.5 * l, 0.0]);
    let mut t = Vec::new();
    for k in 0..n {
        let (a, b) = (2 * k as u32, 2 * ((k + 1) % n) as u32);
        t.push([a, b, b + 1]);
        t.push([a, b + 1, a + 1]);
        t.push([c0, a, b]);
        t.push([c1, b + 1, a + 1]);
    }
    // Outwards: the normal points away from the centre (the drum is convex).
    for f in t.iter_mut() {
        let p = f.map(|i| glam::DVec3::from_array(v[i as usize]));
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        if n.dot(p[0] + p[1] + p[2]) < 0.0 {
            f.swap(1, 2);
        }
    }
    (v, t)
}

const MATERIAL: &str = r#"[[material]]
name = "steel"
density = 2500.0
stiffness = 2.0e4
friction = 0.4
restitution = 0.6
"#;

/// The drum scene: spheres and cubes inside a closed drum turning about y.
pub fn drum_scene(mesh: &str) -> String {
    let mut s = format!(
        "[simulation]\nsteps = 6000\ndt = 2.0e-5\n{MATERIAL}[[shape]]\nname = \"ball\"\nsphere = {{ radius = 0.006 }}\n[[shape]]\nname = \"die\"\nbox = {{ half_extents = [0.005, 0.005, 0.005] }}\n"
    );
    for (k, x) in [-0.02, 0.0, 0.02].iter().enumerate() {
        let shape = if k % 2 == 0 { "ball" } else { "die" };
        writeln!(
            s,
            "[[body]]\nshape = \"{shape}\"\nmaterial = \"steel\"\nposition = [{x}, 0.0, -0.036]\nvelocity = [0.0, 0.0, -0.3]"
        )
        .unwrap();
    }
    writeln!(
        s,
        "[[boundary]]\nmesh = {{ file = \"{mesh}\" }}\nmaterial = \"steel\"\nmotion = {{ angular_velocity = [0.0, 3.0, 0.0], center = [0.0, 0.0, 0.0] }}"
    )
    .unwrap();
    s
}

/// The floor scene: a ball rolling and a cube sliding across a 200-triangle floor, and a
/// ball running at a fin standing on the floor (only where `fin` names its separate mesh,
/// or the floor mesh carries it); `meshes` are the `[[boundary]]` files.
fn floor_scene(meshes: &[&str]) -> String {
    let mut s = format!(
        "[simulation]\nsteps = 2500\ndt = 2.0e-5\n{MATERIAL}[[shape]]\nname = \"ball\"\nsphere = {{ radius = 0.01 }}\n[[shape]]\nname = \"die\"\nbox = {{ half_extents = [0.008, 0.008, 0.008] }}\n"
    );
    s.push_str(
        "[[body]]\nshape = \"ball\"\nmaterial = \"steel\"\nposition = [-0.05, -0.011, 0.01]\nvelocity = [1.0, 0.0, 0.0]\nangular_velocity = [0.0, 100.0, 0.0]\n",
    );
    s.push_str(
        "[[body]]\nshape = \"die\"\nmaterial = \"steel\"\nposition = [-0.05, 0.025, 0.008]\nvelocity = [0.8, 0.1, 0.0]\n",
    );
    s.push_str(
        "[[body]]\nshape = \"ball\"\nmaterial = \"steel\"\nposition = [-0.01, 0.085, 0.01]\nvelocity = [0.0, -0.5, 0.0]\n",
    );
    for m in meshes {
        writeln!(
            s,
            "[[boundary]]\nmesh = {{ file = \"{m}\" }}\nmaterial = \"steel\""
        )
        .unwrap();
    }
    s
}

fn write(d: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn flip(t: &[u32; 3]) -> [u32; 3] {
    [t[0], t[2], t[1]]
}

/// The floor of the floor scene: `floor_mesh(10, 0.1)` (squares of 0.02 m).
fn floor() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    floor_mesh(10, 0.1)
}

/// Vertex `(i, j)` of [`floor`].
fn at(i: u32, j: u32) -> u32 {
    j * 11 + i
}

/// Every case, its files written under `d`.
pub fn cases(d: &Path) -> Vec<Case> {
    let mut out = vec![drum_case(d)];
    out.extend(floor_cases(d));
    out.extend(format_cases(d));
    out
}

fn drum_case(d: &Path) -> Case {
    let (v, t) = closed_drum(0.05, 0.04, 144);
    assert_eq!(t.len(), 576);
    let inward: Vec<[u32; 3]> = t.iter().map(flip).collect();
    write(
        d,
        "drum-out.stl",
        binary_stl(&v, &t, "clean", t.len() as u32),
    );
    write(
        d,
        "drum-in.stl",
        binary_stl(&v, &inward, "liggghts", t.len() as u32),
    );
    Case {
        name: "inverted closed drum (binary STL, 576 triangles, normals inwards)",
        awkward: write(d, "drum-in.toml", drum_scene("drum-in.stl")),
        clean: write(d, "drum-out.toml", drum_scene("drum-out.stl")),
        expect: Expect::Bitwise,
        warning: None,
        note: Some("wound inwards"),
    }
}

fn floor_cases(d: &Path) -> Vec<Case> {
    let (v, t) = floor();
    write(d, "floor.obj", obj(&v, &t));
    let clean = write(d, "floor.toml", floor_scene(&["floor.obj"]));
    let mut cases = Vec::new();
    // Mixed winding: every other triangle flipped (the first kept).
    let mixed: Vec<[u32; 3]> = t
        .iter()
        .enumerate()
        .map(|(k, f)| if k % 2 == 1 { flip(f) } else { *f })
        .collect();
    write(d, "mixed.obj", obj(&v, &mixed));
    cases.push(Case {
        name: "mixed winding",
        awkward: write(d, "mixed.toml", floor_scene(&["mixed.obj"])),
        clean: clean.clone(),
        expect: Expect::Bitwise,
        warning: None,
        note: Some("wound against their neighbours"),
    });
    // Duplicates (one re-wound), degenerate triangles, a sliver, and a gap: copies of
    // vertices 1e-9 m away used by later triangles.
    let (mut v2, mut t2) = (v.clone(), t.clone());
    t2.push(t[7]);
    t2.push(flip(&t[40]));
    t2.push([at(2, 2), at(3, 2), at(3, 2)]);
    t2.push([at(0, 0), at(1, 0), at(2, 0)]); // collinear
    v2.push([-0.05, -0.02, 1e-14]); // a sliver's apex, on the edge from (2, 4) to (3, 4)
    t2.push([at(2, 4), at(3, 4), v2.len() as u32 - 1]);
    for f in t2.iter_mut().skip(100).take(100) {
        for i in f.iter_mut() {
            let p = v[*i as usize];
            v2.push([p[0] + 1e-9, p[1] - 1e-9, p[2]]);
            *i = v2.len() as u32 - 1;
        }
    }
    write(d, "dirty.obj", obj(&v2, &t2));
    cases.push(Case {
        name: "duplicates, slivers and gaps",
        awkward: write(d, "dirty.toml", floor_scene(&["dirty.obj"])),
        clean: clean.clone(),
        expect: Expect::Bitwise,
        warning: Some("dropped 2 duplicate triangles"),
        note: None,
    });
    cases.push(t_junction_case(d, &clean));
    cases.push(fin_case(d));
    cases
}

/// A T-junction on the rolling ball's path: in square (4, 4) (diagonal from (4, 4) to
/// (5, 5)), one triangle is split at the diagonal's midpoint and the other is not.
fn t_junction_case(d: &Path, clean: &Path) -> Case {
    let (mut v, mut t) = floor();
    let (a, c) = (at(4, 4), at(5, 5));
    let k = t
        .iter()
        .position(|f| f.contains(&a) && f.contains(&c) && !f.contains(&at(5, 4)))
        .expect("the square's triangle left of the diagonal");
    let other = t[k].iter().copied().find(|&i| i != a && i != c).unwrap();
    let m = v.len() as u32;
    v.push([-0.01, -0.01, 0.0]);
    t[k] = [a, m, other];
    t.push([m, c, other]);
    write(d, "tjunction.obj", obj(&v, &t));
    Case {
        name: "T-junction",
        awkward: write(d, "tjunction.toml", floor_scene(&["tjunction.obj"])),
        clean: clean.to_path_buf(),
        expect: Expect::Within(1e-7),
        warning: Some("T-junction"),
        note: None,
    }
}

/// A fin (one vertical triangle) standing on the floor edge from (4, 8) to (5, 8): its base
/// edge is shared by three triangles. Its twin is the same fin as a boundary of its own.
fn fin_case(d: &Path) -> Case {
    let (mut v, mut t) = floor();
    let apex = v.len() as u32;
    v.push([-0.01, 0.06, 0.03]);
    let fin = [at(4, 8), at(5, 8), apex];
    t.push(fin);
    write(d, "fin.obj", obj(&v, &t));
    let fv = vec![v[at(4, 8) as usize], v[at(5, 8) as usize], v[apex as usize]];
    write(d, "fin-alone.obj", obj(&fv, &[[0, 1, 2]]));
    Case {
        name: "non-manifold fin",
        awkward: write(d, "fin.toml", floor_scene(&["fin.obj"])),
        clean: write(
            d,
            "fin-twin.toml",
            floor_scene(&["floor.obj", "fin-alone.obj"]),
        ),
        expect: Expect::Within(1e-6),
        warning: Some("1 edges shared by more than two triangles"),
        note: None,
    }
}

fn format_cases(d: &Path) -> Vec<Case> {
    let (v, t) = floor();
    // Binary STL whose header starts with "solid " (as some CAD exporters write it) and
    // whose face count field is 0.
    write(
        d,
        "floor-bin.stl",
        binary_stl(&v, &t, "binary", t.len() as u32),
    );
    write(
        d,
        "bogus.stl",
        binary_stl(&v, &t, "solid exported by a CAD tool", 0),
    );
    let mut cases = vec![Case {
        name: "binary STL with a bogus header",
        awkward: write(d, "bogus.toml", floor_scene(&["bogus.stl"])),
        clean: write(d, "floor-bin.toml", floor_scene(&["floor-bin.stl"])),
        expect: Expect::Bitwise,
        warning: None,
        note: None,
    }];
    // OBJ with quads (one per square, fanned from its first corner) and negative
    // (relative) indices, against the same triangles written out.
    let mut quad_obj = String::from("# quads, relative indices\no floor\n");
    let mut tris = Vec::new();
    let mut verts = Vec::new();
    for j in 0..10u32 {
        for i in 0..10u32 {
            let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            let q = if (i + j) % 2 == 0 {
                q
            } else {
                [q[1], q[2], q[3], q[0]]
            };
            for &k in &q {
                let p = v[k as usize];
                writeln!(quad_obj, "v {} {} {}", p[0], p[1], p[2]).unwrap();
                verts.push(p);
            }
            quad_obj.push_str("f -4 -3 -2 -1\n");
            let b = verts.len() as u32 - 4;
            tris.push([b, b + 1, b + 2]);
            tris.push([b, b + 2, b + 3]);
        }
    }
    write(d, "quads.obj", quad_obj);
    write(d, "quads-twin.obj", obj(&verts, &tris));
    cases.push(Case {
        name: "OBJ with quads and negative indices",
        awkward: write(d, "quads.toml", floor_scene(&["quads.obj"])),
        clean: write(d, "quads-twin.toml", floor_scene(&["quads-twin.obj"])),
        expect: Expect::Bitwise,
        warning: None,
        note: None,
    });
    cases
}

/// Meshes that cannot be a surface, each refused naming what is wrong: (file name, file
/// contents, a phrase of the message).
pub fn refused(d: &Path) -> Vec<(PathBuf, &'static str)> {
    let ply_out_of_range = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 99\n";
    let all_degenerate = "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n";
    let mut out = Vec::new();
    for (file, text, phrase) in [
        ("range.ply", ply_out_of_range, "triangle 1 uses vertex 99"),
        ("flat.obj", all_degenerate, "every triangle is degenerate"),
    ] {
        write(d, file, text);
        let scene = write(d, &format!("{file}.toml"), floor_scene(&[file]));
        out.push((scene, phrase));
    }
    out
}
