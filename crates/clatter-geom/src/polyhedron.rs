//! The convex polyhedron: vertices, polygonal faces with outward planes, and the unique edges
//! with their two adjacent faces (what the separating-axis test and the Gauss-map pruning need).

use glam::{DVec3, IVec3, Vec3};

/// One polygonal face: outward unit normal, plane offset (`normal . x = offset` on the face) and
/// a counter-clockwise (seen from outside) loop of vertex indices stored in
/// [`ConvexPolyhedron::face_vertices`]`[first..first + count]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Face {
    pub normal: Vec3,
    pub offset: f32,
    pub first: u32,
    pub count: u32,
}

/// A convex polyhedron with merged coplanar faces (a cube has 6 quads, not 12 triangles).
///
/// Built by [`ConvexPolyhedron::from_faces`] (normally through [`crate::convex_hull`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ConvexPolyhedron {
    /// Vertex positions in the shape's local frame.
    pub vertices: Vec<Vec3>,
    /// Faces with outward planes.
    pub faces: Vec<Face>,
    /// Concatenated counter-clockwise vertex loops of all faces.
    pub face_vertices: Vec<u32>,
    /// Unique undirected edges `[a, b]` with `a < b`.
    pub edges: Vec<[u32; 2]>,
    /// For each edge, the two faces sharing it.
    pub edge_faces: Vec<[u32; 2]>,
    /// For each edge, `n1 x n0` of its two faces' normals: the plane of the edge's arc on the
    /// Gauss map (used to prune edge-edge axes in the separating-axis test).
    pub edge_arcs: Vec<Vec3>,
    /// Unique edge directions up to sign (unit vectors): a cube has 3, an icosahedron 15.
    pub edge_dirs: Vec<Vec3>,
    /// For each edge, the index of its direction in `edge_dirs`.
    pub edge_dir_of: Vec<u32>,
    /// Largest distance of a vertex from the local origin (bounding-sphere radius).
    pub radius: f32,
    /// When the polyhedron is a rectangular box centred on the origin: its axes and half
    /// extents, recognised once here so that queries take the closed-form box paths.
    pub box_frame: Option<BoxFrame>,
    /// When the vertices are exactly the eight corners `(±h.x, ±h.y, ±h.z)` in f32 (an
    /// axis-aligned box centred on the origin, as a prepared cube is): `h`. Then the
    /// smallest projection of the vertices on any direction `n`, each projection computed
    /// as `n.x * v.x + n.y * v.y + n.z * v.z`, is `-((|n.x| h.x + |n.y| h.y) + |n.z| h.z)`
    /// bitwise (up to the sign of a zero), which [`ConvexPolyhedron::smallest_projection`]
    /// takes (see [`ConvexPolyhedron::detect_corner_box`] for why).
    pub corner_box: Option<Vec3>,
    /// When the polyhedron has six faces whose normals are exactly the six signed unit axes
    /// (one component `±1`, two `±0`; as a prepared cube's are): the face of each signed
    /// axis, `face_axes[axis | (negative as usize) << 2]` (entries 3 and 7 unused). Then a
    /// face normal's dot product with a finite vector `v` is `±v[axis]` as a value (the
    /// products with `±0` are zeros, and a zero added to `x` gives `x`, or a zero for a
    /// zero), so the smallest dot product is `-max |v[k]|` and its faces are known without
    /// the products (see [`ConvexPolyhedron::detect_face_axes`] and the clipping's
    /// incident face).
    pub face_axes: Option<[u8; 8]>,
    /// `vertices` as 4-point SIMD lanes, built once by the constructor (derived from
    /// `vertices` like the planes and `radius`: a changed shape is built anew), so that the
    /// separating-axis test does not lay them out again for every pair.
    lanes: crate::narrow::SoaPoints,
    /// For each face's loop edge `k` (from `face_vertices[first + k]` to the next vertex of
    /// the loop), its side plane `(side, offset)`: `side = (v1 - v0) x normal` (outward for
    /// a counter-clockwise loop) and `offset = side . v0`, built once by the constructor
    /// with the clipping's own expressions (the same floats), so that clipping an incident
    /// face against a reference face does not recompute them for every pair and step.
    side_planes: Vec<(Vec3, f32)>,
    /// For each face, the axes of its normal and of its side planes' vectors packed in one
    /// word ([`AxisCode`], one load for the clip): each the axis of a vector that is finite
    /// with exactly one component not zero (the other two `±0`), else [`NO_AXIS`] (a
    /// box's are all axes). Then, for a finite point `p`, such a vector's dot product is
    /// that one product as a value (the products with `±0` are zeros, and adding a zero
    /// changes no value but a zero's sign), so the clipping takes it alone (see
    /// [`axis_of`]).
    axis_codes: Vec<AxisCode>,
    /// A lower bound of the radius of a ball about the local origin inside the hull: the
    /// smallest face offset less `1e-4 * radius` (the hull merges faces within about
    /// `5e-6 * radius`) when that is positive (the origin well inside), else minus
    /// infinity (no bound). For any unit `u`, the vertices reach at least this far along
    /// `u`; the edge-axis search uses it to leave out axes that cannot matter (see
    /// `edge_axes_by_direction`).
    inner: f32,
    /// The edges of each direction, in increasing order: those of direction `d` are
    /// `dir_edges[dir_first[d]..dir_first[d + 1]]` (built by the constructor from
    /// `edge_dir_of`), so that the edge-axis search finds a direction's supporting edge
    /// without scanning every edge's direction for each pair and step.
    dir_edges: Vec<u32>,
    /// Where each direction's edges start in `dir_edges` (one entry per direction, and the
    /// end).
    dir_first: Vec<u32>,
    /// Each edge of `dir_edges` in the same order, with its ends (`edges[e]`, so that the
    /// search for B's supporting edge reads them in sequence) and their sum
    /// (`vertices[v0] + vertices[v1]`, the same floats as the search's sum: A's supporting
    /// edge along an axis is the first largest `axis . sum`, without the vertices looked
    /// up per pair and step). One record per edge, so that a direction's group is one
    /// slice (one range check per search and body, not three; issue 23, edge38).
    dir_records: Vec<DirEdge>,
    /// One more than the largest vertex index among `dir_records`' ends (0 when there are
    /// none): B's points in A's frame, when at least this many, hold every end, which the
    /// search for B's supporting edge then reads without a check per end.
    dir_end_bound: usize,
}

