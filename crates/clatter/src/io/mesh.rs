//! Mesh files for `[[shape]] mesh = { file = .. }`: the vertices of an OBJ, STL (ASCII or
//! binary) or PLY (ASCII or binary) surface mesh, from which the scene takes the convex hull.
//!
//! Readers: `tobj` (OBJ), `stl_io` (ASCII STL; binary STL is read here, detected by its size,
//! since CAD exporters often start a binary header with `solid`) and
//! `ply-rs-bw` (PLY, the maintained fork of `ply-rs`; every PLY encoding). The format comes
//! from the file's extension (case-insensitive).
//!
//! Only the vertices that the faces use matter for a hull, but a mesh without faces is refused
//! as empty: a file with no faces is more likely a point cloud or a mistake than a solid.
//! Face orientation, manifoldness and duplicated vertices do not matter to the hull.

use std::io::Cursor;
use std::path::Path;

/// A mesh read from a file: its vertices (as written, before any scale), its face count and
/// its faces as triangles (polygons fanned from their first vertex), for boundary meshes.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshVertices {
    /// Vertex positions, in file order (OBJ: per object, in the order tobj gives them).
    pub vertices: Vec<[f64; 3]>,
    /// Number of faces (polygons or triangles) in the file.
    pub faces: usize,
    /// The faces as triangles of indices into `vertices`, in file order, with the winding of
    /// the file (a polygon `a b c d` gives `a b c`, `a c d`). Indices are not checked here.
    pub triangles: Vec<[u32; 3]>,
}

/// Fans a polygon (vertex indices, file winding) into triangles.
fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}

/// The mesh formats by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ (`.obj`).
    Obj,
    /// STL, ASCII or binary (`.stl`).
    Stl,
    /// PLY, ASCII or binary (`.ply`).
    Ply,
}

impl MeshFormat {
    /// The format named by `path`'s extension, or a message listing the known ones.
    pub fn from_path(path: &Path) -> Result<MeshFormat, String> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("obj") => Ok(MeshFormat::Obj),
            Some("stl") => Ok(MeshFormat::Stl),
            Some("ply") => Ok(MeshFormat::Ply),
            Some(e) => Err(format!(
                "unknown mesh file extension `.{e}` (expected .obj, .stl or .ply)"
            )),
            None => Err("the mesh file has no extension (expected .obj, .stl or .ply)".to_string()),
        }
    }
}

/// Reads the vertices of the mesh file at `path`. The message of an error says what is wrong
/// with the file, without naming it (the caller names the file and the scene field).
/// Checks: readable, parseable, at least one face and one vertex, every coordinate finite.
pub fn read_mesh(path: &Path) -> Result<MeshVertices, String> {
    let format = MeshFormat::from_path(path)?;
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read the mesh file: {e}"))?;
    let mesh = parse_mesh(&bytes, format)?;
    if mesh.faces == 0 || mesh.vertices.is_empty() {
        return Err(format!(
            "empty mesh: {} vertices and {} faces (a solid needs faces)",
            mesh.vertices.len(),
            mesh.faces
        ));
    }
    if let Some((i, v)) = mesh
        .vertices
        .iter()
        .enumerate()
        .find(|(_, v)| !v.iter().all(|c| c.is_finite()))
    {
        return Err(format!(
            "vertex {i} has a non-finite coordinate: [{}, {}, {}]",
            v[0], v[1], v[2]
        ));
    }
    Ok(mesh)
}

/// Parses a mesh held in memory.
pub fn parse_mesh(bytes: &[u8], format: MeshFormat) -> Result<MeshVertices, String> {
    match format {
        MeshFormat::Obj => parse_obj(bytes),
        MeshFormat::Stl => parse_stl(bytes),
        MeshFormat::Ply => parse_ply(bytes),
    }
}

