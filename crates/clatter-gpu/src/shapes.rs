//! Shape data on the GPU for the narrow phase (`shaders/contacts/narrow.wgsl`).
//!
//! Every [`PreparedShape`] of a scene is packed into two read-only storage buffers that the
//! WGSL narrow phase reads (bind group 1):
//!
//! - binding 0, `shape_f: array<vec4<f32>>`: per polyhedron its vertices (`xyz`), then its
//!   faces (outward normal `xyz`, plane offset `w`), then its edge arcs (`xyz`, the Gauss-map
//!   arc planes), then its unique edge directions (`xyz`);
//! - binding 1, `shape_u: array<u32>`: first a [`SHAPE_HEADER_WORDS`]-word header per shape
//!   (kind, bounding radius, counts, offsets into both buffers), then per polyhedron the face
//!   loops (`first`, `count` per face, absolute indices into `shape_u`), the concatenated
//!   face vertex loops, the edges (`v0, v1, f0, f1` per edge), each edge's direction index,
//!   and (shapes of at most 64 edges and faces) each face's edges as a 64-bit set.
//!
//! Composite shapes (clumps) have a header of kind 2 pointing at their piece records; each
//! piece's own shape is packed as one more shape after the scene's (see `KIND_COMPOSITE`).
//!
//! Two buffers rather than one per table keep the kernels that call `collide` within the
//! default limit of 8 storage buffers per stage, next to the simulation's own buffers.

use clatter_geom::{PreparedShape, Shape};

use crate::{GpuContext, GpuError};

/// Most vertices of one polyhedron. No private array depends on it (the wall test reduces
/// the vertices below the wall on the fly); it bounds the work of one GPU thread, whose
/// separating-axis loops are O(edges_a x edges_b) with up to 3V - 6 edges per shape.
///
/// 64, down from 256: on lavapipe the WGSL narrow phase disagrees with the CPU's for most
/// pairs of hulls of about 86 or more vertices (a Fibonacci sphere of 86 points: 2,733 of
/// 6,000 random pairs; 70 points: none), found when mesh files made such hulls common. Not
/// yet understood (the SAT and clipping code read the same as the CPU's, and no array in
/// them is sized by the vertex count); until it is, larger hulls run on the CPU only.
/// `tests/narrow.rs` (`gpu_collide_matches_cpu_on_mesh_file_hulls`) covers a 64-vertex hull.
pub const MAX_SHAPE_VERTICES: usize = 64;
/// Most vertices in one face loop. Clipping the incident face against the reference face
/// gives at most `incident + reference` loop vertices, held in private arrays of
/// [`MAX_CLIP_POINTS`]. Kept small on purpose: llvmpipe's shader compile time grows steeply
/// with private array size (measured for the batch kernel with Mesa's cache off: ~15 s of
/// CPU at 32, ~35 s at 64 with one combined array, ~7 min with three 256-entry copies).
/// A 32-gon prism (64 vertices) fits; a pyramid on a 40-gon does not.
pub const MAX_FACE_VERTICES: usize = 32;
/// Capacity of each private clipping array in `narrow.wgsl` (`NRW_MAX_CLIP`).
pub const MAX_CLIP_POINTS: usize = 2 * MAX_FACE_VERTICES;
/// Words of the per-shape header at the start of `shape_u`.
pub const SHAPE_HEADER_WORDS: usize = 12;

/// Header `kind` of a sphere.
const KIND_SPHERE: u32 = 0;
/// Header `kind` of a convex polyhedron.
const KIND_POLYHEDRON: u32 = 1;
/// Header `kind` of a composite (clump): `[h + 2]` its piece count, `[h + 3]` the first of
/// its piece records in `shape_u` (3 words each: the piece's shape index, its equivalent
/// radius's bits, 1 for a sphere), `[h + 4]` the first in `shape_f` (2 each: the piece's
/// centre in the composite's frame with its bounding radius in `w`, its orientation),
/// `[h + 5]` the reach's bits. The pieces' shapes follow the scene's shapes in the table.
const KIND_COMPOSITE: u32 = 2;

