//! The world: body state (structure of arrays), walls, materials, the contact list with its
//! tangential history, and the step pipeline that ties the stages together:
//! **bin -> sort -> pairs** (only when the Verlet skin is used up) -> **narrow -> forces ->
//! integrate** (every step).

use glam::{Quat, Vec3};
use rayon::prelude::*;
use thiserror::Error;

use crate::broad::{self, Grid};
use crate::forces::{ContactForce, Side, contact_force, point_contact_force};
use crate::material::{Material, PairParams};
use clatter_geom::narrow::{self, Plane};
use clatter_geom::{Pose, PreparedShape, Shape};

/// A body as placed by a scene: which shape and material, and its initial state.
/// `orientation` is in the frame the shape was authored in; `position` is the centre of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyInit {
    pub shape: u32,
    pub material: u32,
    pub position: Vec3,
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

/// A world's contact list in a backend-neutral form (see [`World::contact_state`]): how the
/// GPU backend takes over and hands back the contacts' springs, so runs can move between
/// backends and checkpoints stay complete.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactState {
    /// Positions at the last broad-phase rebuild (empty: no list, rebuild at the next step).
    pub rebuild_position: Vec<Vec3>,
    /// Candidate body pairs `(i, j)`, `i < j`, sorted.
    pub pairs: Vec<[u32; 2]>,
    /// Tangential spring per pair.
    pub history: Vec<Vec3>,
    /// Twisting spring per pair (rad).
    pub twist: Vec<f32>,
    /// Whether each pair touched in the last step.
    pub touching: Vec<bool>,
    /// The last step's force per pair.
    pub forces: Vec<ContactForce>,
    /// Tangential spring per body and wall (`body * walls + wall`).
    pub wall_history: Vec<Vec3>,
    /// Twisting spring per body and wall.
    pub wall_twist: Vec<f32>,
    /// Whether each body touched each wall in the last step.
    pub wall_touching: Vec<bool>,
    /// The last step's force per body and wall.
    pub wall_forces: Vec<ContactForce>,
}

/// Per-pair contact state: the pair, its tangential spring, and what this step computed.
#[derive(Debug, Clone, Default)]
pub(crate) struct ContactList {
    /// Body pairs `(i, j)`, `i < j`, sorted.
    pub(crate) pairs: Vec<[u32; 2]>,
    /// Body-wall pairs `(body, wall)`, sorted.
    pub(crate) wall_pairs: Vec<[u32; 2]>,
    /// Tangential springs: body pairs first, then wall pairs.
    pub(crate) history: Vec<Vec3>,
    /// Twisting springs (rad), same order as `history`.
    pub(crate) twist: Vec<f32>,
    /// This step's forces, same order as `history`.
    pub(crate) forces: Vec<ContactForce>,
    /// Whether each contact touches this step.
    pub(crate) touching: Vec<bool>,
    /// Separating-axis hints of the body pairs (temporal coherence of the narrow phase).
    pub(crate) hints: Vec<narrow::SatHint>,
    /// Per body pair: how far apart the pair was last found, less the most the two bodies
    /// can have moved since (see [`World::motion_bound`]); the pair is skipped while positive.
    pub(crate) budget: Vec<f32>,
    /// Body `i` is side a of body pairs `a_start[i]..a_start[i+1]` (pairs are sorted by `i`).
    a_start: Vec<u32>,
    /// Body `i` is side b of body pairs `b_adj[b_start[i]..b_start[i+1]]`.
    b_start: Vec<u32>,
    b_adj: Vec<u32>,
    /// Body `i`'s wall contacts are `w_start[i]..w_start[i+1]` (indices into `forces`).
    w_start: Vec<u32>,
}

