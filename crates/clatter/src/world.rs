//! The world: bodies (state and constants, structure of arrays; composites with their
//! pieces' reaches), materials, walls, triangle-mesh boundaries, the periodic box, sinks and
//! the contact list. The step that advances it, and whatever else needs a stage (rebuilding
//! the contact list, taking one over from the GPU), is in [`crate::step`]: the stages use
//! the world, the world does not call them.

use glam::{DVec3, Quat, Vec3};
use thiserror::Error;

use crate::bodies::{BodyConstants, BodyStates};
use crate::contact_list::{ContactState, Contacts};
use crate::exact_sum::ExactSum;
use crate::law::{BodyMotion, ContactForce};
use crate::material::{Material, Materials, PairParams};
use crate::mesh_boundary::{Boundary, MESH_SLOTS, MeshContacts, MeshSlot};
use crate::periodic::Periodic;
use crate::precise::{self, PositionPairs};
use crate::sink::{Discharged, Sink};
use clatter_geom::narrow::{Manifold, Plane};
use clatter_geom::{Pose, PreparedShape, Shape};

/// A body as placed by a scene: which shape and material, and its initial state.
/// `orientation` is in the frame the shape was authored in; `position` is the centre of mass
/// (f64, kept at full precision).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyInit {
    pub shape: u32,
    pub material: u32,
    pub position: DVec3,
    pub orientation: Quat,
    pub velocity: Vec3,
    pub angular_velocity: Vec3,
}

/// An infinite wall plane with the material bodies touch it with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    pub plane: Plane,
    pub material: u32,
}

/// Everything needed to build a [`World`].
#[derive(Debug, Clone, PartialEq)]
pub struct WorldDesc {
    pub shapes: Vec<PreparedShape>,
    pub materials: Vec<Material>,
    pub walls: Vec<Wall>,
    pub bodies: Vec<BodyInit>,
    /// m/s^2.
    pub gravity: Vec3,
    /// Time step; `None` picks `t_c / 50` from the stiffest contact (see [`World::auto_dt`]).
    pub dt: Option<f32>,
    /// Verlet skin (m); `None` uses 10% of the largest bounding diameter.
    pub skin: Option<f32>,
    /// Periodic boundaries, if any.
    pub periodic: Option<Periodic>,
}

/// Why a step could not go on.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimError {
    /// A body's state became NaN or infinite.
    #[error(
        "body {body} has a non-finite position or velocity at step {step} (t = {time:.6e} s): the simulation blew up; the time step ({dt:.3e} s) is probably too large for the stiffness, or bodies start overlapping deeply"
    )]
    NonFinite {
        body: usize,
        step: u64,
        time: f64,
        dt: f32,
    },
}

/// What one step found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepStats {
    /// Body-body and body-wall contacts that touch (manifolds with at least one point).
    pub contacts: usize,
    /// Whether the broad phase was rebuilt this step.
    pub rebuilt: bool,
}