/// Most pieces of one composite on the GPU: piece ids are kept in the top 6 bits of the
/// pair list's words (`PIECE_SHIFT` in pieces.wgsl), above a 26-bit body index.
pub const MAX_GPU_PIECES: usize = 1 << (32 - PIECE_SHIFT);
/// Bits of the body index in a pair-list word of a scene with composites.
pub const PIECE_SHIFT: u32 = 26;
// Every composite the geometry crate builds fits the piece ids.
const _: () = assert!(clatter_geom::composite::MAX_PIECES <= MAX_GPU_PIECES);
/// Most bodies of a scene with composites on the GPU (`2^PIECE_SHIFT`).
pub const MAX_COMPOSITE_BODIES: u64 = 1 << PIECE_SHIFT;

/// The shapes of a scene on the GPU (bind group 1 of every kernel that calls the WGSL
/// `collide` / `collide_plane`).
pub struct GpuShapes {
    /// `shape_f`: vertices, faces, edge arcs, edge directions (binding 0).
    pub floats: wgpu::Buffer,
    /// `shape_u`: headers, face loops, edges, edge directions' indices (binding 1).
    pub words: wgpu::Buffer,
    /// Number of shapes uploaded; valid shape indices are `0..count`.
    pub count: usize,
    /// The most vertices of any polyhedron face, composite pieces included (0 without
    /// polyhedra): sizes the contact kernels' clipping buffers
    /// (`pipeline::ContactVariant::clip_points`).
    pub longest_face: usize,
}

/// The most vertices of any face of `shapes`' polyhedra and composite pieces.
fn longest_face(shapes: &[PreparedShape]) -> usize {
    fn of(shape: &Shape) -> usize {
        match shape {
            Shape::Polyhedron(p) => p.faces.iter().map(|f| f.count as usize).max().unwrap_or(0),
            Shape::Composite(c) => c.pieces.iter().map(|p| of(&p.shape)).max().unwrap_or(0),
            _ => 0,
        }
    }
    shapes.iter().map(|p| of(&p.shape)).max().unwrap_or(0)
}

/// The packed contents of the two buffers, built on the host.
struct Packed {
    floats: Vec<[f32; 4]>,
    words: Vec<u32>,
}

