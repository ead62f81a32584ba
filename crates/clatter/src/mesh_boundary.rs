//! Triangle-mesh boundaries (`[[boundary]]` in a scene): static or rigidly moving surfaces
//! made of triangles (hoppers, drums, chutes), with which bodies collide like with walls.
//!
//! # Data
//! A [`Boundary`] keeps its triangles in its own *mesh frame* (the file's coordinates times
//! the scale; the world frame before the motion starts), with per-triangle normals, the
//! triangle across each edge and each vertex's neighbours (for the ghost-contact tests), and
//! a [`MeshGrid`]: a uniform grid with the body grid's cell size (`2 r_max + skin`), built
//! once at load, in which every triangle is listed in each cell its plane slab crosses
//! within its bounding box. The grid moves with the mesh: a body is looked up at its position
//! in the mesh frame. It is the same grid as the bodies' in spirit (same cells, same
//! `27`-neighbourhood reach) without rebinning the triangles at every rebuild.
//!
//! # Motion
//! A boundary's pose at time `t` is closed-form: a translation `v (t' - start)` or a rotation
//! by `|w| (t' - start)` about the axis through `center`, with `t' = clamp(t, start, end)`.
//! While `start <= t < end` its surface moves with velocity `v`, or `w x (x - center)`; that
//! is the motion the contact law sees on side a of the contact (a drum drags its bed).
//!
//! # Contacts
//! At each broad-phase rebuild every body collects its candidate triangles (those within its
//! bounding radius plus the skin), sorted by id. Every step, each body's piece is tested
//! against its candidates ([`clatter_geom::triangle`]), then:
//! - face contacts with coplanar triangles (same boundary, same plane) become **one** plane
//!   contact: a body resting or rolling across a floor of many triangles feels exactly the
//!   plane (the same manifold as a `[[wall]]`, when its contact patch lies on the mesh);
//! - an edge contact is kept only when its normal is in the edge's Voronoi region: not
//!   pointing into the neighbouring triangle's face region (no *ghost* contacts at the
//!   internal edges of flat or convex surfaces), and once per shared edge;
//! - a vertex contact is kept only when its normal points away from every edge at the
//!   vertex (the vertex's Voronoi region), once per vertex.
//!
//! The remaining contacts (at most [`MESH_SLOTS`], the deepest) go into the body's mesh
//! slots, each with a tangential spring and the law's coverage/twist word. A new contact
//! takes over the springs of the old slot of the same boundary with the closest normal
//! (within [`SLOT_MATCH_COS`]), so a ball rolling from one triangle to the next keeps its
//! spring exactly as on a plane.

use glam::{DVec3, Quat, Vec3};

use crate::law::{BodyMotion, ContactForce};

/// Mesh contacts kept per body.
pub const MESH_SLOTS: usize = 4;

/// A new mesh contact takes over an old slot's springs when their normals' cosine is at
/// least this (about 37 degrees).
pub const SLOT_MATCH_COS: f32 = 0.8;

/// No triangle across this edge (a border edge of the mesh).
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// How a boundary moves (rigidly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BoundaryMotion {
    /// It stays where the file puts it.
    Fixed,
    /// Translation at `velocity` (m/s).
    Translate { velocity: Vec3 },
    /// Rotation at `angular_velocity` (rad/s, world frame) about the axis through `center`.
    Rotate {
        angular_velocity: Vec3,
        center: Vec3,
    },
}

/// A rigid transform of a boundary at some time: `world = rotation * local + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshPose {
    pub rotation: Quat,
    pub translation: Vec3,
}

/// The poses are applied with [`crate::turn::rotate`] (not glam's product, which rounds
/// otherwise), bitwise as the GPU's `turn_rotate`: both executors see a moving mesh's
/// triangles at the same coordinates.
impl MeshPose {
    /// A mesh-frame point in the world.
    #[inline]
    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.rotate(p) + self.translation
    }

    /// A world point in the mesh frame.
    #[inline]
    pub fn inverse(&self, p: Vec3) -> Vec3 {
        self.unrotate(p - self.translation)
    }

    /// A mesh-frame direction in the world.
    #[inline]
    pub fn rotate(&self, v: Vec3) -> Vec3 {
        crate::turn::rotate(self.rotation, v)
    }

    /// A world direction in the mesh frame.
    #[inline]
    pub fn unrotate(&self, v: Vec3) -> Vec3 {
        crate::turn::rotate(self.rotation.conjugate(), v)
    }
}