/// An edge of a direction group (see `ConvexPolyhedron::dir_group`): the sum of its ends'
/// positions, its index and its ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct DirEdge {
    /// `vertices[ends[0]] + vertices[ends[1]]`.
    pub(crate) sum: Vec3,
    /// The edge's index in `edges`.
    pub(crate) edge: u32,
    /// `edges[edge]`.
    pub(crate) ends: [u32; 2],
}

/// The frame of a box-shaped polyhedron: orthonormal axes (columns, right-handed) and half
/// extents, centred on the local origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxFrame {
    /// Box axes as columns.
    pub axes: glam::DMat3,
    /// Half extents along the axes.
    pub half: glam::DVec3,
    /// `axes` is the identity (the usual case: a box authored axis-aligned).
    pub aligned: bool,
}

/// No axis: a vector that is not a finite multiple of one axis with exact zeros (see
/// [`axis_of`]).
pub(crate) const NO_AXIS: u8 = 3;

/// The axis `k` of `v` when `v[k]` is finite and not zero and the other two components
/// are zeros (of either sign), else [`NO_AXIS`]. Then for any finite `p`, `v.dot(p)`
/// (glam's `(x x' + y y') + z z'`) has the value `v[k] * p[k]`: the other products are
/// zeros, and a zero added to a value gives that value (to a zero, a zero), so the value
/// differs at most in the sign of a zero (an infinite `v[k] * p[k]` stays infinite).
pub(crate) fn axis_of(v: Vec3) -> u8 {
    let c = v.to_array();
    let mut axis = NO_AXIS;
    for (k, &x) in c.iter().enumerate() {
        if x != 0.0 {
            if axis != NO_AXIS || !x.is_finite() {
                return NO_AXIS;
            }
            axis = k as u8;
        }
    }
    axis
}

/// The axes ([`axis_of`]) of a face's normal (bits 0-1) and of the vectors of its first
/// fifteen side planes, in loop order (plane `k` in bits `2k + 2` and `2k + 3`; [`NO_AXIS`]
/// for the planes after them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct AxisCode(u32);