/// A simulation: bodies (state and constants), materials, walls and the contact list.
#[derive(Debug, Clone)]
pub struct World {
    /// The shapes bodies refer to.
    pub shapes: Vec<PreparedShape>,
    /// The materials bodies and walls refer to, with their pair table.
    pub materials: Materials,
    /// Wall planes.
    pub walls: Vec<Wall>,
    /// Triangle-mesh boundaries (static or moving), see [`crate::mesh_boundary`].
    pub boundaries: Vec<Boundary>,
    /// Per body: candidate triangles and mesh contact slots.
    pub(crate) mesh: MeshContacts,
    /// Periodic boundaries, if any (positions are kept wrapped into its box).
    pub periodic: Option<Periodic>,
    /// Sink boxes: a body whose centre enters one is removed ([`crate::sink`]). Set after
    /// [`World::new`] (the scene loader does, from `[[sink]]`).
    pub sinks: Vec<Sink>,
    /// Gravity, m/s^2.
    pub gravity: Vec3,
    /// Time step, s.
    pub dt: f32,
    /// Verlet skin, m: the broad phase finds pairs within it and is rebuilt once a body has
    /// moved half of it.
    pub skin: f32,
    /// Simulated time, s.
    pub time: f64,
    /// Steps taken.
    pub step_count: u64,
    /// Broad-phase rebuilds so far.
    pub rebuilds: u64,
    /// What the step integrates, per body.
    pub state: BodyStates,
    /// What the step reads, per body.
    pub consts: BodyConstants,
    /// Candidate contacts and their springs.
    pub contacts: Contacts,
    /// Every body is a sphere: the contact stage takes the sphere-sphere fast path.
    spheres_only: bool,
    /// Some body is a composite: contacts are kept per piece pair.
    has_composites: bool,
    /// Per body, how far a rotation can carry a piece (0 unless a composite; empty when no
    /// body is a composite).
    pub(crate) reach: Vec<f32>,
    /// Orientations at the last broad-phase rebuild (composite worlds only; empty otherwise):
    /// the pieces' pairs were found at these.
    pub(crate) rebuild_orientation: Vec<Quat>,
    /// Positions at the last broad-phase rebuild.
    pub(crate) rebuild_position: Vec<DVec3>,
    /// The positions as pairs ([`precise::Ds3A`]), split once per step when the contact
    /// stage starts ([`World::split_positions`]) and read by the contact stage and integrate:
    /// a pair's offset then needs no `f64` splits. Stale outside a step.
    pub(crate) position_pairs: Vec<precise::Ds3A>,
    /// Per body, its motion over the last step as the contact stage's bounds read it, made
    /// with [`World::position_pairs`] (`step::motion`). Stale outside a step.
    pub(crate) body_bounds: Vec<crate::step::motion::BodyBound>,
    /// Per body pair (by contact slot), what its Gauss-map edge search remembers
    /// ([`clatter_geom::narrow::EdgeMemory`]): a cache that changes no result (a memory
    /// serves only the polyhedra and the rotation it was recorded for), so it is in no
    /// checkpoint and need not follow its pair when the contact list is rebuilt.
    pub(crate) edge_memory: Vec<clatter_geom::narrow::EdgeMemory>,
    /// The allocation the next rebuild carries the edge memories into (`step::caches`).
    pub(crate) edge_memory_spare: crate::step::caches::Spare<clatter_geom::narrow::EdgeMemory>,
    needs_rebuild: bool,
    /// Per body, whether it is a ghost: a copy of a body another MPI rank owns
    /// ([`crate::domain`]), read by the contacts of this rank's bodies but never integrated,
    /// and in no pair with another ghost nor in any wall pair. Empty (no ghosts) outside
    /// a domain decomposition.
    pub(crate) ghost: Vec<bool>,
}

impl World {
    /// Builds the world; the caller (the scene loader) has validated indices and values.
    pub fn new(desc: WorldDesc) -> World {
        World::with_boundaries(desc, Vec::new())
    }

    /// [`World::new`] with triangle-mesh boundaries (their grids are built here, with the
    /// body grid's cell size `2 r_max + skin`).
    pub fn with_boundaries(desc: WorldDesc, boundaries: Vec<Boundary>) -> World {
        let n = desc.bodies.len();
        let mut state = BodyStates::default();
        let mut consts = BodyConstants::default();
        let materials = Materials::new(desc.materials);
        for b in &desc.bodies {
            let shape = &desc.shapes[b.shape as usize];
            let density = materials.list()[b.material as usize].density;
            let mass = density * shape.volume;
            let inertia = shape.unit_inertia * density;
            let q = (b.orientation * shape.frame).normalize();
            // Wrapped, and on the grid of stored positions (48 bits: `precise::snap`).
            let x = desc.periodic.map_or(b.position, |p| p.wrap_f64(b.position));
            state
                .position
                .push(precise::join(precise::snap(precise::split(x))));
            state.velocity.push(b.velocity);
            state.orientation.push(q);
            let body_w = q.conjugate() * b.angular_velocity;
            state.angular_momentum.push(q * (inertia * body_w));
            state.omega.push(b.angular_velocity);
            consts.shape.push(b.shape);
            consts.material.push(b.material);
            consts
                .is_sphere
                .push(matches!(shape.shape, Shape::Sphere { .. }));
            consts.mass.push(mass);
            consts.inertia.push(inertia);
            consts.inv_mass.push(1.0 / mass);
            consts.inv_inertia.push(inertia.recip());
            consts.radius.push(shape.shape.bounding_radius());
            consts
                .equivalent_radius
                .push((3.0 * shape.volume / (4.0 * std::f32::consts::PI)).cbrt());
        }
        state.orientation_residual = vec![Quat::from_xyzw(0.0, 0.0, 0.0, 0.0); n];
        state.removed = vec![false; n];
        let spheres_only = consts.is_sphere.iter().all(|&s| s);
        let reach_of = |s: u32| match &desc.shapes[s as usize].shape {
            Shape::Composite(c) => Some(c.reach),
            _ => None,
        };
        let has_composites = consts.shape.iter().any(|&s| reach_of(s).is_some());
        let reach = if has_composites {
            consts
                .shape
                .iter()
                .map(|&s| reach_of(s).unwrap_or(0.0))
                .collect()
        } else {
            Vec::new()
        };
        let skin = desc.skin.unwrap_or(0.2 * consts.max_radius());
        let mut w = World {
            shapes: desc.shapes,
            materials,
            walls: desc.walls,
            boundaries,
            mesh: MeshContacts::default(),
            periodic: desc.periodic,
            sinks: Vec::new(),
            gravity: desc.gravity,
            dt: 0.0,
            skin,
            time: 0.0,
            step_count: 0,
            rebuilds: 0,
            state,
            consts,
            contacts: Contacts::default(),
            spheres_only,
            has_composites,
            reach,
            rebuild_orientation: Vec::new(),
            rebuild_position: Vec::new(),
            position_pairs: Vec::new(),
            body_bounds: Vec::new(),
            edge_memory: Vec::new(),
            edge_memory_spare: Default::default(),
            needs_rebuild: true,
            ghost: Vec::new(),
        };
        if !w.boundaries.is_empty() {
            let cell = 2.0 * w.consts.max_radius() + w.skin;
            let mut first = vec![0u32];
            for b in &mut w.boundaries {
                b.build_grid(cell);
                first.push(first.last().copied().unwrap_or(0) + b.triangles.len() as u32);
            }
            w.mesh.first = first;
            w.mesh.slots = vec![MeshSlot::default(); n * MESH_SLOTS];
            w.mesh.total = vec![[Vec3::ZERO; 2]; n];
        }
        w.dt = desc.dt.unwrap_or_else(|| w.auto_dt());
        w
    }