/// The triangles of a boundary, binned into a uniform grid in the mesh frame: the cells
/// that hold something, sorted by key, each with its triangles (sorted by id).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshGrid {
    /// Lower corner (mesh frame).
    pub min: Vec3,
    /// Cell edge length.
    pub cell: f32,
    /// Cells along x, y, z.
    pub dims: [u32; 3],
    /// Keys (`(z ny + y) nx + x`) of the occupied cells, ascending.
    pub keys: Vec<u64>,
    /// Cell `keys[c]` holds `tris[start[c]..start[c + 1]]`.
    pub start: Vec<u32>,
    /// Triangle ids, per cell.
    pub tris: Vec<u32>,
}

/// Most cell entries one boundary's grid may hold before its cells are made larger.
const MAX_GRID_ENTRIES: usize = 1 << 24;

impl MeshGrid {
    fn build(vertices: &[Vec3], triangles: &[[u32; 3]], normals: &[Vec3], cell: f32) -> Self {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for v in vertices {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        let mut cell = cell.max((hi - lo).max_element() * 1e-6).max(1e-9);
        loop {
            let d = ((hi - lo) / cell).floor() + Vec3::ONE;
            let dims = [d.x as u32, d.y as u32, d.z as u32];
            if let Some(g) = Self::fill(vertices, triangles, normals, lo, cell, dims) {
                return g;
            }
            cell *= 2.0;
        }
    }

    /// Bins every triangle into the cells of its bounding box that its plane's slab crosses;
    /// `None` when that makes more than [`MAX_GRID_ENTRIES`] entries.
    fn fill(
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        normals: &[Vec3],
        min: Vec3,
        cell: f32,
        dims: [u32; 3],
    ) -> Option<Self> {
        let mut entries: Vec<(u64, u32)> = Vec::new();
        let half_diag = 0.5 * cell * 3f32.sqrt();
        let cell_of = |x: f32, a: usize| -> u32 {
            (((x - min[a]) / cell).floor().max(0.0) as u32).min(dims[a] - 1)
        };
        for (t, tri) in triangles.iter().enumerate() {
            let p = tri.map(|i| vertices[i as usize]);
            let lo = p[0].min(p[1]).min(p[2]);
            let hi = p[0].max(p[1]).max(p[2]);
            let (c0, c1) = (
                [0, 1, 2].map(|a| cell_of(lo[a], a)),
                [0, 1, 2].map(|a| cell_of(hi[a], a)),
            );
            let n = normals[t];
            let off = n.dot(p[0]);
            for z in c0[2]..=c1[2] {
                for y in c0[1]..=c1[1] {
                    for x in c0[0]..=c1[0] {
                        let centre = min + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * cell;
                        if (n.dot(centre) - off).abs() <= half_diag {
                            let key =
                                (z as u64 * dims[1] as u64 + y as u64) * dims[0] as u64 + x as u64;
                            entries.push((key, t as u32));
                            if entries.len() > MAX_GRID_ENTRIES {
                                return None;
                            }
                        }
                    }
                }
            }
        }
        entries.sort_unstable();
        let mut g = MeshGrid {
            min,
            cell,
            dims,
            ..Default::default()
        };
        for (key, t) in entries {
            if g.keys.last() != Some(&key) {
                g.keys.push(key);
                g.start.push(g.tris.len() as u32);
            }
            g.tris.push(t);
        }
        g.start.push(g.tris.len() as u32);
        Some(g)
    }

    /// Appends to `out` the triangles of every cell that the ball `(centre, radius)` (mesh
    /// frame) overlaps (with repeats).
    pub fn query(&self, centre: Vec3, radius: f32, out: &mut Vec<u32>) {
        if self.keys.is_empty() {
            return;
        }
        let lo = ((centre - radius - self.min) / self.cell).floor();
        let hi = ((centre + radius - self.min) / self.cell).floor();
        let dims = Vec3::new(
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
        );
        if hi.cmplt(Vec3::ZERO).any() || lo.cmpge(dims).any() || !(lo.is_finite() && hi.is_finite())
        {
            return;
        }
        let lo = lo.max(Vec3::ZERO);
        let hi = hi.min(dims - 1.0);
        for z in lo.z as u64..=hi.z as u64 {
            for y in lo.y as u64..=hi.y as u64 {
                for x in lo.x as u64..=hi.x as u64 {
                    let key = (z * self.dims[1] as u64 + y) * self.dims[0] as u64 + x;
                    if let Ok(c) = self.keys.binary_search(&key) {
                        out.extend_from_slice(
                            &self.tris[self.start[c] as usize..self.start[c + 1] as usize],
                        );
                    }
                }
            }
        }
    }
}

/// A triangle-mesh boundary: its triangles (mesh frame), material and motion. See the module
/// docs.
#[derive(Debug, Clone, PartialEq)]
pub struct Boundary {
    /// The mesh file as the scene names it (for messages and outputs).
    pub file: String,
    /// Material bodies touch it with.
    pub material: u32,
    /// Its motion.
    pub motion: BoundaryMotion,
    /// When the motion starts (s).
    pub start: f64,
    /// When it stops (s; infinite: never).
    pub end: f64,
    /// Vertices, mesh frame (welded within the tolerance, see [`crate::mesh_repair`]).
    pub vertices: Vec<Vec3>,
    /// Triangles (vertex indices; cleaned: each connected part wound consistently, closed
    /// parts outwards).
    pub triangles: Vec<[u32; 3]>,
    /// Unit normal per triangle (right-handed with the winding).
    pub normals: Vec<Vec3>,
    /// Per triangle and edge `k` (vertex `k` to `k + 1`): the triangle across it, or
    /// [`NO_NEIGHBOUR`].
    pub neighbours: Vec<[u32; 3]>,
    /// Vertex `v`'s neighbour vertices are `links[link_start[v]..link_start[v + 1]]`.
    pub link_start: Vec<u32>,
    pub links: Vec<u32>,
    /// Largest distance of a vertex from the rotation centre (or 0): bounds how far a point
    /// of the mesh moves per radian.
    pub reach: f32,
    /// The triangles binned in the mesh frame (built by the world, with its cell size).
    pub grid: MeshGrid,
    /// What cleaning the file's mesh changed ([`crate::mesh_repair`]).
    pub repairs: crate::mesh_repair::MeshRepairs,
}

impl Boundary {
    /// Builds a boundary from a mesh's vertices (file coordinates, scaled by `scale`) and
    /// triangles, cleaned by [`crate::mesh_repair::repair`] with the default weld tolerance;
    /// see [`Boundary::from_repaired`]. The error says what cannot be a surface (the caller
    /// names the file and field): no triangles, an index out of range, a non-finite
    /// coordinate, or no triangle with an area.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        file: &str,
        vertices: &[[f64; 3]],
        triangles: &[[u32; 3]],
        scale: [f64; 3],
        material: u32,
        motion: BoundaryMotion,
        start: f64,
        end: f64,
    ) -> Result<Boundary, String> {
        let mesh = crate::mesh_repair::repair(vertices, triangles, scale, None)?;
        Ok(Boundary::from_repaired(
            file, mesh, material, motion, start, end,
        ))
    }