impl AxisCode {
    /// The code of a face of normal `normal` and side planes `planes`.
    fn of(normal: Vec3, planes: &[(Vec3, f32)]) -> Self {
        let mut code = u32::MAX;
        let mut put = |slot: usize, axis: u8| {
            code &= !(3 << (2 * slot));
            code |= (axis as u32) << (2 * slot);
        };
        put(0, axis_of(normal));
        for (k, &(side, _)) in planes.iter().enumerate().take(15) {
            put(k + 1, axis_of(side));
        }
        AxisCode(code)
    }

    /// The axis of the face's normal.
    #[inline]
    pub(crate) fn normal(self) -> u8 {
        (self.0 & 3) as u8
    }

    /// The axis of side plane `k`'s vector ([`NO_AXIS`] from the sixteenth on).
    #[inline]
    pub(crate) fn side(self, k: usize) -> u8 {
        if k < 15 {
            (self.0 >> (2 * k + 2) & 3) as u8
        } else {
            NO_AXIS
        }
    }
}

impl ConvexPolyhedron {
    /// Builds the polyhedron from vertices and counter-clockwise face loops (seen from outside).
    /// Normals come from Newell's method (robust for slightly non-planar loops); edges and their
    /// adjacent faces are derived from the loops. The caller guarantees a closed convex surface.
    pub fn from_faces(vertices: Vec<Vec3>, loops: &[Vec<u32>]) -> Self {
        let mut faces = Vec::with_capacity(loops.len());
        let mut face_vertices = Vec::new();
        for lp in loops {
            // Newell's vector area, in f64 and relative to the first vertex: in f32 with raw
            // coordinates the products cancel badly for small or thin faces far from the origin.
            let origin = lp
                .first()
                .map_or(DVec3::ZERO, |&i| vertices[i as usize].as_dvec3());
            let mut n = DVec3::ZERO;
            let mut centroid = Vec3::ZERO;
            for (k, &i) in lp.iter().enumerate() {
                let a = vertices[i as usize].as_dvec3() - origin;
                let b = vertices[lp[(k + 1) % lp.len()] as usize].as_dvec3() - origin;
                n += a.cross(b);
                centroid += vertices[i as usize];
            }
            centroid /= lp.len() as f32;
            let normal = n.normalize_or_zero().as_vec3();
            // The face plane passes through the loop's outermost vertex so that every vertex
            // is on or behind every face plane (no false separation from rounding).
            let offset = lp
                .iter()
                .map(|&i| normal.dot(vertices[i as usize]))
                .fold(normal.dot(centroid), f32::max);
            faces.push(Face {
                normal,
                offset,
                first: face_vertices.len() as u32,
                count: lp.len() as u32,
            });
            face_vertices.extend_from_slice(lp);
        }
        let mut edge_map: std::collections::BTreeMap<(u32, u32), Vec<u32>> = Default::default();
        for (f, lp) in loops.iter().enumerate() {
            for k in 0..lp.len() {
                let a = lp[k];
                let b = lp[(k + 1) % lp.len()];
                edge_map
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push(f as u32);
            }
        }
        let mut edges = Vec::with_capacity(edge_map.len());
        let mut edge_faces = Vec::with_capacity(edge_map.len());
        for ((a, b), fs) in edge_map {
            edges.push([a, b]);
            edge_faces.push([fs[0], *fs.get(1).unwrap_or(&fs[0])]);
        }
        let radius = vertices.iter().map(|v| v.length()).fold(0.0, f32::max);
        let edge_arcs = edge_faces
            .iter()
            .map(|&[f0, f1]| faces[f1 as usize].normal.cross(faces[f0 as usize].normal))
            .collect();
        // Directions with |u x d|^2 < 1e-10 share an entry (the first one). Such a u lies within
        // REACH of +d or -d, so a hash grid over the unit vectors with cells wider than 2 REACH
        // finds every candidate in the (at most 2 x 2 x 2) cells that the balls of radius REACH
        // around +d and -d touch: linear time, where scanning all directions was quadratic
        // (seconds for a 10k-vertex hull).
        const REACH: f32 = 1.5e-5;
        const CELL: f32 = 4e-5;
        let cell = |v: Vec3| (v / CELL).floor().as_ivec3();
        let mut grid: std::collections::HashMap<IVec3, Vec<u32>> = Default::default();
        let mut edge_dirs: Vec<Vec3> = Vec::new();
        let mut edge_dir_of = Vec::with_capacity(edges.len());
        for &[a, b] in &edges {
            let d = (vertices[b as usize] - vertices[a as usize]).normalize_or_zero();
            let mut found = (d == Vec3::ZERO && !edge_dirs.is_empty()).then_some(0);
            for s in [d, -d] {
                let (lo, hi) = (cell(s - REACH), cell(s + REACH));
                for z in lo.z..=hi.z {
                    for y in lo.y..=hi.y {
                        for x in lo.x..=hi.x {
                            let Some(list) = grid.get(&IVec3::new(x, y, z)) else {
                                continue;
                            };
                            for &k in list {
                                if edge_dirs[k as usize].cross(d).length_squared() < 1e-10 {
                                    found = Some(found.map_or(k, |f: u32| f.min(k)));
                                }
                            }
                        }
                    }
                }
            }
            let k = found.unwrap_or_else(|| {
                edge_dirs.push(d);
                let k = (edge_dirs.len() - 1) as u32;
                grid.entry(cell(d)).or_default().push(k);
                k
            });
            edge_dir_of.push(k);
        }
        let mut p = Self {
            vertices,
            faces,
            face_vertices,
            edges,
            edge_faces,
            edge_arcs,
            edge_dirs,
            edge_dir_of,
            radius,
            box_frame: None,
            corner_box: None,
            face_axes: None,
            lanes: crate::narrow::SoaPoints::default(),
            side_planes: Vec::new(),
            axis_codes: Vec::new(),
            inner: 0.0,
            dir_edges: Vec::new(),
            dir_first: Vec::new(),
            dir_records: Vec::new(),
            dir_end_bound: 0,
        };
        p.inner = Self::inner_bound(&p);
        (p.dir_edges, p.dir_first) = Self::edges_by_direction(&p);
        // (`dir_edges` holds edge indices, and the edges' ends are vertices: both indexed
        // above already.)
        p.dir_records = (p.dir_edges.iter())
            .map(|&edge| {
                let ends = p.edges[edge as usize];
                let sum = p.vertices[ends[0] as usize] + p.vertices[ends[1] as usize];
                DirEdge { sum, edge, ends }
            })
            .collect();
        p.dir_end_bound = (p.dir_records.iter())
            .map(|r| r.ends[0].max(r.ends[1]) as usize + 1)
            .max()
            .unwrap_or(0);
        p.lanes = crate::narrow::SoaPoints::of(&p.vertices);
        p.side_planes = Self::build_side_planes(&p);
        p.axis_codes = (0..p.faces.len())
            .map(|f| AxisCode::of(p.faces[f].normal, p.side_planes(f)))
            .collect();
        p.box_frame = crate::query::support::detect_box(&p);
        p.corner_box = Self::detect_corner_box(&p.vertices);
        p.face_axes = Self::detect_face_axes(&p.faces);
        p
    }