fn pack(shapes: &[PreparedShape]) -> Result<Packed, GpuError> {
    let n = shapes.len();
    // Composite pieces are shapes of their own, after the scene's: (label, shape).
    let mut all: Vec<(String, &Shape)> = shapes
        .iter()
        .enumerate()
        .map(|(i, p)| (format!("shape {i}"), &p.shape))
        .collect();
    for (i, p) in shapes.iter().enumerate() {
        if let Shape::Composite(c) = &p.shape {
            for (k, piece) in c.pieces.iter().enumerate() {
                all.push((format!("piece {k} of shape {i}"), &piece.shape));
            }
        }
    }
    let mut floats: Vec<[f32; 4]> = Vec::new();
    let mut words: Vec<u32> = vec![0; all.len() * SHAPE_HEADER_WORDS];
    let to_u32 = |v: usize, what: &str| {
        u32::try_from(v)
            .map_err(|_| GpuError::Unsupported(format!("shape data too large ({what} = {v})")))
    };
    let mut next_piece = n;
    for (i, (label, shape)) in all.iter().enumerate() {
        let h = i * SHAPE_HEADER_WORDS;
        match shape {
            Shape::Composite(c) => {
                if i >= n {
                    return Err(GpuError::Unsupported(format!(
                        "{label} is itself a composite, which the GPU backend does not support"
                    )));
                }
                if c.pieces.is_empty() || c.pieces.len() > MAX_GPU_PIECES {
                    return Err(GpuError::Unsupported(format!(
                        "{label} is a composite of {} pieces; the GPU backend takes 1 to {MAX_GPU_PIECES}",
                        c.pieces.len()
                    )));
                }
                words[h] = KIND_COMPOSITE;
                words[h + 1] = c.radius.to_bits();
                words[h + 2] = c.pieces.len() as u32;
                words[h + 3] = to_u32(words.len(), "word offset")?;
                words[h + 4] = to_u32(floats.len(), "float offset")?;
                words[h + 5] = c.reach.to_bits();
                for piece in &c.pieces {
                    words.push(to_u32(next_piece, "piece shape index")?);
                    words.push(piece.equivalent_radius.to_bits());
                    words.push(matches!(piece.shape, Shape::Sphere { .. }) as u32);
                    next_piece += 1;
                    let (x, q) = (piece.position, piece.orientation);
                    floats.push([x.x, x.y, x.z, piece.radius()]);
                    floats.push([q.x, q.y, q.z, q.w]);
                }
            }
            Shape::Sphere { radius } => {
                words[h] = KIND_SPHERE;
                words[h + 1] = radius.to_bits();
            }
            Shape::Polyhedron(p) => {
                if p.vertices.len() > MAX_SHAPE_VERTICES {
                    return Err(GpuError::Unsupported(format!(
                        "{label} has {} vertices, more than the GPU narrow phase's limit of {MAX_SHAPE_VERTICES} (MAX_SHAPE_VERTICES)",
                        p.vertices.len()
                    )));
                }
                let longest = p.faces.iter().map(|f| f.count as usize).max().unwrap_or(0);
                if longest > MAX_FACE_VERTICES {
                    return Err(GpuError::Unsupported(format!(
                        "{label} has a face with {longest} vertices, more than the GPU narrow phase's limit of {MAX_FACE_VERTICES} (MAX_FACE_VERTICES)"
                    )));
                }
                words[h] = KIND_POLYHEDRON;
                words[h + 1] = p.radius.to_bits();
                words[h + 2] = p.vertices.len() as u32;
                words[h + 3] = p.faces.len() as u32;
                words[h + 4] = p.edges.len() as u32;
                words[h + 5] = p.edge_dirs.len() as u32;
                words[h + 6] = to_u32(floats.len(), "float offset")?;
                floats.extend(p.vertices.iter().map(|v| [v.x, v.y, v.z, 0.0]));
                floats.extend(
                    p.faces
                        .iter()
                        .map(|f| [f.normal.x, f.normal.y, f.normal.z, f.offset]),
                );
                floats.extend(p.edge_arcs.iter().map(|v| [v.x, v.y, v.z, 0.0]));
                floats.extend(p.edge_dirs.iter().map(|v| [v.x, v.y, v.z, 0.0]));
                // Face loops: (first, count) per face, `first` absolute in `shape_u`.
                let fc = words.len();
                let lb = fc + 2 * p.faces.len();
                words[h + 7] = to_u32(fc, "word offset")?;
                for f in &p.faces {
                    words.push(to_u32(lb + f.first as usize, "word offset")?);
                    words.push(f.count);
                }
                words.extend_from_slice(&p.face_vertices);
                words[h + 8] = to_u32(words.len(), "word offset")?;
                for (e, f) in p.edges.iter().zip(&p.edge_faces) {
                    words.extend_from_slice(&[e[0], e[1], f[0], f[1]]);
                }
                words[h + 9] = to_u32(words.len(), "word offset")?;
                words.extend_from_slice(&p.edge_dir_of);
                // The edges of each face as a 64-bit set (two words, low first), for the
                // Gauss-map pruning of the edge axes against this shape as B; 0 (none) when
                // the shape has more than 64 edges or faces (the kernel then visits every edge).
                if p.edges.len() <= 64 && p.faces.len() <= 64 {
                    words[h + 10] = to_u32(words.len(), "word offset")?;
                    words.extend_from_slice(&edge_sets_by_face(p));
                }
            }
        }
    }
    Ok(Packed { floats, words })
}

/// The edges of each face of `p` as 64-bit sets, two words per face (low word first): bit `e`
/// of face `f` is set when edge `e` borders face `f`. At most 64 edges and faces.
fn edge_sets_by_face(p: &clatter_geom::ConvexPolyhedron) -> Vec<u32> {
    let mut sets = vec![0u64; p.faces.len()];
    for (e, faces) in p.edge_faces.iter().enumerate() {
        for &f in faces {
            sets[f as usize] |= 1 << e;
        }
    }
    sets.iter()
        .flat_map(|s| [*s as u32, (s >> 32) as u32])
        .collect()
}