    /// Builds a boundary from a cleaned mesh: per-triangle normals (right-handed with the
    /// cleaned winding) and adjacency. At an edge shared by more than two triangles the
    /// triangles are paired by [`crate::mesh_repair::pair_edge_users`] (the flattest
    /// continuations); a triangle left without a partner treats the edge as a border.
    pub fn from_repaired(
        file: &str,
        mesh: crate::mesh_repair::Repaired,
        material: u32,
        motion: BoundaryMotion,
        start: f64,
        end: f64,
    ) -> Boundary {
        let crate::mesh_repair::Repaired {
            vertices: pos,
            triangles: tris,
            repairs,
        } = mesh;
        let normals: Vec<Vec3> = tris
            .iter()
            .map(|w| {
                let [a, b, c] = w.map(|i| pos[i as usize]);
                (b - a).cross(c - a).normalize().as_vec3()
            })
            .collect();
        let mut neighbours = vec![[NO_NEIGHBOUR; 3]; tris.len()];
        let mut sorted: Vec<_> = crate::mesh_repair::edge_users(&tris).into_iter().collect();
        sorted.sort_unstable();
        let mut link_pairs = Vec::with_capacity(2 * sorted.len());
        for ((a, b), users) in &sorted {
            link_pairs.push((*a, *b));
            link_pairs.push((*b, *a));
            let pairs = match users.len() {
                2 => vec![(0, 1)],
                n if n > 2 => {
                    let dirs: Vec<DVec3> = users
                        .iter()
                        .map(|&(t, _)| into_triangle(&pos, &tris[t as usize], *a, *b))
                        .collect();
                    crate::mesh_repair::pair_edge_users(&dirs)
                }
                _ => Vec::new(),
            };
            for (i, j) in pairs {
                let ((t0, k0), (t1, k1)) = (users[i], users[j]);
                neighbours[t0 as usize][k0 as usize] = t1;
                neighbours[t1 as usize][k1 as usize] = t0;
            }
        }
        link_pairs.sort_unstable();
        link_pairs.dedup();
        let mut link_start = vec![0u32; pos.len() + 1];
        for &(a, _) in &link_pairs {
            link_start[a as usize + 1] += 1;
        }
        for v in 0..pos.len() {
            link_start[v + 1] += link_start[v];
        }
        let links = link_pairs.iter().map(|&(_, b)| b).collect();
        let vertices: Vec<Vec3> = pos.iter().map(|p| p.as_vec3()).collect();
        let reach = match motion {
            BoundaryMotion::Rotate { center, .. } => vertices
                .iter()
                .map(|v| (*v - center).length())
                .fold(0.0, f32::max),
            _ => 0.0,
        };
        Boundary {
            file: file.to_string(),
            material,
            motion,
            start,
            end,
            vertices,
            triangles: tris,
            normals,
            neighbours,
            link_start,
            links,
            reach,
            grid: MeshGrid::default(),
            repairs,
        }
    }