    /// The face of each signed axis when there are six faces and their normals are exactly
    /// the six signed unit axes (see [`ConvexPolyhedron::face_axes`]'s field), else `None`.
    pub fn detect_face_axes(faces: &[Face]) -> Option<[u8; 8]> {
        if faces.len() != 6 {
            return None;
        }
        let mut of = [u8::MAX; 8];
        for (f, face) in faces.iter().enumerate() {
            let c = face.normal.to_array();
            let axis = c.iter().position(|x| x.abs() == 1.0)?;
            if !(0..3).all(|k| k == axis || c[k] == 0.0) {
                return None;
            }
            let code = axis | ((c[axis] < 0.0) as usize) << 2;
            if of[code] != u8::MAX {
                return None;
            }
            of[code] = f as u8;
        }
        Some(of)
    }

    /// `h` when `vertices` are exactly the eight corners `(±h.x, ±h.y, ±h.z)` (each sign
    /// pattern once, every half extent positive), else `None` (see
    /// [`ConvexPolyhedron::corner_box`]'s field). Why the closed form is then the vertices'
    /// smallest projection bitwise: the corner with `v_i = -sign(n_i) h_i` has the products
    /// `-(|n_i| h_i)` (a product's rounding is symmetric in sign), each at most the same
    /// coordinate's product for any other corner; rounded sums are monotonic in each
    /// operand, so its projection, `-((|n.x| h.x + |n.y| h.y) + |n.z| h.z)` with the sums
    /// in the same order, is the smallest.
    pub fn detect_corner_box(vertices: &[Vec3]) -> Option<Vec3> {
        let first = vertices.first()?;
        let h = first.abs();
        if vertices.len() != 8 || !(h.x > 0.0 && h.y > 0.0 && h.z > 0.0) {
            return None;
        }
        let mut seen = 0u32;
        for v in vertices {
            if v.abs() != h {
                return None;
            }
            seen |=
                1 << ((v.x < 0.0) as u32 | ((v.y < 0.0) as u32) << 1 | ((v.z < 0.0) as u32) << 2);
        }
        (seen == 0xff).then_some(h)
    }