/// A simulation: body state, static data and the contact list.
#[derive(Debug, Clone)]
pub struct World {
    /// The shapes bodies refer to.
    pub shapes: Vec<PreparedShape>,
    /// The materials bodies and walls refer to.
    pub materials: Vec<Material>,
    /// Wall planes.
    pub walls: Vec<Wall>,
    /// Gravity, m/s^2.
    pub gravity: Vec3,
    /// Time step, s.
    pub dt: f32,
    /// Simulated time, s.
    pub time: f64,
    /// Steps taken.
    pub step_count: u64,
    /// Centre of mass of each body.
    pub position: Vec<Vec3>,
    /// Linear velocity.
    pub velocity: Vec<Vec3>,
    /// Orientation of the principal frame (see [`World::user_orientation`]).
    pub orientation: Vec<Quat>,
    /// Rounding carried over from the orientation updates (compensated summation), so that
    /// slow rotations, whose per-step increment is below the precision of `orientation`,
    /// still turn the body.
    pub(crate) orientation_residual: Vec<Quat>,
    /// Angular momentum about the centre of mass (world frame), the integrated quantity.
    pub angular_momentum: Vec<Vec3>,
    /// Angular velocity (world frame), derived from the angular momentum.
    pub omega: Vec<Vec3>,
    /// Shape index per body.
    pub shape_of: Vec<u32>,
    /// Material index per body.
    pub material_of: Vec<u32>,
    /// Mass per body, kg.
    pub mass: Vec<f32>,
    /// Principal moments of inertia per body, kg m^2.
    pub inertia: Vec<Vec3>,
    /// `1 / mass`, per body.
    pub inv_mass: Vec<f32>,
    /// `1 / inertia`, per body and principal axis.
    pub inv_inertia: Vec<Vec3>,
    /// Bounding radius per body.
    pub radius: Vec<f32>,
    /// Volume-equivalent sphere radius per body (the Hertz law's radius).
    pub equivalent_radius: Vec<f32>,
    /// Verlet skin.
    pub skin: f32,
    /// Broad-phase rebuilds so far.
    pub rebuilds: u64,
    pair_table: Vec<PairParams>,
    /// Every body is a sphere: the pair loop takes the sphere-sphere fast path.
    spheres_only: bool,
    pub(crate) contacts: ContactList,
    pub(crate) rebuild_position: Vec<Vec3>,
    pub(crate) needs_rebuild: bool,
}