    /// Bins the triangles with cells of `cell` (the world does this once it knows its cell
    /// size).
    pub fn build_grid(&mut self, cell: f32) {
        self.grid = MeshGrid::build(&self.vertices, &self.triangles, &self.normals, cell);
    }

    /// How long the motion has run at time `t` (s, f32 as both backends compute it).
    #[inline]
    fn elapsed(&self, t: f64) -> f32 {
        (t.clamp(self.start, self.end.max(self.start)) - self.start) as f32
    }

    /// The motion's elapsed time at `t` as a double-single `(hi, lo)` (the GPU's clock
    /// `u`, clamped to the motion's span): the f64 difference split into two f32.
    pub fn elapsed_ds(&self, t: f64) -> (f32, f32) {
        let u = t.clamp(self.start, self.end.max(self.start)) - self.start;
        let hi = u as f32;
        if !hi.is_finite() {
            return (hi, 0.0);
        }
        (hi, (u - hi as f64) as f32)
    }

    /// The boundary's pose at time `t`. A rotation's is [`crate::turn`]'s, bitwise that of
    /// the GPU: the angle `rate u mod 2 pi` from the double-single elapsed time, so that long
    /// runs keep their precision.
    pub fn pose(&self, t: f64) -> MeshPose {
        let tau = self.elapsed(t);
        match self.motion {
            BoundaryMotion::Fixed => MeshPose {
                rotation: Quat::IDENTITY,
                translation: Vec3::ZERO,
            },
            BoundaryMotion::Translate { velocity } => MeshPose {
                rotation: Quat::IDENTITY,
                translation: velocity * tau,
            },
            BoundaryMotion::Rotate {
                angular_velocity,
                center,
            } => {
                let rate = angular_velocity.length();
                if rate > 0.0 {
                    // Not yet started: exactly 0 (as the GPU has it, signed zeros included).
                    let u = self.elapsed_ds(t);
                    let angle = if u.0 > 0.0 || (u.0 == 0.0 && u.1 > 0.0) {
                        crate::turn::turn_angle(rate, u)
                    } else {
                        0.0
                    };
                    let (rotation, translation) =
                        crate::turn::turn_pose(angular_velocity / rate, center, angle);
                    MeshPose {
                        rotation,
                        translation,
                    }
                } else {
                    MeshPose {
                        rotation: Quat::IDENTITY,
                        translation: Vec3::ZERO,
                    }
                }
            }
        }
    }