    /// The side planes of every face's loop edges, in `face_vertices`' order (see the field).
    fn build_side_planes(p: &Self) -> Vec<(Vec3, f32)> {
        let mut planes = Vec::with_capacity(p.face_vertices.len());
        for (f, face) in p.faces.iter().enumerate() {
            let rl = p.face_loop(f);
            for k in 0..rl.len() {
                let v0 = p.vertices[rl[k] as usize];
                let v1 = p.vertices[rl[if k + 1 < rl.len() { k + 1 } else { 0 }] as usize];
                let side = (v1 - v0).cross(face.normal);
                planes.push((side, side.dot(v0)));
            }
        }
        planes
    }

    /// The side planes `(side, offset)` of face `f`'s loop edges, in loop order: a point
    /// `x` of the face's plane is inside the face when `side . x - offset <= 0` for all.
    #[inline]
    pub(crate) fn side_planes(&self, f: usize) -> &[(Vec3, f32)] {
        let face = &self.faces[f];
        &self.side_planes[face.first as usize..(face.first + face.count) as usize]
    }

    /// The axes of face `f`'s normal and side planes (see the field `axis_codes`).
    #[inline]
    pub(crate) fn axis_code(&self, f: usize) -> AxisCode {
        self.axis_codes[f]
    }

    /// The smallest face offset less `1e-4 * radius` when positive, else minus infinity
    /// (see the field `inner`). The ball of that radius lies inside the hull only when the
    /// faces close the shape (every edge between two faces) and each face's loop is planar
    /// (every loop vertex within `1e-5 * radius` of its face's plane, which passes through
    /// the loop's outermost vertex): a shape built by hand through [`Self::from_faces`]
    /// that is open or has warped faces gets no bound, so no edge axis is left out for it.
    fn inner_bound(p: &ConvexPolyhedron) -> f32 {
        let tol = 1e-5 * p.radius;
        let closed = p.edge_faces.iter().all(|&[a, b]| a != b);
        let planar = (0..p.faces.len()).all(|f| {
            let face = &p.faces[f];
            p.face_loop(f)
                .iter()
                .all(|&v| face.normal.dot(p.vertices[v as usize]) >= face.offset - tol)
        });
        let smallest = p
            .faces
            .iter()
            .map(|f| f.offset)
            .fold(f32::INFINITY, f32::min);
        let inner = smallest - 1e-4 * p.radius;
        if closed && planar && inner > 0.0 && smallest.is_finite() {
            inner
        } else {
            f32::NEG_INFINITY
        }
    }

    /// A lower bound of how far the vertices reach along any unit direction from the
    /// local origin (built by the constructor; see the field `inner`).
    #[inline]
    pub(crate) fn inner_radius(&self) -> f32 {
        self.inner
    }

