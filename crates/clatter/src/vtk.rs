//! VTK output for ParaView: one XML UnstructuredGrid file (`.vtu`) per output step, and a
//! `.pvd` collection that indexes them by time.
//!
//! Used by `clatter run --format vtk` and the Python module's `Simulation.write_vtk`.
//!
//! Written by hand rather than through a crate: the whole format needed here is one grid of
//! vertex cells with a few point arrays, about 150 lines; `vtkio` (the only maintained-looking
//! Rust crate) has had no stable release since 0.6 (2021), pulls in an XML parser, serde and
//! nom, and would still leave the atomic writing and the array layout to us. Arrays are stored
//! inline as base64 binary (`format="binary"`, little-endian, UInt32 byte-count header), which
//! ParaView, VTK's own readers and `meshio` all read, and which is about 3x smaller and much
//! faster to write than ASCII.
//!
//! - `bodies_NNNNNN.vtu`: one point per body at its centre of mass (a `VTK_VERTEX` cell each)
//!   with point data `id`, `shape`, `material`, `contacts` (Int32), `radius` (bounding
//!   radius), `velocity`, `angular_velocity` (3 components), `orientation` (quaternion
//!   `w, x, y, z` in the authored frame) and `rotation` (the same rotation as a 3x3 matrix, row
//!   major: a tensor for ParaView's Tensor Glyph). Field data `TimeValue` and `Step`.
//! - `contacts_NNNNNN.vtu`: one point per touching contact at the centroid of its manifold,
//!   with `body_a`, `body_b` (Int32; a wall is `-1 - wall index` in `body_a`), `normal` (unit,
//!   from a to b), `force` (N, on b; a gets the opposite), `normal_force`, `depth`, `points`.
//!   Points and normals are recomputed at output time from the current positions; forces are
//!   those of the last step.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::Partner;
use crate::World;
use crate::checkpoint::write_atomic;
use crate::health::{ContactReport, touching_contacts};

/// One data array: name, component count and little-endian bytes of its values.
struct Array {
    name: &'static str,
    ty: &'static str,
    components: usize,
    bytes: Vec<u8>,
}

impl Array {
    fn f32(name: &'static str, components: usize, values: impl IntoIterator<Item = f32>) -> Array {
        Array {
            name,
            ty: "Float32",
            components,
            bytes: values.into_iter().flat_map(f32::to_le_bytes).collect(),
        }
    }
    fn i32(name: &'static str, values: impl IntoIterator<Item = i32>) -> Array {
        Array {
            name,
            ty: "Int32",
            components: 1,
            bytes: values.into_iter().flat_map(i32::to_le_bytes).collect(),
        }
    }
}

/// Writes a vertex-cell UnstructuredGrid with `points` and `arrays` of point data.
fn write_vtu(
    path: &Path,
    step: u64,
    time: f64,
    points: &[f32],
    arrays: &[Array],
    vectors: &str,
) -> std::io::Result<()> {
    let n = points.len() / 3;
    let mut buf = Vec::with_capacity(64 * n + 4096);
    let w = &mut buf;
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt32\">"
    )?;
    writeln!(w, "  <UnstructuredGrid>")?;
    writeln!(w, "    <FieldData>")?;
    writeln!(
        w,
        "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">{time:e}</DataArray>"
    )?;
    writeln!(
        w,
        "      <DataArray type=\"Int64\" Name=\"Step\" NumberOfTuples=\"1\" format=\"ascii\">{step}</DataArray>"
    )?;
    writeln!(w, "    </FieldData>")?;
    writeln!(
        w,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">"
    )?;
    writeln!(w, "      <PointData Vectors=\"{vectors}\">")?;
    for a in arrays {
        data_array(w, a)?;
    }
    writeln!(w, "      </PointData>")?;
    writeln!(w, "      <Points>")?;
    data_array(
        w,
        &Array {
            name: "Points",
            ty: "Float32",
            components: 3,
            bytes: points.iter().flat_map(|v| v.to_le_bytes()).collect(),
        },
    )?;
    writeln!(w, "      </Points>")?;
    writeln!(w, "      <Cells>")?;
    data_array(w, &Array::i32("connectivity", 0..n as i32))?;
    data_array(w, &Array::i32("offsets", 1..=n as i32))?;
    data_array(
        w,
        &Array {
            name: "types",
            ty: "UInt8",
            components: 1,
            bytes: vec![1u8; n],
        },
    )?;
    writeln!(w, "      </Cells>")?;
    writeln!(w, "    </Piece>")?;
    writeln!(w, "  </UnstructuredGrid>")?;
    writeln!(w, "</VTKFile>")?;
    write_atomic(path, &buf)
}

fn data_array(w: &mut impl Write, a: &Array) -> std::io::Result<()> {
    write!(
        w,
        "        <DataArray type=\"{}\" Name=\"{}\"",
        a.ty, a.name
    )?;
    if a.components > 1 {
        write!(w, " NumberOfComponents=\"{}\"", a.components)?;
    }
    write!(w, " format=\"binary\">")?;
    let mut block = Vec::with_capacity(4 + a.bytes.len());
    block.extend_from_slice(&(a.bytes.len() as u32).to_le_bytes());
    block.extend_from_slice(&a.bytes);
    w.write_all(base64(&block).as_bytes())?;
    writeln!(w, "</DataArray>")
}

/// Standard base64 with padding (RFC 4648).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = Vec::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let v = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        out.push(ALPHABET[(v >> 18) as usize & 63]);
        out.push(ALPHABET[(v >> 12) as usize & 63]);
        out.push(if chunk.len() > 1 {
            ALPHABET[(v >> 6) as usize & 63]
        } else {
            b'='
        });
        out.push(if chunk.len() > 2 {
            ALPHABET[v as usize & 63]
        } else {
            b'='
        });
    }
    String::from_utf8(out).expect("base64 is ASCII")
}