impl World {
    /// Builds the world; the caller (the scene loader) has validated indices and values.
    pub fn new(desc: WorldDesc) -> World {
        let n = desc.bodies.len();
        let nm = desc.materials.len();
        let mut pair_table = Vec::with_capacity(nm * nm);
        for a in &desc.materials {
            for b in &desc.materials {
                pair_table.push(PairParams::combine(a, b));
            }
        }
        let mut w = World {
            shapes: desc.shapes,
            materials: desc.materials,
            walls: desc.walls,
            gravity: desc.gravity,
            dt: 0.0,
            time: 0.0,
            step_count: 0,
            position: Vec::with_capacity(n),
            velocity: Vec::with_capacity(n),
            orientation: Vec::with_capacity(n),
            orientation_residual: vec![Quat::from_xyzw(0.0, 0.0, 0.0, 0.0); n],
            angular_momentum: Vec::with_capacity(n),
            omega: Vec::with_capacity(n),
            shape_of: Vec::with_capacity(n),
            material_of: Vec::with_capacity(n),
            mass: Vec::with_capacity(n),
            inertia: Vec::with_capacity(n),
            inv_mass: Vec::with_capacity(n),
            inv_inertia: Vec::with_capacity(n),
            radius: Vec::with_capacity(n),
            equivalent_radius: Vec::with_capacity(n),
            skin: 0.0,
            rebuilds: 0,
            pair_table,
            spheres_only: false,
            contacts: ContactList::default(),
            rebuild_position: Vec::new(),
            needs_rebuild: true,
        };
        for b in &desc.bodies {
            let shape = &w.shapes[b.shape as usize];
            let density = w.materials[b.material as usize].density;
            let mass = density * shape.volume;
            let inertia = shape.unit_inertia * density;
            let q = (b.orientation * shape.frame).normalize();
            w.position.push(b.position);
            w.velocity.push(b.velocity);
            w.orientation.push(q);
            let body_w = q.conjugate() * b.angular_velocity;
            w.angular_momentum.push(q * (inertia * body_w));
            w.omega.push(b.angular_velocity);
            w.shape_of.push(b.shape);
            w.material_of.push(b.material);
            w.mass.push(mass);
            w.inertia.push(inertia);
            w.inv_mass.push(1.0 / mass);
            w.inv_inertia.push(inertia.recip());
            w.radius.push(shape.shape.bounding_radius());
            w.equivalent_radius
                .push((3.0 * shape.volume / (4.0 * std::f32::consts::PI)).cbrt());
        }
        w.spheres_only = w
            .shape_of
            .iter()
            .all(|&s| matches!(w.shapes[s as usize].shape, Shape::Sphere { .. }));
        let rmax = w.radius.iter().copied().fold(0.0, f32::max);
        w.skin = desc.skin.unwrap_or(0.2 * rmax);
        w.dt = desc.dt.unwrap_or_else(|| w.auto_dt());
        w
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Combined contact parameters of materials `a` and `b`.
    pub fn pair_params(&self, a: u32, b: u32) -> &PairParams {
        &self.pair_table[a as usize * self.materials.len() + b as usize]
    }

    /// The shortest contact duration over the material pairs present, for the lightest body:
    /// body-body contacts with `m_eff = m_min / 2`, wall contacts with `m_eff = m_min`. Hertz
    /// durations use the larger of the fastest initial speed and the free-fall speed over the
    /// scene's height (at least 0.1 m/s).
    pub fn shortest_contact_duration(&self) -> f64 {
        if self.is_empty() {
            return f64::INFINITY;
        }
        let m_min = self.mass.iter().copied().fold(f32::INFINITY, f32::min) as f64;
        let r_min = self
            .equivalent_radius
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min) as f64;
        let vmax = self.velocity.iter().map(|v| v.length()).fold(0.0, f32::max) as f64;
        let (lo, hi) =
            self.position
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                    let h = p.dot(self.gravity.normalize_or_zero());
                    (lo.min(h), hi.max(h))
                });
        let height = ((hi - lo) as f64).max(0.0) + 2.0 * r_min;
        let speed = vmax
            .max((2.0 * self.gravity.length() as f64 * height).sqrt())
            .max(0.1);
        let mut used: Vec<u32> = self.material_of.clone();
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
            for wall in &self.walls {
                t = t.min(
                    self.pair_params(a, wall.material)
                        .contact_duration(m_min, r_min, speed),
                );
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
        (self.orientation[i] * self.shapes[self.shape_of[i] as usize].frame.conjugate()).normalize()
    }

    /// The rounding carried by body `i`'s compensated orientation update (part of the
    /// state another backend must take over for identical continuation).
    pub fn orientation_residual(&self, i: usize) -> Quat {
        self.orientation_residual[i]
    }

    /// Sets body `i`'s orientation rounding residual (see [`World::orientation_residual`]).
    pub fn set_orientation_residual(&mut self, i: usize, q: Quat) {
        self.orientation_residual[i] = q;
    }

    /// Total kinetic energy, translational plus rotational, J.
    pub fn kinetic_energy(&self) -> f64 {
        (0..self.len())
            .map(|i| {
                let v = self.velocity[i];
                0.5 * self.mass[i] as f64 * v.length_squared() as f64
                    + 0.5 * self.omega[i].dot(self.angular_momentum[i]) as f64
            })
            .sum()
    }

    /// Total gravitational potential energy relative to the origin, J.
    pub fn potential_energy(&self) -> f64 {
        (0..self.len())
            .map(|i| -(self.mass[i] as f64) * self.gravity.dot(self.position[i]) as f64)
            .sum()
    }

    /// Total linear momentum, kg m/s (summed in f64).
    pub fn momentum(&self) -> [f64; 3] {
        let mut p = [0.0f64; 3];
        for i in 0..self.len() {
            let m = self.velocity[i] * self.mass[i];
            p[0] += m.x as f64;
            p[1] += m.y as f64;
            p[2] += m.z as f64;
        }
        p
    }

    /// Number of contacts (body-body and body-wall) that touched in the last step.
    pub fn contact_count(&self) -> usize {
        self.contacts.touching.iter().filter(|&&t| t).count()
    }

    /// Body pairs currently in contact, sorted (for tests and output).
    pub fn touching_pairs(&self) -> Vec<[u32; 2]> {
        self.contacts
            .pairs
            .iter()
            .zip(&self.contacts.touching)
            .filter(|(_, t)| **t)
            .map(|(p, _)| *p)
            .collect()
    }

    /// The current broad-phase candidate pairs (bounding spheres within the skin).
    pub fn candidate_pairs(&self) -> &[[u32; 2]] {
        &self.contacts.pairs
    }

    /// Forces the broad phase to run at the next step (after positions were edited by hand).
    pub fn invalidate_pairs(&mut self) {
        self.needs_rebuild = true;
    }

    /// Stages 1-3 (bin, sort, pairs) plus body-wall candidates; carries the tangential
    /// history of pairs that persist.
    pub(crate) fn rebuild(&mut self) {
        let rmax = self.radius.iter().copied().fold(0.0, f32::max);
        let grid = Grid::around(&self.position, 2.0 * rmax + self.skin);
        let pairs = broad::pairs(&grid, &self.position, &self.radius, self.skin);
        let wall_pairs = self.wall_candidates(&self.position);
        let old = std::mem::take(&mut self.contacts);
        let np_old = old.pairs.len();
        let carry = |list: &[[u32; 2]], walls: bool, new: &[[u32; 2]]| {
            let range = if walls {
                np_old..old.history.len()
            } else {
                0..np_old.min(old.history.len())
            };
            carry_history(
                list,
                &old.history[range.clone()],
                &old.twist[range.start.min(old.twist.len())..range.end.min(old.twist.len())],
                new,
            )
        };
        let (mut history, mut twist) = carry(&old.pairs, false, &pairs);
        let (wall_history, wall_twist) = carry(&old.wall_pairs, true, &wall_pairs);
        history.extend(wall_history);
        twist.extend(wall_twist);
        self.install_contacts(pairs, wall_pairs, history, twist);
        self.rebuild_position.clone_from(&self.position);
        self.needs_rebuild = false;
        self.rebuilds += 1;
    }

    /// Wall candidates of the broad phase: `(body, wall)` for bodies whose bounding sphere at
    /// `positions` comes within the skin of a wall, sorted.
    fn wall_candidates(&self, positions: &[Vec3]) -> Vec<[u32; 2]> {
        let mut wall_pairs = Vec::new();
        for (i, p) in positions.iter().enumerate() {
            for (w, wall) in self.walls.iter().enumerate() {
                let h = wall.plane.normal.dot(*p) - wall.plane.offset;
                if h < self.radius[i] + self.skin {
                    wall_pairs.push([i as u32, w as u32]);
                }
            }
        }
        wall_pairs
    }

    /// Installs a new contact list (springs given, forces zero, nothing touching) and the
    /// per-body gather ranges over it.
    fn install_contacts(
        &mut self,
        pairs: Vec<[u32; 2]>,
        wall_pairs: Vec<[u32; 2]>,
        history: Vec<Vec3>,
        twist: Vec<f32>,
    ) {
        // Gather ranges, in contact order (a fixed, thread-independent summation order).
        let n = self.len();
        let np = pairs.len();
        let mut a_start = vec![0u32; n + 1];
        let mut b_start = vec![0u32; n + 1];
        let mut w_start = vec![np as u32; n + 1];
        for p in &pairs {
            a_start[p[0] as usize + 1] += 1;
            b_start[p[1] as usize + 1] += 1;
        }
        for p in &wall_pairs {
            w_start[p[0] as usize + 1] += 1;
        }
        for i in 0..n {
            a_start[i + 1] += a_start[i];
            b_start[i + 1] += b_start[i];
            w_start[i + 1] += w_start[i] - np as u32;
        }
        let mut fill = b_start.clone();
        let mut b_adj = vec![0u32; np];
        for (c, p) in pairs.iter().enumerate() {
            b_adj[fill[p[1] as usize] as usize] = c as u32;
            fill[p[1] as usize] += 1;
        }
        let total = pairs.len() + wall_pairs.len();
        let hints = vec![narrow::NO_HINT; pairs.len()];
        self.contacts = ContactList {
            hints,
            budget: vec![0.0; pairs.len()],
            pairs,
            wall_pairs,
            history,
            twist,
            forces: vec![ContactForce::default(); total],
            touching: vec![false; total],
            a_start,
            b_start,
            b_adj,
            w_start,
        };
    }

    /// The contact list in a backend-neutral form: what another backend (the GPU) needs to
    /// continue this world's contacts. Wall contacts are given per body and wall
    /// (`body * walls.len() + wall`), zero where the body is no wall candidate.
    pub fn contact_state(&self) -> ContactState {
        let c = &self.contacts;
        let np = c.pairs.len();
        let nw = self.walls.len();
        let mut s = ContactState {
            rebuild_position: if self.needs_rebuild {
                Vec::new()
            } else {
                self.rebuild_position.clone()
            },
            pairs: c.pairs.clone(),
            history: c.history[..np].to_vec(),
            twist: c.twist[..np].to_vec(),
            touching: c.touching[..np].to_vec(),
            forces: c.forces[..np].to_vec(),
            wall_history: vec![Vec3::ZERO; self.len() * nw],
            wall_twist: vec![0.0; self.len() * nw],
            wall_touching: vec![false; self.len() * nw],
            wall_forces: vec![ContactForce::default(); self.len() * nw],
        };
        for (k, &[i, w]) in c.wall_pairs.iter().enumerate() {
            let slot = i as usize * nw + w as usize;
            s.wall_history[slot] = c.history[np + k];
            s.wall_twist[slot] = c.twist[np + k];
            s.wall_touching[slot] = c.touching[np + k];
            s.wall_forces[slot] = c.forces[np + k];
        }
        s
    }

    /// Replaces the contact list with `state` (from another backend): body pairs as given
    /// (sorted by `(i, j)`), wall candidates recomputed from `state.rebuild_position` with
    /// their springs taken from the per-(body, wall) slots. An empty `rebuild_position` means
    /// "no list yet": the next step rebuilds.
    pub fn set_contact_state(&mut self, state: ContactState) {
        if state.rebuild_position.len() != self.len() {
            self.contacts = ContactList::default();
            self.needs_rebuild = true;
            return;
        }
        let nw = self.walls.len();
        let wall_pairs = self.wall_candidates(&state.rebuild_position);
        let mut history = state.history;
        let mut twist = state.twist;
        for &[i, w] in &wall_pairs {
            let slot = i as usize * nw + w as usize;
            history.push(state.wall_history.get(slot).copied().unwrap_or(Vec3::ZERO));
            twist.push(state.wall_twist.get(slot).copied().unwrap_or(0.0));
        }
        let np = state.pairs.len();
        let mut touching = state.touching;
        let mut forces = state.forces;
        touching.resize(np, false);
        forces.resize(np, ContactForce::default());
        for &[i, w] in &wall_pairs {
            let slot = i as usize * nw + w as usize;
            touching.push(state.wall_touching.get(slot).copied().unwrap_or(false));
            forces.push(state.wall_forces.get(slot).copied().unwrap_or_default());
        }
        self.install_contacts(state.pairs, wall_pairs, history, twist);
        self.contacts.touching = touching;
        self.contacts.forces = forces;
        self.rebuild_position = state.rebuild_position;
        self.needs_rebuild = false;
    }

    #[inline]
    fn pose(&self, i: usize) -> Pose {
        Pose::new(self.position[i], self.orientation[i])
    }

    /// Fraction of the material's contact law each manifold point carries: 1 for contacts
    /// with a sphere (always one point), 1/4 for polyhedron-polyhedron and polyhedron-wall
    /// contacts (up to four points; `i == j` for a wall). See [`crate::forces`].
    #[inline]
    fn point_share(&self, i: usize, j: usize) -> f32 {
        let sphere = |k: usize| {
            matches!(
                self.shapes[self.shape_of[k] as usize].shape,
                Shape::Sphere { .. }
            )
        };
        if sphere(i) || sphere(j) { 1.0 } else { 0.25 }
    }

    /// An upper bound of how far any point of body `i` moved in the last step, from its
    /// current velocities (semi-implicit Euler moves it with them): `(|v|_1 + |w|_1 r) dt`
    /// (1-norms bound the 2-norms without a square root), plus margins for rounding (the
    /// compensated orientation update can turn a body by about an ulp more per step).
    #[inline]
    fn motion_bound(&self, i: usize) -> f32 {
        let (v, w) = (self.velocity[i].abs(), self.omega[i].abs());
        ((v.x + v.y + v.z) + (w.x + w.y + w.z) * self.radius[i]) * self.dt * 1.000_001
            + 1e-6 * self.radius[i]
    }

    #[inline]
    fn side(&self, i: usize) -> Side {
        Side {
            position: self.position[i],
            velocity: self.velocity[i],
            omega: self.omega[i],
        }
    }

    /// Stage 4 for one body pair: the contact manifold, if any.
    #[inline]
    fn narrow_pair(
        &self,
        i: usize,
        j: usize,
        hint: &mut narrow::SatHint,
        separation: &mut f32,
    ) -> Option<narrow::Manifold> {
        let si = &self.shapes[self.shape_of[i] as usize].shape;
        let sj = &self.shapes[self.shape_of[j] as usize].shape;
        match (si, sj) {
            (Shape::Sphere { radius: ri }, Shape::Sphere { radius: rj }) => {
                narrow::sphere_sphere(self.position[i], *ri, self.position[j], *rj)
            }
            _ => narrow::collide_with_hint(si, &self.pose(i), sj, &self.pose(j), hint, separation),
        }
    }

    /// Advances the simulation by one time step.
    pub fn step(&mut self) -> Result<StepStats, SimError> {
        /// Items per parallel task in the per-contact and per-body stages.
        const CHUNK: usize = 1024;
        let mut stats = StepStats::default();
        if self.needs_rebuild {
            self.rebuild();
            stats.rebuilt = true;
        }
        let dt = self.dt;
        let np = self.contacts.pairs.len();

        // Stages 4 and 5, narrow and forces, per contact in parallel.
        {
            let mut contacts = std::mem::take(&mut self.contacts);
            let this = &*self;
            let (hist_pairs, hist_walls) = contacts.history.split_at_mut(np);
            let (twist_pairs, twist_walls) = contacts.twist.split_at_mut(np);
            let (force_pairs, force_walls) = contacts.forces.split_at_mut(np);
            let (touch_pairs, touch_walls) = contacts.touching.split_at_mut(np);
            // Sphere-sphere without building a manifold (the common DEM case), over fewer
            // arrays: spheres need no hints, twisting springs or separation budgets.
            let sphere_task = |&[i, j]: &[u32; 2],
                               hist: &mut Vec3,
                               force: &mut ContactForce,
                               touching: &mut bool| {
                let (i, j) = (i as usize, j as usize);
                let (xi, xj) = (this.position[i], this.position[j]);
                let (ri, rj) = (this.radius[i], this.radius[j]);
                let d = xj - xi;
                let dist2 = d.length_squared();
                if dist2 < (ri + rj) * (ri + rj) {
                    let dist = dist2.sqrt();
                    let n = if dist > 0.0 { d / dist } else { Vec3::Z };
                    let depth = ri + rj - dist;
                    let params = this.pair_params(this.material_of[i], this.material_of[j]);
                    let (mi, mj) = (this.mass[i], this.mass[j]);
                    *force = point_contact_force(
                        params,
                        mi * mj / (mi + mj),
                        ri * rj / (ri + rj),
                        1.0,
                        n,
                        xi + n * (ri - 0.5 * depth),
                        depth,
                        &this.side(i),
                        &this.side(j),
                        hist,
                        dt,
                    );
                    *touching = true;
                } else if *touching {
                    *force = ContactForce::default();
                    *hist = Vec3::ZERO;
                    *touching = false;
                }
            };
            let pair_task = |&[i, j]: &[u32; 2],
                             hist: &mut Vec3,
                             force: &mut ContactForce,
                             touching: &mut bool,
                             hint: &mut narrow::SatHint,
                             twist: &mut f32,
                             budget: &mut f32| {
                let (i, j) = (i as usize, j as usize);
                if *budget > 0.0 {
                    // Apart by more than both bodies can have moved: skip the test.
                    *budget -= this.motion_bound(i) + this.motion_bound(j);
                    if *budget > 0.0 {
                        return;
                    }
                }
                let mut separation = 0.0;
                let found = this.narrow_pair(i, j, hint, &mut separation);
                *budget = separation;
                match found {
                    Some(m) => {
                        let params = this.pair_params(this.material_of[i], this.material_of[j]);
                        let (mi, mj) = (this.mass[i], this.mass[j]);
                        let (ri, rj) = (this.equivalent_radius[i], this.equivalent_radius[j]);
                        *force = contact_force(
                            params,
                            mi * mj / (mi + mj),
                            ri * rj / (ri + rj),
                            this.point_share(i, j),
                            &m,
                            &this.side(i),
                            &this.side(j),
                            hist,
                            twist,
                            dt,
                        );
                        *touching = true;
                    }
                    None => {
                        // Released: zero spring and force (written only on the change).
                        if *touching {
                            *force = ContactForce::default();
                            *hist = Vec3::ZERO;
                            *twist = 0.0;
                            *touching = false;
                        }
                    }
                }
            };
            // Body pairs and wall pairs in one fork-join (one synchronisation, not two).
            let (pair_touching, wall_touching) = rayon::join(
                || {
                    if this.spheres_only {
                        return contacts
                            .pairs
                            .par_iter()
                            .zip(hist_pairs.par_iter_mut())
                            .zip(force_pairs.par_iter_mut())
                            .zip(touch_pairs.par_iter_mut())
                            .with_min_len(CHUNK)
                            .map(|(((p, h), f), t)| {
                                sphere_task(p, h, f, t);
                                *t as usize
                            })
                            .sum::<usize>();
                    }
                    contacts
                        .pairs
                        .par_iter()
                        .zip(hist_pairs.par_iter_mut())
                        .zip(force_pairs.par_iter_mut())
                        .zip(touch_pairs.par_iter_mut())
                        .zip(contacts.hints.par_iter_mut())
                        .zip(twist_pairs.par_iter_mut())
                        .zip(contacts.budget.par_iter_mut())
                        .with_min_len(CHUNK)
                        .map(|((((((p, h), f), t), hn), tw), b)| {
                            pair_task(p, h, f, t, hn, tw, b);
                            *t as usize
                        })
                        .sum::<usize>()
                },
                || {
                    contacts
                        .wall_pairs
                        .par_iter()
                        .zip(hist_walls.par_iter_mut())
                        .zip(force_walls.par_iter_mut())
                        .zip(touch_walls.par_iter_mut())
                        .zip(twist_walls.par_iter_mut())
                        .with_min_len(CHUNK)
                        .map(|((((&[i, w], hist), force), touching), twist)| {
                            let (i, w) = (i as usize, w as usize);
                            let wall = &this.walls[w];
                            let shape = &this.shapes[this.shape_of[i] as usize].shape;
                            match narrow::collide_plane(&wall.plane, shape, &this.pose(i)) {
                                Some(m) => {
                                    let params =
                                        this.pair_params(wall.material, this.material_of[i]);
                                    *force = contact_force(
                                        params,
                                        this.mass[i],
                                        this.equivalent_radius[i],
                                        this.point_share(i, i),
                                        &m,
                                        &Side::default(),
                                        &this.side(i),
                                        hist,
                                        twist,
                                        dt,
                                    );
                                    *touching = true;
                                }
                                None => {
                                    // Released: zero spring and force (written only on the change).
                                    if *touching {
                                        *force = ContactForce::default();
                                        *hist = Vec3::ZERO;
                                        *twist = 0.0;
                                        *touching = false;
                                    }
                                }
                            }
                            *touching as usize
                        })
                        .sum::<usize>()
                },
            );
            let touching_count = pair_touching + wall_touching;
            self.contacts = contacts;
            stats.contacts = touching_count;
        }

        // Stage 6, integrate: gather forces in a fixed order, semi-implicit Euler.
        let gravity = self.gravity;
        let contacts = &self.contacts;
        let half_skin2 = 0.25 * self.skin * self.skin;
        let (inv_mass, inv_inertia) = (&self.inv_mass, &self.inv_inertia);
        let rebuild_position = &self.rebuild_position;
        // Plain loops over chunks of bodies: each chunk is one task, and the loop body sees
        // slices, not a chain of zipped iterators.
        let worst = self
            .position
            .par_chunks_mut(CHUNK)
            .zip(self.velocity.par_chunks_mut(CHUNK))
            .zip(self.orientation.par_chunks_mut(CHUNK))
            .zip(self.angular_momentum.par_chunks_mut(CHUNK))
            .zip(self.omega.par_chunks_mut(CHUNK))
            .zip(self.orientation_residual.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(chunk, (((((xs, vs), qs), ls), ws), rs))| {
                let mut worst = 0.0f32;
                for k in 0..xs.len() {
                    let i = chunk * CHUNK + k;
                    let (x, v, q, l, w, residual) = (
                        &mut xs[k], &mut vs[k], &mut qs[k], &mut ls[k], &mut ws[k], &mut rs[k],
                    );
                    // Forces of non-touching contacts are zero, so no branch is needed here.
                    let mut f = Vec3::ZERO;
                    let mut t = Vec3::ZERO;
                    let forces = &contacts.forces;
                    for c in &forces[contacts.a_start[i] as usize..contacts.a_start[i + 1] as usize]
                    {
                        f -= c.force_b;
                        t += c.torque_a;
                    }
                    for &k in &contacts.b_adj
                        [contacts.b_start[i] as usize..contacts.b_start[i + 1] as usize]
                    {
                        let c = &forces[k as usize];
                        f += c.force_b;
                        t += c.torque_b;
                    }
                    for c in &forces[contacts.w_start[i] as usize..contacts.w_start[i + 1] as usize]
                    {
                        f += c.force_b;
                        t += c.torque_b;
                    }
                    *v += (f * inv_mass[i] + gravity) * dt;
                    *x += *v * dt;
                    *l += t * dt;
                    let inv_inertia_i = inv_inertia[i];
                    *w = if inv_inertia_i.x == inv_inertia_i.y && inv_inertia_i.y == inv_inertia_i.z
                    {
                        // Spheres, cubes, Platonic solids: isotropic inertia, no frame change needed.
                        *l * inv_inertia_i.x
                    } else {
                        *q * ((q.conjugate() * *l) * inv_inertia_i)
                    };
                    // First-order quaternion update, renormalised: dq/dt = (w, 0) q / 2. The
                    // rotation per DEM step is tiny, so this matches the exponential map to
                    // O((|w| dt)^2) without the trigonometry.
                    let h = 0.5 * dt;
                    let dq = Quat::from_xyzw(w.x * h, w.y * h, w.z * h, 0.0) * *q;
                    // Compensated (Kahan) sum: the part of dq lost to rounding is kept in
                    // `residual` and added back next step.
                    let y = dq - *residual;
                    let q2 = *q + y;
                    *residual = (q2 - *q) - y;
                    // Renormalise only when |q| has drifted by more than a few ulps, with one
                    // Newton step of 1/sqrt around 1: no square root or division.
                    let n2 = q2.length_squared();
                    *q = if (n2 - 1.0).abs() > 4.0 * f32::EPSILON {
                        q2 * (1.5 - 0.5 * n2)
                    } else {
                        q2
                    };
                    let d2 = (*x - rebuild_position[i]).length_squared();
                    // NaN or infinity anywhere in the state shows up in d2 or in q.
                    let d2 = if d2.is_finite() && q.w.is_finite() {
                        d2
                    } else {
                        f32::INFINITY
                    };
                    worst = if d2 > worst { d2 } else { worst };
                }
                worst
            })
            .reduce(|| 0.0, f32::max);
        self.step_count += 1;
        self.time += dt as f64;
        if worst == f32::INFINITY {
            // Report the first body that went bad.
            let body = (0..self.len())
                .find(|&i| {
                    !(self.position[i].is_finite()
                        && self.velocity[i].is_finite()
                        && self.orientation[i].is_finite())
                })
                .unwrap_or(0);
            return Err(SimError::NonFinite {
                body,
                step: self.step_count,
                time: self.time,
                dt,
            });
        }
        if worst > half_skin2 {
            self.needs_rebuild = true;
        }
        Ok(stats)
    }
}

/// Tangential and twisting springs for `new` pairs: the old values where the pair persists,
/// zero otherwise. Both pair lists are sorted.
fn carry_history(
    old: &[[u32; 2]],
    old_hist: &[Vec3],
    old_twist: &[f32],
    new: &[[u32; 2]],
) -> (Vec<Vec3>, Vec<f32>) {
    let mut hist = Vec::with_capacity(new.len());
    let mut twist = Vec::with_capacity(new.len());
    let mut k = 0;
    for p in new {
        while k < old.len() && old[k] < *p {
            k += 1;
        }
        if k < old.len() && old[k] == *p {
            hist.push(old_hist.get(k).copied().unwrap_or(Vec3::ZERO));
            twist.push(old_twist.get(k).copied().unwrap_or(0.0));
        } else {
            hist.push(Vec3::ZERO);
            twist.push(0.0);
        }
    }
    (hist, twist)
}