    /// The edges of direction `d` (`edge_dir_of[e] == d`), in increasing order (built by
    /// the constructor; empty for a direction that is not one of `edge_dirs`).
    /// (The search reads [`ConvexPolyhedron::dir_group`]; this is the tests' oracle.)
    #[cfg(test)]
    pub(crate) fn edges_of_dir(&self, d: usize) -> &[u32] {
        match (self.dir_first.get(d), self.dir_first.get(d + 1)) {
            (Some(&lo), Some(&hi)) => self.dir_edges.get(lo as usize..hi as usize).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// The edges of direction `d` as [`ConvexPolyhedron::edges_of_dir`] gives them, each
    /// with its ends and the sum of their positions (`vertices[v0] + vertices[v1]`); empty
    /// for a direction that is not one of `edge_dirs`.
    #[inline(always)]
    pub(crate) fn dir_group(&self, d: usize) -> &[DirEdge] {
        match (self.dir_first.get(d), self.dir_first.get(d + 1)) {
            (Some(&lo), Some(&hi)) => (self.dir_records)
                .get(lo as usize..hi as usize)
                .unwrap_or(&[]),
            _ => &[],
        }
    }

    /// Whether every end of the direction groups' edges is below `len` (see
    /// `dir_end_bound`): B's points in A's frame, `len` of them, hold them all.
    #[inline(always)]
    pub(crate) fn dir_ends_below(&self, len: usize) -> bool {
        self.dir_end_bound <= len
    }

    /// The edges grouped by direction, in increasing order within each (a counting sort
    /// of `edge_dir_of`), and where each direction's group starts (see `dir_edges`).
    fn edges_by_direction(p: &Self) -> (Vec<u32>, Vec<u32>) {
        let nd = p.edge_dirs.len();
        let mut first = vec![0u32; nd + 1];
        for &d in &p.edge_dir_of {
            if let Some(c) = first.get_mut(d as usize + 1) {
                *c += 1;
            }
        }
        for k in 0..nd {
            first[k + 1] += first[k];
        }
        let mut next = first.clone();
        let mut edges = vec![0u32; first[nd] as usize];
        for (e, &d) in p.edge_dir_of.iter().enumerate() {
            if let Some(slot) = next.get_mut(d as usize).filter(|_| (d as usize) < nd) {
                edges[*slot as usize] = e as u32;
                *slot += 1;
            }
        }
        (edges, first)
    }

    /// The vertices as the separating-axis test's lanes (built by the constructor).
    #[inline]
    pub(crate) fn lanes(&self) -> &crate::narrow::SoaPoints {
        &self.lanes
    }

    /// The vertex loop of face `f`.
    #[inline]
    pub fn face_loop(&self, f: usize) -> &[u32] {
        let face = &self.faces[f];
        &self.face_vertices[face.first as usize..(face.first + face.count) as usize]
    }

    /// The smallest projection of the vertices on `n` (local frame), each computed as
    /// `n.x * v.x + n.y * v.y + n.z * v.z` and the first of equals kept: in closed form for
    /// a box's corners ([`ConvexPolyhedron::corner_box`], the same value but perhaps for the
    /// sign of a zero), else by the loop. A NaN direction gives infinity, as the loop does.
    #[inline]
    pub fn smallest_projection(&self, n: Vec3) -> f32 {
        if let Some(h) = self.corner_box {
            let a = n.abs();
            let d = -((a.x * h.x + a.y * h.y) + a.z * h.z);
            // The loop's first comparison with infinity, kept for a NaN direction.
            return if d < f32::INFINITY { d } else { f32::INFINITY };
        }
        let mut m = f32::INFINITY;
        for v in &self.vertices {
            let d = n.x * v.x + n.y * v.y + n.z * v.z;
            m = if d < m { d } else { m };
        }
        m
    }

    /// Support point: the vertex furthest along `dir` (local frame).
    #[inline]
    pub fn support(&self, dir: Vec3) -> Vec3 {
        let mut best = self.vertices[0];
        let mut best_d = best.dot(dir);
        for &v in &self.vertices[1..] {
            let d = v.dot(dir);
            if d > best_d {
                best_d = d;
                best = v;
            }
        }
        best
    }

    /// Returns a copy with every vertex mapped by `f` (used to move a hull into its principal
    /// frame); planes and radius are recomputed.
    pub fn map_vertices(&self, f: impl Fn(Vec3) -> Vec3) -> Self {
        let vertices = self.vertices.iter().map(|&v| f(v)).collect();
        let loops: Vec<Vec<u32>> = (0..self.faces.len())
            .map(|i| self.face_loop(i).to_vec())
            .collect();
        Self::from_faces(vertices, &loops)
    }
}