    /// The world of bodies `ids` (ascending) of this one, `ghost[k]` saying whether body
    /// `ids[k]` is a ghost there (`World::ghost`): the same shapes, materials, walls,
    /// gravity, `dt`, skin, clock and code paths (sphere-only, composites: taken from this
    /// world, not from the subset, so that every pair is computed as here), the bodies'
    /// states and constants copied, no contact list (a rebuild is due). Mesh boundaries are
    /// not carried (their per-body slots would have to be). What an MPI rank steps
    /// ([`crate::domain`]).
    pub fn subset(&self, ids: &[u32], ghost: Vec<bool>) -> World {
        debug_assert_eq!(ids.len(), ghost.len());
        let pick = |i: &u32| *i as usize;
        let s = &self.state;
        let c = &self.consts;
        let state = BodyStates {
            position: ids.iter().map(|i| s.position[pick(i)]).collect(),
            velocity: ids.iter().map(|i| s.velocity[pick(i)]).collect(),
            orientation: ids.iter().map(|i| s.orientation[pick(i)]).collect(),
            orientation_residual: ids
                .iter()
                .map(|i| s.orientation_residual[pick(i)])
                .collect(),
            angular_momentum: ids.iter().map(|i| s.angular_momentum[pick(i)]).collect(),
            omega: ids.iter().map(|i| s.omega[pick(i)]).collect(),
            removed: ids.iter().map(|i| s.removed[pick(i)]).collect(),
        };
        let consts = BodyConstants {
            shape: ids.iter().map(|i| c.shape[pick(i)]).collect(),
            material: ids.iter().map(|i| c.material[pick(i)]).collect(),
            is_sphere: ids.iter().map(|i| c.is_sphere[pick(i)]).collect(),
            mass: ids.iter().map(|i| c.mass[pick(i)]).collect(),
            inertia: ids.iter().map(|i| c.inertia[pick(i)]).collect(),
            inv_mass: ids.iter().map(|i| c.inv_mass[pick(i)]).collect(),
            inv_inertia: ids.iter().map(|i| c.inv_inertia[pick(i)]).collect(),
            radius: ids.iter().map(|i| c.radius[pick(i)]).collect(),
            equivalent_radius: ids.iter().map(|i| c.equivalent_radius[pick(i)]).collect(),
        };
        // Mesh boundaries: the bodies' slots (springs); candidates at the next rebuild.
        let mesh = if self.boundaries.is_empty() {
            MeshContacts::default()
        } else {
            let m = &self.mesh;
            let slots: Vec<MeshSlot> = ids
                .iter()
                .flat_map(|&i| m.body_slots(i as usize).iter().copied())
                .collect();
            MeshContacts {
                first: m.first.clone(),
                total: ids.iter().map(|&i| m.total[i as usize]).collect(),
                slots,
                rebuild_time: m.rebuild_time,
                ..MeshContacts::default()
            }
        };
        World {
            shapes: self.shapes.clone(),
            materials: self.materials.clone(),
            walls: self.walls.clone(),
            boundaries: self.boundaries.clone(),
            mesh,
            periodic: self.periodic,
            sinks: self.sinks.clone(),
            gravity: self.gravity,
            dt: self.dt,
            skin: self.skin,
            time: self.time,
            step_count: self.step_count,
            rebuilds: self.rebuilds,
            state,
            consts,
            contacts: Contacts::default(),
            spheres_only: self.spheres_only,
            has_composites: self.has_composites,
            reach: if self.reach.is_empty() {
                Vec::new()
            } else {
                ids.iter().map(|i| self.reach[pick(i)]).collect()
            },
            rebuild_orientation: Vec::new(),
            rebuild_position: Vec::new(),
            needs_rebuild: true,
            ghost,
            position_pairs: Vec::new(),
            body_bounds: Vec::new(),
            edge_memory: Vec::new(),
            edge_memory_spare: Default::default(),
        }
    }