    /// The rigid motion of the boundary's surface at time `t`, as the contact law's side a.
    pub fn motion_at(&self, t: f64) -> BodyMotion {
        if !(t >= self.start && t < self.end) {
            return BodyMotion::default();
        }
        match self.motion {
            BoundaryMotion::Fixed => BodyMotion::default(),
            BoundaryMotion::Translate { velocity } => BodyMotion {
                position: Vec3::ZERO,
                velocity,
                omega: Vec3::ZERO,
            },
            BoundaryMotion::Rotate {
                angular_velocity,
                center,
            } => BodyMotion {
                position: center,
                velocity: Vec3::ZERO,
                omega: angular_velocity,
            },
        }
    }

    /// An upper bound of how far any point of the mesh moves between times `t0` and `t1`.
    pub fn displacement_bound(&self, t0: f64, t1: f64) -> f32 {
        let d = (self.elapsed(t1) - self.elapsed(t0)).abs();
        match self.motion {
            BoundaryMotion::Fixed => 0.0,
            BoundaryMotion::Translate { velocity } => velocity.length() * d * 1.000_001,
            BoundaryMotion::Rotate {
                angular_velocity, ..
            } => angular_velocity.length() * d * self.reach * 1.000_001,
        }
    }

    /// Whether the boundary ever moves.
    pub fn moves(&self) -> bool {
        match self.motion {
            BoundaryMotion::Fixed => false,
            BoundaryMotion::Translate { velocity } => velocity != Vec3::ZERO,
            BoundaryMotion::Rotate {
                angular_velocity, ..
            } => angular_velocity != Vec3::ZERO,
        }
    }

    /// Triangle `t`'s vertices in the world at `pose`.
    #[inline]
    pub fn world_triangle(&self, t: usize, pose: &MeshPose) -> [Vec3; 3] {
        self.triangles[t].map(|i| pose.apply(self.vertices[i as usize]))
    }

    /// Whether an edge contact on edge `k` of triangle `t`, with unit normal `d` (mesh
    /// frame), lies in the edge's Voronoi region: it does not point into the face region of
    /// the triangle across the edge (within a small tolerance).
    pub fn edge_region(&self, t: usize, k: usize, d: Vec3) -> bool {
        let other = self.neighbours[t][k];
        if other == NO_NEIGHBOUR {
            return true;
        }
        let o = other as usize;
        let [a, b] = [
            self.triangles[t][k] as usize,
            self.triangles[t][(k + 1) % 3] as usize,
        ];
        let (va, vb) = (self.vertices[a], self.vertices[b]);
        let apex = self.triangles[o]
            .iter()
            .map(|&i| i as usize)
            .find(|&i| i != a && i != b)
            .unwrap_or(a);
        let e = vb - va;
        // In the other triangle's plane, perpendicular to the edge, pointing into it.
        let mut u = self.normals[o].cross(e).normalize_or_zero();
        if u.dot(self.vertices[apex] - va) < 0.0 {
            u = -u;
        }
        d.dot(u) <= REGION_TOLERANCE
    }

    /// Whether a vertex contact at vertex `v` with unit normal `d` (mesh frame) lies in the
    /// vertex's Voronoi region: `d` points away from (or across) every edge at the vertex.
    pub fn vertex_region(&self, v: usize, d: Vec3) -> bool {
        let p = self.vertices[v];
        self.links[self.link_start[v] as usize..self.link_start[v + 1] as usize]
            .iter()
            .all(|&w| {
                let e = self.vertices[w as usize] - p;
                d.dot(e) <= REGION_TOLERANCE * e.length()
            })
    }
}

/// The unit direction from the edge `a b` into triangle `tri`, in its plane: towards its
/// third corner.
fn into_triangle(pos: &[DVec3], tri: &[u32; 3], a: u32, b: u32) -> DVec3 {
    let apex = tri.iter().copied().find(|&i| i != a && i != b).unwrap_or(a);
    let (pa, e) = (pos[a as usize], pos[b as usize] - pos[a as usize]);
    let d = pos[apex as usize] - pa;
    (d - e * (d.dot(e) / e.length_squared())).normalize_or_zero()
}