/// Keeps at least one element in each buffer (zero-sized bindings are invalid).
fn finish(mut p: Packed) -> Packed {
    let Packed { floats, words } = &mut p;
    if floats.is_empty() {
        floats.push([0.0; 4]);
    }
    if words.is_empty() {
        words.push(0);
    }
    p
}

impl GpuShapes {
    /// Packs `shapes` (indexed as the bodies' shape indices) and uploads them.
    ///
    /// Fails with [`GpuError::Unsupported`] naming the shape and the limit when a polyhedron
    /// has more than [`MAX_SHAPE_VERTICES`] vertices or a face with more than
    /// [`MAX_FACE_VERTICES`] vertices (the WGSL uses fixed-size private arrays), and with
    /// [`GpuError::TooLarge`] when a buffer exceeds the adapter's limits.
    pub fn upload(ctx: &GpuContext, shapes: &[PreparedShape]) -> Result<GpuShapes, GpuError> {
        Ok(Self::upload_with_meshes(ctx, shapes, &[])?.0)
    }

    /// [`GpuShapes::upload`], with the triangle-mesh boundaries' static data appended
    /// (`crate::mesh`); also returns where their headers start in `shape_u`
    /// (`Params::mesh_base`).
    pub fn upload_with_meshes(
        ctx: &GpuContext,
        shapes: &[PreparedShape],
        boundaries: &[clatter::mesh_boundary::Boundary],
    ) -> Result<(GpuShapes, u32), GpuError> {
        use wgpu::util::DeviceExt;
        let mut packed = pack(shapes)?;
        let mut first = vec![0u32];
        for b in boundaries {
            let next = first.last().copied().unwrap_or(0) as u64 + b.triangles.len() as u64;
            first.push(
                u32::try_from(next).map_err(|_| {
                    GpuError::Unsupported("more than 2^32 boundary triangles".into())
                })?,
            );
        }
        let mesh_base =
            crate::mesh::pack(boundaries, &first, &mut packed.floats, &mut packed.words)?;
        let packed = finish(packed);
        let limit = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        for (what, bytes) in [
            ("shape float data", packed.floats.len() as u64 * 16),
            ("shape index data", packed.words.len() as u64 * 4),
        ] {
            if bytes > limit {
                return Err(GpuError::TooLarge {
                    adapter: ctx.adapter_name(),
                    what: what.into(),
                    need: format!("{bytes} bytes"),
                    limit: format!("{limit} bytes"),
                    advice: "use fewer or simpler shapes".into(),
                });
            }
        }
        let floats = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("shape_f"),
                contents: bytemuck::cast_slice(&packed.floats),
                usage: wgpu::BufferUsages::STORAGE,
            });
        let words = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("shape_u"),
                contents: bytemuck::cast_slice(&packed.words),
                usage: wgpu::BufferUsages::STORAGE,
            });
        ctx.take_error()?;
        Ok((
            GpuShapes {
                floats,
                words,
                count: shapes.len(),
                longest_face: longest_face(shapes),
            },
            mesh_base,
        ))
    }

    /// The layout entries of bind group 1 (bindings 0 and 1, read-only storage), visible to
    /// `visibility` (normally [`wgpu::ShaderStages::COMPUTE`]).
    pub fn layout_entries(visibility: wgpu::ShaderStages) -> Vec<wgpu::BindGroupLayoutEntry> {
        (0..2)
            .map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect()
    }

    /// A bind group layout of [`GpuShapes::layout_entries`] for compute shaders.
    pub fn create_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
        ctx.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("clatter shapes (group 1)"),
                entries: &Self::layout_entries(wgpu::ShaderStages::COMPUTE),
            })
    }

    /// The entries of bind group 1 matching [`GpuShapes::layout_entries`].
    pub fn bind_entries(&self) -> Vec<wgpu::BindGroupEntry<'_>> {
        vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: self.floats.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: self.words.as_entire_binding(),
            },
        ]
    }

    /// A bind group for `layout` (made from [`GpuShapes::layout_entries`]).
    pub fn bind_group(&self, ctx: &GpuContext, layout: &wgpu::BindGroupLayout) -> wgpu::BindGroup {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("clatter shapes (group 1)"),
            layout,
            entries: &self.bind_entries(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clatter_geom::{RegularKind, ShapeKind};

    #[test]
    fn clip_buffers_hold_a_clipped_face() {
        use crate::pipeline::ContactVariant;
        // A face of n vertices clipped by another's m <= n edges ends with at most n + m
        // points: every size holds twice the longest face, with 4 to spare.
        for longest in 0..=MAX_FACE_VERTICES {
            let clip = ContactVariant::clip_points(longest, false) as usize;
            assert!(
                clip >= 2 * longest + 4 || clip == MAX_CLIP_POINTS,
                "{longest}: {clip}"
            );
            assert!(clip.is_power_of_two() && (16..=MAX_CLIP_POINTS).contains(&clip));
            assert_eq!(
                ContactVariant::clip_points(longest, true) as usize,
                MAX_CLIP_POINTS
            );
        }
        assert_eq!(ContactVariant::clip_points(4, false), 16);
        assert_eq!(ContactVariant::clip_points(7, false), 32);
    }

    #[test]
    fn wgsl_constants_match() {
        let wgsl = crate::pipeline::NARROW;
        assert!(wgsl.contains(&format!("const NRW_MAX_CLIP: u32 = {MAX_CLIP_POINTS}u;")));
        assert!(wgsl.contains(&format!("array<vec4<f32>, {MAX_CLIP_POINTS}>")));
        // The smaller clipping buffers replace both declarations.
        let small = crate::pipeline::narrow_source(16);
        assert!(small.contains("const NRW_MAX_CLIP: u32 = 16u;"));
        assert!(small.contains("alias NrwBuf = array<vec4<f32>, 16>;"));
        assert!(!small.contains(&format!("{MAX_CLIP_POINTS}u;")));
        assert!(wgsl.contains(&format!("const NRW_HDR: u32 = {SHAPE_HEADER_WORDS}u;")));
        let pieces = include_str!("../shaders/contacts/pieces.wgsl");
        assert!(pieces.contains(&format!("const PIECE_SHIFT: u32 = {PIECE_SHIFT}u;")));
        let mask = (1u32 << PIECE_SHIFT) - 1;
        assert!(pieces.contains(&format!("const BODY_MASK: u32 = {mask:#x}u;")));
        assert!(pieces.contains(&format!("const PC_HDR: u32 = {SHAPE_HEADER_WORDS}u;")));
        assert!(pieces.contains(&format!("const KIND_COMPOSITE: u32 = {KIND_COMPOSITE}u;")));
    }

    #[test]
    fn header_offsets_point_at_the_tables() {
        let cube = ShapeKind::Regular {
            kind: RegularKind::Cube,
            radius: 1.0,
        }
        .prepare()
        .unwrap();
        let sphere = ShapeKind::Sphere { radius: 0.5 }.prepare().unwrap();
        let packed = pack(&[sphere, cube.clone()]).unwrap();
        let h = SHAPE_HEADER_WORDS;
        assert_eq!(packed.words[0], KIND_SPHERE);
        assert_eq!(f32::from_bits(packed.words[1]), 0.5);
        assert_eq!(packed.words[h], KIND_POLYHEDRON);
        let Shape::Polyhedron(p) = &cube.shape else {
            unreachable!()
        };
        assert_eq!(packed.words[h + 2] as usize, p.vertices.len());
        assert_eq!(packed.words[h + 3] as usize, p.faces.len());
        let fc = packed.words[h + 7] as usize;
        // The second face's loop is found through its absolute `first`.
        let first = packed.words[fc + 2] as usize;
        let count = packed.words[fc + 3] as usize;
        assert_eq!(&packed.words[first..first + count], p.face_loop(1));
        let eb = packed.words[h + 8] as usize;
        assert_eq!(packed.words[eb + 4], p.edges[1][0]);
        assert_eq!(packed.words[eb + 6], p.edge_faces[1][0]);
        let db = packed.words[h + 9] as usize;
        assert_eq!(packed.words[db + 5], p.edge_dir_of[5]);
        // Face f's edge set: exactly the edges that border f (a cube's face has 4).
        let sb = packed.words[h + 10] as usize;
        for f in 0..p.faces.len() {
            let set = packed.words[sb + 2 * f] as u64 | (packed.words[sb + 2 * f + 1] as u64) << 32;
            for (e, faces) in p.edge_faces.iter().enumerate() {
                assert_eq!(
                    set >> e & 1 == 1,
                    faces.contains(&(f as u32)),
                    "face {f} edge {e}"
                );
            }
            assert_eq!(set.count_ones(), 4);
        }
        let vb = packed.words[h + 6] as usize;
        let nv = p.vertices.len();
        assert_eq!(packed.floats[vb + nv + 2][3], p.faces[2].offset);
    }

    #[test]
    fn composite_header_points_at_its_pieces() {
        use clatter_geom::{PieceSpec, prepare_composite};
        use glam::{DQuat, DVec3};
        let sphere = ShapeKind::Sphere { radius: 0.5 }.prepare().unwrap();
        let cube = ShapeKind::Regular {
            kind: RegularKind::Cube,
            radius: 1.0,
        }
        .prepare()
        .unwrap();
        let clump = prepare_composite(&[
            PieceSpec {
                shape: sphere.clone(),
                offset: DVec3::new(-1.0, 0.0, 0.0),
                orientation: DQuat::IDENTITY,
            },
            PieceSpec {
                shape: cube.clone(),
                offset: DVec3::new(1.0, 0.0, 0.0),
                orientation: DQuat::from_rotation_x(0.5),
            },
        ])
        .unwrap();
        let Shape::Composite(c) = &clump.shape else {
            unreachable!()
        };
        let packed = pack(&[sphere, clump.clone()]).unwrap();
        let h = SHAPE_HEADER_WORDS;
        assert_eq!(packed.words[h], KIND_COMPOSITE);
        assert_eq!(f32::from_bits(packed.words[h + 1]), c.radius);
        assert_eq!(packed.words[h + 2], 2);
        assert_eq!(f32::from_bits(packed.words[h + 5]), c.reach);
        let (u, f) = (packed.words[h + 3] as usize, packed.words[h + 4] as usize);
        for (k, piece) in c.pieces.iter().enumerate() {
            // The piece's shape follows the scene's two shapes, with its own header.
            let s = packed.words[u + 3 * k] as usize;
            assert_eq!(s, 2 + k);
            let kind = if k == 0 { KIND_SPHERE } else { KIND_POLYHEDRON };
            assert_eq!(packed.words[s * h], kind);
            assert_eq!(
                f32::from_bits(packed.words[u + 3 * k + 1]),
                piece.equivalent_radius
            );
            assert_eq!(packed.words[u + 3 * k + 2], (k == 0) as u32);
            let p = piece.position;
            assert_eq!(packed.floats[f + 2 * k], [p.x, p.y, p.z, piece.radius()]);
            let q = piece.orientation;
            assert_eq!(packed.floats[f + 2 * k + 1], [q.x, q.y, q.z, q.w]);
        }
    }

    #[test]
    fn a_piece_over_the_vertex_limit_is_named() {
        use clatter_geom::{PieceSpec, prepare_composite};
        use glam::{DQuat, DVec3};
        // 100 points on a Fibonacci sphere: a hull of more than MAX_SHAPE_VERTICES vertices.
        let points: Vec<[f64; 3]> = (0..100)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / 100.0;
                let r = (1.0 - z * z).sqrt();
                let a = k as f64 * 2.399_963_229_728_653;
                [r * a.cos(), r * a.sin(), z]
            })
            .collect();
        let ball = ShapeKind::Convex { points }.prepare().unwrap();
        let sphere = ShapeKind::Sphere { radius: 0.5 }.prepare().unwrap();
        let clump = prepare_composite(&[
            PieceSpec {
                shape: sphere,
                offset: DVec3::new(-1.0, 0.0, 0.0),
                orientation: DQuat::IDENTITY,
            },
            PieceSpec {
                shape: ball,
                offset: DVec3::new(1.0, 0.0, 0.0),
                orientation: DQuat::IDENTITY,
            },
        ])
        .unwrap();
        let err = pack(&[clump]).err().expect("the piece is over the limit");
        let GpuError::Unsupported(msg) = &err else {
            panic!("wrong error {err}")
        };
        assert!(
            msg.contains("piece 1 of shape 0") && msg.contains("64"),
            "{msg}"
        );
    }
}