fn parse_obj(bytes: &[u8]) -> Result<MeshVertices, String> {
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials (`mtllib`) are not needed: the loader refuses them without touching the disk.
    let (models, _materials) = tobj::load_obj_buf(&mut Cursor::new(bytes), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| format!("cannot parse the OBJ file: {e}"))?;
    let mut vertices = Vec::new();
    let mut faces = 0;
    let mut triangles = Vec::new();
    for m in &models {
        let mesh = &m.mesh;
        let base = vertices.len() as u32;
        let idx: Vec<u32> = mesh.indices.iter().map(|&i| i.wrapping_add(base)).collect();
        if mesh.face_arities.is_empty() {
            for t in idx.chunks_exact(3) {
                fan(t, &mut triangles);
            }
        } else {
            let mut at = 0usize;
            for &a in &mesh.face_arities {
                let end = (at + a as usize).min(idx.len());
                fan(&idx[at..end], &mut triangles);
                at = end;
            }
        }
        vertices.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]),
        );
        faces += if mesh.face_arities.is_empty() {
            mesh.indices.len() / 3
        } else {
            mesh.face_arities.len()
        };
    }
    Ok(MeshVertices {
        vertices,
        faces,
        triangles,
    })
}

/// STL: binary when the size is exactly the one the header's face count gives (whatever the
/// 80-byte header says: many CAD exporters start it with `solid`), else ASCII when it starts
/// with `solid`, else binary with the face count the size gives (a wrong count field).
fn parse_stl(bytes: &[u8]) -> Result<MeshVertices, String> {
    let faces_by_size = (bytes.len() >= 84 && (bytes.len() - 84).is_multiple_of(50))
        .then(|| (bytes.len() - 84) / 50);
    let count = bytes
        .get(80..84)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as usize);
    if let Some(n) = faces_by_size
        && count == Some(n)
    {
        return Ok(binary_stl(bytes, n));
    }
    let ascii = bytes.trim_ascii_start().starts_with(b"solid");
    let parsed = if ascii {
        ascii_stl(bytes)
    } else {
        Err(match count {
            Some(n) => format!(
                "cannot parse the STL file: not ASCII (it does not start with `solid`) and not binary ({} bytes, but a binary STL with {n} faces has {})",
                bytes.len(),
                84 + 50 * n as u64
            ),
            None => format!(
                "cannot parse the STL file: not ASCII (it does not start with `solid`) and too short for binary ({} bytes)",
                bytes.len()
            ),
        })
    };
    match (parsed, faces_by_size) {
        (Ok(m), _) if m.faces > 0 => Ok(m),
        // A binary file with a wrong face count (0 is common), or a header starting `solid`.
        (_, Some(n)) => Ok(binary_stl(bytes, n)),
        (r, None) => r,
    }
}

/// An ASCII STL, by `stl_io`.
fn ascii_stl(bytes: &[u8]) -> Result<MeshVertices, String> {
    let mesh = stl_io::read_stl(&mut Cursor::new(bytes))
        .map_err(|e| format!("cannot parse the STL file (ASCII or binary): {e}"))?;
    Ok(MeshVertices {
        vertices: mesh
            .vertices
            .iter()
            .map(|v| [v.0[0] as f64, v.0[1] as f64, v.0[2] as f64])
            .collect(),
        faces: mesh.faces.len(),
        triangles: mesh
            .faces
            .iter()
            .map(|f| f.vertices.map(|i| u32::try_from(i).unwrap_or(u32::MAX)))
            .collect(),
    })
}

/// A binary STL's `faces` facets (the caller checked the size): three vertices each, in
/// order (the welding happens later), the facet normals ignored.
fn binary_stl(bytes: &[u8], faces: usize) -> MeshVertices {
    let f32_at =
        |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let mut vertices = Vec::with_capacity(3 * faces);
    for f in 0..faces {
        let base = 84 + 50 * f + 12;
        for k in 0..3 {
            let o = base + 12 * k;
            vertices.push([f32_at(o) as f64, f32_at(o + 4) as f64, f32_at(o + 8) as f64]);
        }
    }
    MeshVertices {
        vertices,
        faces,
        triangles: (0..faces as u32)
            .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
            .collect(),
    }
}