/// Writes the bodies of `world` at its current step.
pub fn write_bodies(path: &Path, world: &World) -> std::io::Result<()> {
    let n = world.len();
    let counts = world.contacts.counts(world.len());
    let mut points = Vec::with_capacity(3 * n);
    let mut quats = Vec::with_capacity(4 * n);
    let mut rotations = Vec::with_capacity(9 * n);
    for i in 0..n {
        points.extend(world.state.position[i].to_array());
        let q = world.user_orientation(i);
        quats.extend([q.w, q.x, q.y, q.z]);
        let m = glam::Mat3::from_quat(q);
        for r in 0..3 {
            rotations.extend([m.x_axis[r], m.y_axis[r], m.z_axis[r]]);
        }
    }
    let arrays = [
        Array::i32("id", 0..n as i32),
        Array::i32("shape", world.consts.shape.iter().map(|&s| s as i32)),
        Array::i32("material", world.consts.material.iter().map(|&m| m as i32)),
        Array::i32("contacts", counts.iter().map(|&c| c as i32)),
        Array::f32("radius", 1, world.consts.radius.iter().copied()),
        Array::f32(
            "velocity",
            3,
            world.state.velocity.iter().flat_map(|v| v.to_array()),
        ),
        Array::f32(
            "angular_velocity",
            3,
            world.state.omega.iter().flat_map(|v| v.to_array()),
        ),
        Array::f32("orientation", 4, quats),
        Array::f32("rotation", 9, rotations),
    ];
    write_vtu(
        path,
        world.step_count,
        world.time,
        &points,
        &arrays,
        "velocity",
    )
}

/// Writes the touching contacts of `world` at its current step.
pub fn write_contacts(path: &Path, world: &World) -> std::io::Result<()> {
    let contacts: Vec<ContactReport> = touching_contacts(world);
    let mut points = Vec::with_capacity(3 * contacts.len());
    for c in &contacts {
        let pts = c.manifold.points();
        let centroid = pts.iter().map(|p| p.point).sum::<glam::Vec3>() / pts.len().max(1) as f32;
        points.extend(centroid.to_array());
    }
    let arrays = [
        Array::i32(
            "body_a",
            contacts.iter().map(|c| match c.other {
                Partner::Body(_) => c.body as i32,
                Partner::Wall(w) => -1 - w as i32,
            }),
        ),
        Array::i32(
            "body_b",
            contacts.iter().map(|c| match c.other {
                Partner::Body(j) => j as i32,
                Partner::Wall(_) => c.body as i32,
            }),
        ),
        Array::f32(
            "normal",
            3,
            contacts.iter().flat_map(|c| c.manifold.normal.to_array()),
        ),
        Array::f32(
            "force",
            3,
            contacts.iter().flat_map(|c| c.force.force_b.to_array()),
        ),
        Array::f32(
            "normal_force",
            1,
            contacts.iter().map(|c| c.force.normal_force),
        ),
        Array::f32("depth", 1, contacts.iter().map(|c| c.manifold.max_depth())),
        Array::i32("points", contacts.iter().map(|c| c.manifold.count as i32)),
    ];
    write_vtu(
        path,
        world.step_count,
        world.time,
        &points,
        &arrays,
        "force",
    )
}

/// A `.pvd` collection: the frames of one series with their times, rewritten atomically after
/// every frame so that a killed run leaves an index of the frames it finished.
pub struct Pvd {
    path: PathBuf,
    entries: Vec<(u64, f64, String)>,
}

impl Pvd {
    /// A new index at `path`, keeping the entries of an existing one for steps before `step`
    /// (a resumed run continues the series it was written by).
    pub fn continuing(path: &Path, step: u64) -> Pvd {
        let mut entries = Vec::new();
        if step > 0
            && let Ok(text) = std::fs::read_to_string(path)
        {
            for line in text.lines() {
                let attr = |name: &str| {
                    let key = format!("{name}=\"");
                    let start = line.find(&key)? + key.len();
                    let len = line[start..].find('"')?;
                    Some(line[start..start + len].to_string())
                };
                let (Some(time), Some(file), Some(s)) =
                    (attr(" timestep"), attr(" file"), attr(" step"))
                else {
                    continue;
                };
                if let (Ok(time), Ok(s)) = (time.parse::<f64>(), s.parse::<u64>())
                    && s < step
                {
                    entries.push((s, time, file));
                }
            }
        }
        Pvd {
            path: path.to_path_buf(),
            entries,
        }
    }

    /// Adds a frame and rewrites the index.
    pub fn push(&mut self, step: u64, time: f64, file: String) -> std::io::Result<()> {
        self.entries.retain(|e| e.0 != step);
        self.entries.push((step, time, file));
        let mut buf = Vec::new();
        let w = &mut buf;
        writeln!(w, "<?xml version=\"1.0\"?>")?;
        writeln!(
            w,
            "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">"
        )?;
        writeln!(w, "  <Collection>")?;
        for (s, t, file) in &self.entries {
            writeln!(
                w,
                "    <DataSet timestep=\"{t:e}\" group=\"\" part=\"0\" file=\"{file}\" step=\"{s}\"/>"
            )?;
        }
        writeln!(w, "  </Collection>")?;
        writeln!(w, "</VTKFile>")?;
        write_atomic(&self.path, &buf)
    }
}

#[cfg(test)]
mod tests {
    use super::base64;

    #[test]
    fn base64_rfc4648_vectors() {
        for (input, out) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(input.as_bytes()), out);
        }
    }
}