/// How far (cosine) a feature contact's normal may lean into a neighbouring region and still
/// count as the feature's.
const REGION_TOLERANCE: f32 = 1e-5;

/// One mesh contact slot of a body: the springs it carries, its normal (to match the next
/// step's contacts) and what the last step computed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MeshSlot {
    /// The boundary touched.
    pub boundary: u32,
    /// The body's piece that touches it (0 unless the body is a composite): a slot's springs
    /// pass only to a contact of the same piece.
    pub piece: u32,
    /// Whether the slot held a contact in the last step.
    pub touching: bool,
    /// The contact's normal in the last step (from the boundary to the body).
    pub normal: Vec3,
    /// Tangential spring.
    pub history: Vec3,
    /// The law's twist / coverage word.
    pub twist: f32,
    /// The last step's force (the body is side b).
    pub force: ContactForce,
}

/// The mesh contacts of every body: candidates from the last rebuild and the slots.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshContacts {
    /// Body `i`'s candidate triangles are `candidates[start[i]..start[i + 1]]`: global ids
    /// (boundary `b`'s triangle `t` is `first[b] + t`), ascending.
    pub start: Vec<u32>,
    pub candidates: Vec<u32>,
    /// The bodies that have candidates, ascending (the others' slots are clear).
    pub active: Vec<u32>,
    /// The first global triangle id of each boundary (and the total at the end).
    pub first: Vec<u32>,
    /// [`MESH_SLOTS`] per body.
    pub slots: Vec<MeshSlot>,
    /// Per body, the force and torque of its mesh contacts summed in slot order (zero for
    /// bodies without): what the integrate stage adds.
    pub total: Vec<[Vec3; 2]>,
    /// The time of the last rebuild (the mesh poses the candidates were found at).
    pub rebuild_time: f64,
}

impl MeshContacts {
    /// The boundary and its triangle of global id `g`.
    #[inline]
    pub fn locate(&self, g: u32) -> (usize, usize) {
        let b = self.first.partition_point(|&f| f <= g) - 1;
        (b, (g - self.first[b]) as usize)
    }

    /// Body `i`'s [`MESH_SLOTS`] slots (none in a world without boundaries).
    #[inline]
    pub fn body_slots(&self, i: usize) -> &[MeshSlot] {
        self.slots
            .get(i * MESH_SLOTS..(i + 1) * MESH_SLOTS)
            .unwrap_or(&[])
    }

    /// Body `i`'s mesh force and torque added to `(f, t)`.
    #[inline]
    pub fn gather(&self, i: usize, f: Vec3, t: Vec3) -> (Vec3, Vec3) {
        let [mf, mt] = self.total[i];
        (f + mf, t + mt)
    }