fn parse_ply(bytes: &[u8]) -> Result<MeshVertices, String> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut Cursor::new(bytes))
        .map_err(|e| format!("cannot parse the PLY file: {e}"))?;
    let scalar = |p: &Property| -> Option<f64> {
        Some(match *p {
            Property::Char(v) => v as f64,
            Property::UChar(v) => v as f64,
            Property::Short(v) => v as f64,
            Property::UShort(v) => v as f64,
            Property::Int(v) => v as f64,
            Property::UInt(v) => v as f64,
            Property::Float(v) => v as f64,
            Property::Double(v) => v,
            _ => return None,
        })
    };
    let mut vertices = Vec::new();
    if let Some(elements) = ply.payload.get("vertex") {
        vertices.reserve(elements.len());
        for (i, e) in elements.iter().enumerate() {
            let mut v = [0.0; 3];
            for (k, name) in ["x", "y", "z"].iter().enumerate() {
                v[k] = e
                    .get(*name)
                    .and_then(scalar)
                    .ok_or_else(|| format!("PLY vertex {i} has no scalar property `{name}`"))?;
            }
            vertices.push(v);
        }
    }
    let faces = ply.payload.get("face").map_or(0, Vec::len);
    let mut triangles = Vec::new();
    for (i, e) in ply.payload.get("face").into_iter().flatten().enumerate() {
        let list = e
            .get("vertex_indices")
            .or_else(|| e.get("vertex_index"))
            .ok_or_else(|| format!("PLY face {i} has no list property `vertex_indices`"))?;
        let poly: Vec<u32> = match list {
            Property::ListChar(v) => v.iter().map(|&x| x as u32).collect(),
            Property::ListUChar(v) => v.iter().map(|&x| x as u32).collect(),
            Property::ListShort(v) => v.iter().map(|&x| x as u32).collect(),
            Property::ListUShort(v) => v.iter().map(|&x| x as u32).collect(),
            Property::ListInt(v) => v.iter().map(|&x| x as u32).collect(),
            Property::ListUInt(v) => v.clone(),
            _ => {
                return Err(format!(
                    "PLY face {i}: `vertex_indices` is not a list of integers"
                ));
            }
        };
        fan(&poly, &mut triangles);
    }
    Ok(MeshVertices {
        vertices,
        faces,
        triangles,
    })
}

/// A mesh's vertices (as written) and its faces split into triangles (polygons fanned from
/// their first vertex): what a convex decomposition needs.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshTriangles {
    /// Vertex positions, in file order.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

/// Reads the mesh file at `path` with its triangles (the checks of [`read_mesh`], and every
/// index must name a vertex).
pub fn read_triangles(path: &Path) -> Result<MeshTriangles, String> {
    let mesh = read_mesh(path)?;
    check_triangles(MeshTriangles {
        vertices: mesh.vertices,
        triangles: mesh.triangles,
    })
}

/// [`read_mesh`]'s checks plus: at least one triangle, every index names a vertex.
fn check_triangles(m: MeshTriangles) -> Result<MeshTriangles, String> {
    if m.triangles.is_empty() {
        return Err("empty mesh: no faces (a solid needs faces)".into());
    }
    let n = m.vertices.len() as u32;
    if let Some(t) = m.triangles.iter().find(|t| t.iter().any(|&i| i >= n)) {
        return Err(format!(
            "a face refers to vertex {}, but the mesh has {n} vertices",
            t.iter().max().copied().unwrap_or(0)
        ));
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_extension() {
        assert_eq!(
            MeshFormat::from_path(Path::new("a/rock.OBJ")),
            Ok(MeshFormat::Obj)
        );
        assert_eq!(
            MeshFormat::from_path(Path::new("x.stl")),
            Ok(MeshFormat::Stl)
        );
        assert_eq!(
            MeshFormat::from_path(Path::new("x.Ply")),
            Ok(MeshFormat::Ply)
        );
        assert!(
            MeshFormat::from_path(Path::new("x.off"))
                .unwrap_err()
                .contains("`.off`")
        );
        assert!(MeshFormat::from_path(Path::new("x")).is_err());
    }

    #[test]
    fn garbage_is_an_error_in_every_format() {
        let garbage: Vec<u8> = (0..300u32).map(|i| (i * 7919 % 251) as u8).collect();
        for f in [MeshFormat::Obj, MeshFormat::Stl, MeshFormat::Ply] {
            for bytes in [
                &garbage[..],
                b"",
                b"solid x\nfacet normal 0 0 1\n",
                b"ply\n",
            ] {
                let r = parse_mesh(bytes, f);
                // Either an error, or (OBJ ignores unknown lines) nothing to build a solid from.
                if let Ok(m) = r {
                    assert_eq!(m.faces, 0, "{f:?}");
                }
            }
        }
    }
}