    /// Whether body `i` is a ghost (a copy of another rank's body, see [`World::subset`]).
    #[inline]
    pub fn is_ghost(&self, i: usize) -> bool {
        self.ghost.get(i).copied().unwrap_or(false)
    }

    /// Every body's mesh contact slots ([`MESH_SLOTS`] per body; empty without boundaries).
    pub fn mesh_slots(&self) -> &[MeshSlot] {
        &self.mesh.slots
    }

    /// Replaces the mesh slots (a checkpoint's); fails when the length does not match.
    pub fn set_mesh_slots(&mut self, slots: Vec<MeshSlot>) -> Result<(), String> {
        if slots.len() != self.mesh.slots.len() {
            return Err(format!(
                "{} mesh contact slots for {} expected",
                slots.len(),
                self.mesh.slots.len()
            ));
        }
        for (i, t) in self.mesh.total.iter_mut().enumerate() {
            *t = MeshContacts::sum_slots(&slots[i * MESH_SLOTS..(i + 1) * MESH_SLOTS]);
        }
        self.mesh.slots = slots;
        Ok(())
    }

    /// The time the boundaries' candidate triangles were last found at.
    pub fn mesh_rebuild_time(&self) -> f64 {
        self.mesh.rebuild_time
    }

    /// Body `i`'s candidate triangles from the last rebuild, as `(boundary, triangle)`.
    pub fn mesh_candidates(&self, i: usize) -> Vec<(usize, usize)> {
        let m = &self.mesh;
        if m.start.len() <= i + 1 {
            return Vec::new();
        }
        m.candidates[m.start[i] as usize..m.start[i + 1] as usize]
            .iter()
            .map(|&g| m.locate(g))
            .collect()
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.state.len()
    }

    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.state.is_empty()
    }

    /// Combined contact parameters of materials `a` and `b`.
    pub fn pair_params(&self, a: u32, b: u32) -> &PairParams {
        self.materials.pair(a, b)
    }

    /// Whether every body is a sphere.
    pub fn spheres_only(&self) -> bool {
        self.spheres_only
    }

    /// Whether some body is a composite (contacts are then kept per piece pair).
    pub fn has_composites(&self) -> bool {
        self.has_composites
    }

    /// Orientations at the last broad-phase rebuild (empty unless the world has composites).
    pub fn rebuild_orientation(&self) -> &[Quat] {
        &self.rebuild_orientation
    }

    /// Piece `k` of body `i` (the body itself, `k = 0`, unless a composite): its shape and
    /// world pose, with body `i` placed at `origin` (its position, or a periodic image).
    #[inline]
    pub fn piece_at(&self, i: usize, k: u32, origin: Vec3) -> (&Shape, Pose) {
        let q = self.state.orientation[i];
        match self.shape(i) {
            Shape::Composite(c) => {
                let p = &c.pieces[k as usize];
                (
                    &p.shape,
                    Pose::new(origin + q * p.position, q * p.orientation),
                )
            }
            s => (s, Pose::new(origin, q)),
        }
    }

    /// Piece `k` of body `i`'s volume-equivalent radius and whether it is a sphere (the
    /// contact law's radius and point share for that piece's contacts).
    #[inline]
    pub fn piece_law(&self, i: usize, k: u32) -> (f32, bool) {
        match self.shape(i) {
            Shape::Composite(c) => {
                let p = &c.pieces[k as usize];
                (p.equivalent_radius, matches!(p.shape, Shape::Sphere { .. }))
            }
            _ => (self.consts.equivalent_radius[i], self.consts.is_sphere[i]),
        }
    }

    /// The shortest contact duration over the material pairs present, for the lightest body:
    /// body-body contacts with `m_eff = m_min / 2`, wall contacts with `m_eff = m_min`. Hertz
    /// durations use the larger of the fastest initial speed and the free-fall speed over the
    /// scene's height (at least 0.1 m/s).
    pub fn shortest_contact_duration(&self) -> f64 {
        if self.is_empty() {
            return f64::INFINITY;
        }
        let m_min = self
            .consts
            .mass
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min) as f64;
        let r_min = self
            .consts
            .equivalent_radius
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min) as f64;
        let vmax = self
            .state
            .velocity
            .iter()
            .map(|v| v.length())
            .fold(0.0, f32::max) as f64;
        let down = self.gravity.normalize_or_zero().as_dvec3();
        let (lo, hi) =
            self.state
                .position
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    let h = p.dot(down);
                    (lo.min(h), hi.max(h))
                });
        let height = (hi - lo).max(0.0) + 2.0 * r_min;
        let speed = vmax
            .max((2.0 * self.gravity.length() as f64 * height).sqrt())
            .max(0.1);
        let mut used: Vec<u32> = self.consts.material.clone();
        used.sort_unstable();
        used.dedup();
        let mut t = f64::INFINITY;
        for &a in &used {
            for &b in &used {
                t = t.min(
                    self.pair_params(a, b)
                        .contact_duration(m_min / 2.0, r_min / 2.0, speed),
                );
            }
            for m in self
                .walls
                .iter()
                .map(|w| w.material)
                .chain(self.boundaries.iter().map(|b| b.material))
            {
                t = t.min(self.pair_params(a, m).contact_duration(m_min, r_min, speed));
            }
        }
        t
    }

    /// The automatic time step: 1/50 of [`World::shortest_contact_duration`].
    pub fn auto_dt(&self) -> f32 {
        let t = self.shortest_contact_duration();
        if t.is_finite() {
            (t / 50.0) as f32
        } else {
            1e-4
        }
    }

    /// Orientation of body `i` in the frame its shape was authored in (what scene files and
    /// outputs use).
    pub fn user_orientation(&self, i: usize) -> Quat {
        let frame = self.shapes[self.consts.shape[i] as usize].frame;
        (self.state.orientation[i] * frame.conjugate()).normalize()
    }

    /// Body `i`'s pose in the world (centre of mass rounded to f32, principal frame): for
    /// drawing and queries. The contact stages use [`World::local_pose`] and
    /// [`World::pose_from`], which keep the precision of the positions.
    #[inline]
    pub fn pose(&self, i: usize) -> Pose {
        Pose::new(self.state.position_f32(i), self.state.orientation[i])
    }

    /// Body `i`'s pose in its own frame of reference: at the origin, in its orientation
    /// (what the contact stages collide; see [`World::offset_of`]).
    #[inline]
    pub fn local_pose(&self, i: usize) -> Pose {
        Pose::new(Vec3::ZERO, self.state.orientation[i])
    }

    /// Where body `j` (or its nearest periodic image) is seen from body `i`: `x_j - x_i`,
    /// subtracted in f64 and rounded to f32 after, so a contact is resolved to the float
    /// precision of the offset, not of the coordinates.
    /// The arithmetic is [`crate::precise`]'s, bit for bit the GPU's.
    #[inline(always)]
    pub fn offset_of(&self, i: usize, j: usize) -> Vec3 {
        precise::offset(
            self.periodic.as_ref(),
            self.state.position[i],
            self.state.position[j],
        )
    }

    /// [`World::offset_of`] with the positions read from `x` (the step's pairs, or the
    /// stored positions): the same bits.
    #[inline(always)]
    pub(crate) fn offset_in(&self, x: impl PositionPairs, i: usize, j: usize) -> Vec3 {
        precise::offset_a(self.periodic.as_ref(), x.pair(i), x.pair(j))
    }

    /// Splits the stored positions into [`World::position_pairs`] and makes
    /// [`World::body_bounds`] (once per step, before the contact stage), in parallel chunks:
    /// each body's pair depends on its position alone, so the result does not depend on the
    /// thread count. Serial, this pass was a few percent of a sphere step's work, which a
    /// second thread then waited for.
    pub(crate) fn split_positions(&mut self) {
        use rayon::prelude::*;
        // Only the length changes here (no pass over kept elements): every slot is
        // written below.
        let zero = precise::Ds3A {
            hi: glam::Vec3A::ZERO,
            lo: glam::Vec3A::ZERO,
        };
        self.position_pairs.resize(self.state.position.len(), zero);
        self.position_pairs
            .par_chunks_mut(precise::SPLIT_CHUNK)
            .zip(self.state.position.par_chunks(precise::SPLIT_CHUNK))
            .for_each(|(out, x)| precise::split_chunk(x, out));
        crate::step::motion::update(self);
    }

    /// A world point `x` as seen from body `i` (`x - x_i` of the precise pairs, then rounded
    /// to f32; [`precise::relative`]).
    #[inline]
    pub fn relative_to(&self, i: usize, x: Vec3) -> Vec3 {
        precise::relative(precise::split(self.state.position[i]), x)
    }

    /// Body `j`'s pose as seen from body `i`: relative to `i`'s position (see
    /// [`World::offset_of`]), in `j`'s orientation.
    #[inline]
    pub fn pose_from(&self, i: usize, j: usize) -> Pose {
        Pose::new(self.offset_of(i, j), self.state.orientation[j])
    }

    /// Body `j`'s rigid motion as seen from body `i` (its position relative to `i`'s, at
    /// its nearest image).
    #[inline]
    pub fn motion_from(&self, i: usize, j: usize) -> BodyMotion {
        self.motion_at(j, self.offset_of(i, j))
    }

    /// Body `j`'s rigid motion with its position given (its offset from the body the
    /// contact is seen from, already computed).
    #[inline(always)]
    pub(crate) fn motion_at(&self, j: usize, position: Vec3) -> BodyMotion {
        BodyMotion {
            position,
            velocity: self.state.velocity[j],
            omega: self.state.omega[j],
        }
    }

    /// A wall's plane as seen from body `i`: its offset `d - n . x_i`, with the products
    /// exact, and the rest of that offset below f32, to be added to the depths of the
    /// contacts found with the plane ([`precise::plane_offset`], [`World::add_rest`]).
    #[inline]
    pub fn plane_from(&self, i: usize, plane: &Plane) -> (Plane, f32) {
        self.plane_in(self.state.position.as_slice(), i, plane)
    }

    /// [`World::plane_from`] with the positions read from `x` (the step's pairs, or the
    /// stored positions): the same bits.
    #[inline(always)]
    pub(crate) fn plane_in(&self, x: impl PositionPairs, i: usize, plane: &Plane) -> (Plane, f32) {
        let (offset, rest) = precise::plane_offset_a(plane.normal, plane.offset, x.pair(i));
        (
            Plane {
                normal: plane.normal,
                offset,
            },
            rest,
        )
    }

    /// `m` with `rest` (from [`World::plane_from`]) added to its depths.
    #[inline]
    pub fn add_rest(mut m: Manifold, rest: f32) -> Manifold {
        for p in &mut m.points[..m.count] {
            p.depth += rest;
        }
        m
    }

    /// Body `i`'s shape.
    #[inline]
    pub fn shape(&self, i: usize) -> &Shape {
        &self.shapes[self.consts.shape[i] as usize].shape
    }

    /// The shape of body `i` and its orientation.
    #[inline]
    pub(crate) fn body_shape(&self, i: usize) -> (&Shape, Quat) {
        (self.shape(i), self.state.orientation[i])
    }

    /// Whether body `i` has been removed by a sink.
    #[inline]
    pub fn is_removed(&self, i: usize) -> bool {
        self.state.removed[i]
    }

    /// The bodies removed by sinks so far: how many, and their mass (summed exactly,
    /// [`ExactSum`]: the same on every backend, thread and rank count).
    pub fn discharged(&self) -> Discharged {
        let removed = (0..self.len()).filter(|&i| self.state.removed[i]);
        Discharged {
            count: removed.clone().count() as u64,
            mass: ExactSum::of(removed.map(|i| self.consts.mass[i] as f64)).value(),
        }
    }

    /// Body `i`'s kinetic energy, translational plus rotational, J (0 for a removed body).
    pub fn body_kinetic_energy(&self, i: usize) -> f64 {
        if self.state.removed[i] {
            return 0.0;
        }
        let v = self.state.velocity[i];
        0.5 * self.consts.mass[i] as f64 * v.length_squared() as f64
            + 0.5 * self.state.omega[i].dot(self.state.angular_momentum[i]) as f64
    }

    /// Total kinetic energy, translational plus rotational, J: the bodies' energies summed
    /// exactly ([`ExactSum`]), so ranks that each sum their own bodies find the same total.
    pub fn kinetic_energy(&self) -> f64 {
        let [k] = ExactSum::par_sums(self.len(), |i| [self.body_kinetic_energy(i)]);
        k.value()
    }

    /// Total gravitational potential energy relative to the origin, J. Removed bodies count
    /// where they were removed (a constant), so that taking a body out never looks like
    /// energy appearing to the blow-up checks. Summed exactly, as [`World::kinetic_energy`].
    pub fn potential_energy(&self) -> f64 {
        let [p] = ExactSum::par_sums(self.len(), |i| [self.body_potential_energy(i)]);
        p.value()
    }

    /// Body `i`'s gravitational potential energy relative to the origin, J (a removed body's
    /// where it was removed).
    pub fn body_potential_energy(&self, i: usize) -> f64 {
        -(self.consts.mass[i] as f64) * self.gravity.as_dvec3().dot(self.state.position[i])
    }

    /// Total linear momentum of the bodies still in the simulation, kg m/s (each
    /// component's terms summed exactly, as [`World::kinetic_energy`]).
    pub fn momentum(&self) -> [f64; 3] {
        let p = ExactSum::par_sums(self.len(), |i| {
            if self.state.removed[i] {
                return [0.0; 3];
            }
            let m = self.state.velocity[i] * self.consts.mass[i];
            [m.x as f64, m.y as f64, m.z as f64]
        });
        p.map(|s| s.value())
    }

    /// [`World::kinetic_energy`], [`World::potential_energy`] and [`World::momentum`] from
    /// one parallel pass over the bodies (the same exact sums of the same terms, so the
    /// same bits): an energy sample's three quantities with one fork-join, not three.
    pub fn energies_and_momentum(&self) -> (f64, f64, [f64; 3]) {
        let [k, p, px, py, pz] = ExactSum::par_sums(self.len(), |i| {
            let (k, p) = (self.body_kinetic_energy(i), self.body_potential_energy(i));
            if self.state.removed[i] {
                return [k, p, 0.0, 0.0, 0.0];
            }
            let m = self.state.velocity[i] * self.consts.mass[i];
            [k, p, m.x as f64, m.y as f64, m.z as f64]
        });
        (k.value(), p.value(), [px, py, pz].map(|s| s.value()))
    }

    /// The exact sums of the momentum components of `bodies` (those not removed).
    pub fn momentum_sums(&self, bodies: impl Iterator<Item = usize>) -> [ExactSum; 3] {
        let mut p: [ExactSum; 3] = Default::default();
        for i in bodies.filter(|&i| !self.state.removed[i]) {
            let m = self.state.velocity[i] * self.consts.mass[i];
            p[0].add(m.x as f64);
            p[1].add(m.y as f64);
            p[2].add(m.z as f64);
        }
        p
    }

    /// Number of contacts (body-body, body-wall and body-mesh) that touched in the last step.
    pub fn contact_count(&self) -> usize {
        // Only the active list's contacts (a near list's, while one lives) can touch.
        self.contacts
            .active()
            .springs
            .touching
            .iter()
            .filter(|&&t| t)
            .count()
            + self.mesh.slots.iter().filter(|s| s.touching).count()
    }

    /// Per body, the number of contacts (body, wall and mesh boundary) that touched in the
    /// last step: what the VTK `contacts` array and the renderers' contact colours show.
    /// They add up to [`World::contact_count`] with each body-body contact counted twice.
    pub fn contact_counts(&self) -> Vec<u32> {
        let mut counts = self.contacts.counts(self.len());
        for (i, c) in counts.iter_mut().enumerate() {
            *c += self
                .mesh
                .body_slots(i)
                .iter()
                .filter(|s| s.touching)
                .count() as u32;
        }
        counts
    }

    /// Body pairs currently in contact, sorted (for tests and output).
    pub fn touching_pairs(&self) -> Vec<[u32; 2]> {
        let c = self.contacts.active();
        let mut out: Vec<[u32; 2]> = c
            .pairs
            .iter()
            .zip(&c.springs.touching)
            .filter(|(_, t)| **t)
            .map(|(p, _)| *p)
            .collect();
        // Composites: one entry per body pair, however many of their pieces touch.
        out.dedup();
        out
    }

    /// The current broad-phase candidate pairs (bounding spheres within the skin).
    pub fn candidate_pairs(&self) -> &[[u32; 2]] {
        &self.contacts.pairs
    }

    /// Positions at the last broad-phase rebuild (empty before the first).
    pub fn rebuild_position(&self) -> &[DVec3] {
        &self.rebuild_position
    }

    /// Whether the next step rebuilds the broad phase.
    pub fn needs_rebuild(&self) -> bool {
        self.needs_rebuild
    }

    /// Asks for a broad-phase rebuild at the next step (`true`), or cancels one (`false`:
    /// a restored checkpoint whose list is current).
    pub fn set_needs_rebuild(&mut self, rebuild: bool) {
        self.needs_rebuild = rebuild;
    }

    /// The most pieces of any body's shape (1 without composites): the number of wall slots
    /// per body and wall in [`ContactState`].
    pub fn max_pieces(&self) -> usize {
        if !self.has_composites {
            return 1;
        }
        self.consts
            .shape
            .iter()
            .map(|&s| self.shapes[s as usize].shape.piece_count())
            .max()
            .unwrap_or(1)
            .max(1)
    }

    /// The contact list in a backend-neutral form: what another backend (the GPU) needs to
    /// continue this world's contacts. Wall contacts are given per body, wall and piece
    /// (`(body * walls.len() + wall) * max_pieces + piece`, see [`World::max_pieces`]), zero
    /// where the piece is no wall candidate.
    pub fn contact_state(&self) -> ContactState {
        let c = &self.contacts;
        let sp = c.springs();
        let np = c.pairs.len();
        let nw = self.walls.len();
        let mp = self.max_pieces();
        let slots = self.len() * nw * mp;
        let composite = self.has_composites && c.pieces.len() == c.len();
        let mut s = ContactState {
            rebuild_position: if self.needs_rebuild {
                Vec::new()
            } else {
                self.rebuild_position.clone()
            },
            pairs: c.pairs.clone(),
            pieces: if composite {
                c.pieces[..np].to_vec()
            } else {
                Vec::new()
            },
            rebuild_orientation: if composite && !self.needs_rebuild {
                self.rebuild_orientation.clone()
            } else {
                Vec::new()
            },
            history: sp.history[..np].to_vec(),
            twist: sp.twist[..np].to_vec(),
            touching: sp.touching[..np].to_vec(),
            forces: sp.forces[..np].to_vec(),
            wall_history: vec![Vec3::ZERO; slots],
            wall_twist: vec![0.0; slots],
            wall_touching: vec![false; slots],
            wall_forces: vec![ContactForce::default(); slots],
        };
        for (k, &[i, w]) in c.wall_pairs.iter().enumerate() {
            let piece = if composite { c.pieces[np + k] } else { 0 };
            let slot = (i as usize * nw + w as usize) * mp + piece as usize;
            s.wall_history[slot] = sp.history[np + k];
            s.wall_twist[slot] = sp.twist[np + k];
            s.wall_touching[slot] = sp.touching[np + k];
            s.wall_forces[slot] = sp.forces[np + k];
        }
        s
    }

    /// Sets the list and springs from the step of a rebuild (the broad phase's own use).
    pub(crate) fn install_contacts(&mut self, contacts: Contacts) {
        self.contacts = contacts;
        self.rebuild_position.clone_from(&self.state.position);
        if self.has_composites {
            self.rebuild_orientation.clone_from(&self.state.orientation);
        }
        self.needs_rebuild = false;
        self.rebuilds += 1;
    }

    /// Body `i`'s rigid motion in its own frame of reference (at the origin; see
    /// [`World::local_pose`]), as the contact law sees it.
    #[inline]
    pub fn local_motion(&self, i: usize) -> BodyMotion {
        BodyMotion {
            position: Vec3::ZERO,
            velocity: self.state.velocity[i],
            omega: self.state.omega[i],
        }
    }
}