    /// Sums the slots of body `i` into its total, in slot order.
    pub fn sum_slots(slots: &[MeshSlot]) -> [Vec3; 2] {
        let (mut f, mut t) = (Vec3::ZERO, Vec3::ZERO);
        for s in slots {
            if s.touching {
                f += s.force.force_b;
                t += s.force.torque_b;
            }
        }
        [f, t]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        (
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn adjacency_and_regions() {
        let (v, t) = square();
        let b = Boundary::new("sq", &v, &t, [1.0; 3], 0, BoundaryMotion::Fixed, 0.0, 1.0).unwrap();
        // Edge 2 of triangle 0 (vertex 2 -> 0) is shared with triangle 1's edge 0.
        assert_eq!(b.neighbours[0], [NO_NEIGHBOUR, NO_NEIGHBOUR, 1]);
        assert_eq!(b.neighbours[1], [0, NO_NEIGHBOUR, NO_NEIGHBOUR]);
        // A normal straight up at the internal edge is in its region (flat surface: the
        // face's normal); one leaning into triangle 1 is not.
        assert!(b.edge_region(0, 2, Vec3::Z));
        let lean = Vec3::new(-1.0, 1.0, 1.0).normalize();
        assert!(!b.edge_region(0, 2, lean));
        // A border edge accepts any normal.
        assert!(b.edge_region(0, 0, -Vec3::Y));
        // Vertex 0 (corner): a normal pointing out of the corner is its own, up is not
        // beyond the edges, into the square is not.
        assert!(b.vertex_region(0, Vec3::new(-1.0, -1.0, 0.5).normalize()));
        assert!(!b.vertex_region(0, Vec3::new(1.0, 0.2, 0.5).normalize()));
    }

    #[test]
    fn bad_meshes_refused_awkward_ones_cleaned() {
        let (v, t) = square();
        let motion = BoundaryMotion::Fixed;
        let make = |v: &[[f64; 3]], t: &[[u32; 3]]| {
            Boundary::new("m", v, t, [1.0; 3], 0, motion, 0.0, 1.0)
        };
        let err = |v: &[[f64; 3]], t: &[[u32; 3]]| make(v, t).unwrap_err();
        assert!(err(&v, &[]).contains("empty"));
        assert!(err(&v, &[[0, 1, 7]]).contains("vertex 7"));
        assert!(err(&v, &[[0, 1, 1]]).contains("degenerate"));
        let mut nan = v.clone();
        nan[2][1] = f64::NAN;
        assert!(err(&nan, &t).contains("non-finite"));
        // Neighbours wound against each other: re-wound like the first, same adjacency.
        let mixed = make(&v, &[[0, 1, 2], [0, 3, 2]]).unwrap();
        assert_eq!(mixed.triangles, t);
        assert_eq!(mixed.repairs.rewound, 1);
        assert_eq!(mixed.neighbours[0], [NO_NEIGHBOUR, NO_NEIGHBOUR, 1]);
        // A fin on an edge shared by three triangles: the two flat ones are each other's
        // neighbours, the fin's base is a border.
        let mut fin = v.clone();
        fin.push([0.5, 0.5, 1.0]);
        let b = make(&fin, &[[0, 1, 2], [0, 2, 3], [0, 2, 4]]).unwrap();
        assert_eq!(b.repairs.non_manifold, 1);
        assert_eq!(b.neighbours[0][2], 1);
        assert_eq!(b.neighbours[1][0], 0);
        assert_eq!(b.neighbours[2], [NO_NEIGHBOUR; 3]);
        // A tetrahedron wound inside out is turned outwards, as the outward one.
        let tv = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let out = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let good = make(&tv, &out).unwrap();
        let inside: Vec<[u32; 3]> = out.iter().map(|t| [t[0], t[2], t[1]]).collect();
        let turned = make(&tv, &inside).unwrap();
        assert_eq!(turned.repairs.inward_parts, 1);
        assert_eq!(
            (turned.triangles, turned.normals, turned.neighbours),
            (good.triangles, good.normals, good.neighbours)
        );
    }

    #[test]
    fn grid_finds_what_brute_force_finds() {
        // A bumpy 10 x 10 sheet of 200 triangles; every ball's grid candidates include every
        // triangle whose bounding box the ball's box overlaps.
        let n = 10;
        let mut v = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 * 0.1, j as f64 * 0.1);
                v.push([x, y, 0.03 * ((7.0 * x).sin() + (5.0 * y).cos())]);
            }
        }
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = (j * (n + 1) + i) as u32;
                t.push([a, a + 1, a + n as u32 + 2]);
                t.push([a, a + n as u32 + 2, a + n as u32 + 1]);
            }
        }
        let mut b =
            Boundary::new("g", &v, &t, [1.0; 3], 0, BoundaryMotion::Fixed, 0.0, 1.0).unwrap();
        b.build_grid(0.037);
        let mut out = Vec::new();
        for k in 0..500 {
            let c = Vec3::new(
                (k as f32 * 0.618).fract() * 1.2 - 0.1,
                (k as f32 * 0.377).fract() * 1.2 - 0.1,
                (k as f32 * 0.211).fract() * 0.2 - 0.1,
            );
            let r = 0.02;
            out.clear();
            b.grid.query(c, r, &mut out);
            for (ti, tri) in b.triangles.iter().enumerate() {
                let p = tri.map(|i| b.vertices[i as usize]);
                let (q, _) = clatter_geom::triangle::closest_on_triangle(c, p[0], p[1], p[2]);
                if (q - c).length() < r {
                    assert!(out.contains(&(ti as u32)), "ball {k} misses triangle {ti}");
                }
            }
        }
    }
}
