//! Blow-up detection: the checks that stop a run that has gone wrong, with a message that
//! names the body, the step and the likely cause.
//!
//! - **Non-finite state** (NaN or infinity): found by [`World::step`] itself, every step.
//! - **Escape**: a body entirely on the solid side of a wall (its centre more than its
//!   bounding radius behind the plane) has tunnelled through it: it moved more than its size
//!   in one step.
//! - **Energy growth**: the kinetic energy exceeds [`ENERGY_FACTOR`] times the energy the run
//!   can have: the initial kinetic energy, plus the potential energy released since the start,
//!   plus the elastic energy of initial overlaps, plus a floor (every body lifted by its own
//!   size and moving one size per second; with moving boundary meshes, also every body at
//!   twice their fastest surface speed and lifted by their extent and travel). Contacts only
//!   dissipate, so a physical run stays below 1x; an unstable integration grows exponentially
//!   past any factor.
//! - **Deep overlap**: a contact deeper than [`OVERLAP_LIMIT`] of the smaller body's size
//!   (its volume-equivalent radius: a sphere's radius; for a polyhedron the radius of the
//!   sphere of the same volume, which, unlike the inradius, does not make a vertex of a
//!   tetrahedron resting on a soft floor look like tunnelling).
//! - **Before the run**: an overlap deeper than [`INITIAL_OVERLAP_LIMIT`] at step 0 (bodies
//!   placed on top of each other or behind a wall) refuses to start, and a time step above the
//!   stability bound of the stiffest contact is warned about.
//!
//! [`Health::check`] without `full` is the cheap check: one sequential pass over the bodies
//! (escape, energies; about 10 ns per body) and, for the overlap test, only the contacts
//! whose last normal force implies a deep overlap (a streaming compare, exact test on the few
//! suspects). The CLI runs it every 10 steps. The full check adds the exact overlap test of
//! every touching contact (a narrow phase) and is meant for every hundred steps and output
//! steps. When several problems show at once, the first of non-finite state, energy growth,
//! escape, deep overlap is reported: an unstable integration also flings bodies through
//! walls, and the energy names the cause better.

use std::fmt;

use rayon::prelude::*;

use crate::contact_list::Partner;
use crate::exact_sum::ExactSum;
use crate::law;
use crate::world::{SimError, World};

mod contacts;
pub use contacts::{ContactReport, find_contacts, touching_contacts};
use contacts::{contact_report, estimated_depth, law_of, mesh_reports};

/// A contact deeper than this fraction of the smaller body's size stops the run.
pub const OVERLAP_LIMIT: f32 = 0.5;
/// At step 0, an overlap deeper than this fraction of the smaller body's size refuses to start.
pub const INITIAL_OVERLAP_LIMIT: f32 = 0.25;
/// Kinetic energy above this multiple of the energy available to the run stops it.
pub const ENERGY_FACTOR: f64 = 10.0;

/// What went wrong.
#[derive(Debug, Clone, PartialEq)]
pub enum BlowUpKind {
    /// A position, velocity or orientation became NaN or infinite.
    NonFinite,
    /// The kinetic energy exceeds [`ENERGY_FACTOR`] times the energy available.
    EnergyGrowth {
        /// Total kinetic energy, J.
        kinetic: f64,
        /// The energy available to the run at this point, J.
        available: f64,
        /// The body's own kinetic energy, J.
        body_kinetic: f64,
    },
    /// The body is entirely on the solid side of a wall.
    Escaped {
        /// The wall.
        wall: u32,
        /// How far its centre is behind the wall plane, m.
        distance: f32,
    },
    /// A contact deeper than the limit.
    DeepOverlap {
        /// The other side.
        other: Partner,
        /// Overlap depth, m.
        depth: f32,
        /// The size (volume-equivalent radius) it is compared with, m.
        size: f32,
        /// The limit, as a fraction of `size`.
        limit: f32,
    },
}

/// A run that went wrong: what, which body, when, and the likely cause.
#[derive(Debug, Clone, PartialEq)]
pub struct BlowUp {
    /// What was found.
    pub kind: BlowUpKind,
    /// The body it concerns.
    pub body: usize,
    /// The step at which it was found (0: before the run).
    pub step: u64,
    /// Simulated time then, s.
    pub time: f64,
    /// The likely cause, in words, with what to change.
    pub cause: String,
}

impl fmt::Display for BlowUp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (b, s, t) = (self.body, self.step, self.time);
        match &self.kind {
            BlowUpKind::NonFinite => write!(
                f,
                "the simulation blew up at step {s} (t = {t:.6e} s): body {b} has a non-finite position or velocity (NaN or infinity)"
            )?,
            BlowUpKind::EnergyGrowth {
                kinetic,
                available,
                body_kinetic,
            } => write!(
                f,
                "the simulation blew up at step {s} (t = {t:.6e} s): the kinetic energy grows without bound ({kinetic:.3e} J, more than {ENERGY_FACTOR}x the {available:.3e} J available to the run); body {b} is the fastest ({body_kinetic:.3e} J)"
            )?,
            BlowUpKind::Escaped { wall, distance } => write!(
                f,
                "the simulation blew up at step {s} (t = {t:.6e} s): body {b} escaped through wall {wall} (its centre is {distance:.3e} m behind the wall, on the solid side)"
            )?,
            BlowUpKind::DeepOverlap {
                other,
                depth,
                size,
                limit,
            } if s == 0 => write!(
                f,
                "the bodies start overlapping: body {b} and {other} overlap by {depth:.3e} m at step 0, {:.0}% of the body's size {size:.3e} m (the limit is {:.0}%)",
                100.0 * depth / size,
                100.0 * limit
            )?,
            BlowUpKind::DeepOverlap {
                other,
                depth,
                size,
                limit,
            } => write!(
                f,
                "the simulation blew up at step {s} (t = {t:.6e} s): body {b} and {other} overlap by {depth:.3e} m, {:.0}% of the body's size {size:.3e} m (the limit is {:.0}%)",
                100.0 * depth / size,
                100.0 * limit
            )?,
        }
        write!(f, ". Likely cause: {}", self.cause)
    }
}

impl std::error::Error for BlowUp {}

/// Relative spacing of the stored positions: 2^-48, the double-single pair the GPU keeps
/// (the CPU's f64 is finer, 2^-52); a contact whose overlap is a few of these at the body's
/// coordinate cannot be resolved.
pub const POSITION_EPSILON: f64 = 3.552713678800501e-15;

/// How many position spacings an overlap must span to be resolved.
pub const SPACINGS_PER_OVERLAP: f64 = 4.0;

/// Float spacing as the likely cause: body `body`'s resting overlap under its own weight on a
/// contact of its own material (`m g` on one point) is below [`SPACINGS_PER_OVERLAP`] spacings
/// of the stored positions at its coordinate, so the contact force jumps between zero and
/// many times the weight. Rare with double-precision positions (it needs coordinates of
/// about 1e6 m for a millimetre grain), but the message then says so.
fn float_spacing_cause(world: &World, i: usize, body: usize) -> Option<String> {
    let x = *world.state.position.get(i)?;
    let weight = world.consts.mass[i] * world.gravity.length();
    if weight.is_nan() || weight <= 0.0 || !x.is_finite() {
        return None;
    }
    let (params, r_eff, share) = law_of(world, i as u32, Partner::Body(i as u32));
    let depth = law::depth_at_force(&params, r_eff, weight, share) as f64;
    let spacing = x.abs().max_element() * POSITION_EPSILON;
    (depth < SPACINGS_PER_OVERLAP * spacing).then(|| {
        format!(
            "float spacing: body {body}'s resting overlap under its weight ({depth:.3e} m) is below {SPACINGS_PER_OVERLAP} spacings ({spacing:.3e} m each) of the positions at its coordinate {x} m, so its contact force cannot be resolved: move the scene nearer the origin (coordinates are kept to {POSITION_EPSILON:.1e} relative), or use larger or heavier bodies or softer contacts"
        )
    })
}

/// The blow-up checks of one run, with the baseline they compare against.
#[derive(Debug, Clone)]
pub struct Health {
    /// Size (volume-equivalent radius) per shape.
    size: Vec<f32>,
    /// `KE0 + PE0 + E_elastic0 + floor`: the available energy is this minus the current PE.
    budget: f64,
    /// Shortest contact duration, s.
    t_c: f64,
    /// Largest stable time step of the stiffest contact, s.
    stable_dt: f64,
    /// Deepest initial overlap: body, other side, depth over size.
    initial_overlap: Option<(u32, Partner, f32)>,
    /// Fastest body at the start relative to its size: body, speed, size moved per step.
    initial_travel: Option<(usize, f32, f32)>,
    /// The smallest normal force any contact can have at an overlap of [`OVERLAP_LIMIT`]:
    /// contacts below it are not looked at by the cheap check.
    force_floor: f32,
}

/// How many f32 spacings of a 1 m/s velocity a step's gravity must span at least before
/// [`Health::warnings`] warns that slow accelerations are rounded (64: half a spacing is
/// 0.8% of the step's change).
pub const SLOW_STEP_SPACINGS: f64 = 64.0;

impl Health {
    /// The checks for a run starting from `world`'s current state (the baseline energy is
    /// measured now; overlaps are found from scratch).
    pub fn new(world: &World) -> Health {
        let mut h = Health::bare(world);
        let contacts = find_contacts(world);
        let mut elastic = 0.0f64;
        for c in &contacts {
            elastic += h.elastic_energy(world, c);
            let (depth, size) = (c.manifold.max_depth(), h.contact_size(world, c));
            let ratio = depth / size;
            if h.initial_overlap.is_none_or(|(_, _, r)| ratio > r) {
                h.initial_overlap = Some((c.body, c.other, ratio));
            }
        }
        h.budget = world.kinetic_energy() + world.potential_energy() + elastic + h.floor(world);
        h
    }

    /// The checks with a baseline saved earlier ([`Health::baseline`]), for a resumed run.
    pub fn with_baseline(world: &World, baseline: f64) -> Health {
        let mut h = Health::bare(world);
        h.budget = baseline;
        h
    }

    fn bare(world: &World) -> Health {
        let size = world
            .shapes
            .iter()
            .map(|s| {
                (3.0 * s.volume / (4.0 * std::f32::consts::PI))
                    .cbrt()
                    .max(1e-12)
            })
            .collect();
        let t_c = world.shortest_contact_duration();
        let mut h = Health {
            size,
            budget: 0.0,
            t_c,
            stable_dt: 2.0 / std::f64::consts::PI * t_c,
            initial_overlap: None,
            initial_travel: None,
            force_floor: 0.0,
        };
        // The weakest spring over everything present: the softest pair, the smallest size
        // and radius, the smallest point share.
        let min_size = h.size.iter().copied().fold(f32::INFINITY, f32::min);
        let min_r = world
            .consts
            .equivalent_radius
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min);
        let share = law::point_share(world.spheres_only(), world.spheres_only());
        let d = OVERLAP_LIMIT * min_size;
        let floor = world
            .materials
            .table()
            .iter()
            .map(|p| law::spring(p, 0.5 * min_r, d, share).0)
            .fold(f32::INFINITY, f32::min);
        h.force_floor = if floor.is_finite() { 0.5 * floor } else { 0.0 };
        let dt = world.dt;
        for i in 0..world.len() {
            let speed = world.state.velocity[i].length();
            let travel = speed * dt / h.body_size(world, i);
            if travel > 0.0 && h.initial_travel.is_none_or(|(_, _, t)| travel > t) {
                h.initial_travel = Some((i, speed, travel));
            }
        }
        h
    }

    /// The energy baseline, to be saved with a checkpoint and given to [`Health::with_baseline`].
    pub fn baseline(&self) -> f64 {
        self.budget
    }

    /// The smallest normal force any contact can have at an overlap of [`OVERLAP_LIMIT`], N:
    /// the cheap check looks only at touching contacts above it (so does the GPU's).
    pub fn force_floor(&self) -> f32 {
        self.force_floor
    }

    /// The largest stable time step of the stiffest contact (`2 / omega`, about `0.64 t_c`), s.
    pub fn stable_dt(&self) -> f64 {
        self.stable_dt
    }

    /// Warnings before the run: a time step above the stability bound, or above `t_c / 10`,
    /// or so small that gravity's change of a velocity per step is a few f32 spacings.
    pub fn warnings(&self, world: &World) -> Vec<String> {
        let dt = world.dt as f64;
        let mut out = Vec::new();
        if self.t_c.is_finite() && dt > self.stable_dt {
            out.push(format!(
                "dt = {dt:.3e} s is above the stability bound {:.3e} s of the stiffest contact (shortest contact duration {:.3e} s): the run will blow up; lower dt (or omit it for t_c/50) or the stiffness",
                self.stable_dt, self.t_c
            ));
        } else if self.t_c.is_finite() && dt > self.t_c / 10.0 {
            out.push(format!(
                "dt = {dt:.3e} s is more than 1/10 of the shortest contact duration {:.3e} s: contacts will be poorly resolved or blow up",
                self.t_c
            ));
        }
        // Velocities are f32: a step's gravity within 64 spacings of a 1 m/s velocity is
        // rounded by up to half a spacing, 0.8% there and more as dt shrinks
        // (docs/scene-format.md, "Velocities are f32").
        let g_dt = world.gravity.length() as f64 * dt;
        if g_dt > 0.0 && g_dt < SLOW_STEP_SPACINGS * f32::EPSILON as f64 {
            out.push(format!(
                "dt = {dt:.3e} s is so small that a step's gravity, {g_dt:.2e} m/s, is within {SLOW_STEP_SPACINGS} float spacings of a 1 m/s velocity: velocities are 32-bit floats, so slow accelerations (gravity, friction) are rounded by about a percent or more at such speeds; soften the stiffness for a larger automatic dt (docs/scene-format.md, \"Velocities are f32\")"
            ));
        }
        out
    }

    /// The check before the first step: no overlap deeper than [`INITIAL_OVERLAP_LIMIT`].
    pub fn check_initial(&self, world: &World) -> Result<(), BlowUp> {
        if let Some((body, other, ratio)) = self.initial_overlap
            && ratio > INITIAL_OVERLAP_LIMIT
        {
            let size = self.body_size(world, body as usize).min(match other {
                Partner::Body(j) => self.body_size(world, j as usize),
                Partner::Wall(_) | Partner::Boundary(_) => f32::INFINITY,
            });
            let cause = match other {
                Partner::Body(_) => "overlapping initial placement: place the bodies apart (a lattice's spacing at least the bodies' bounding diameter, random groups clear of `[[body]]` entries)".to_string(),
                Partner::Wall(_) => "initial placement across a wall: a body starts (partly) on the solid side of a wall or outside the container; move it inside".to_string(),
                Partner::Boundary(b) => format!("initial placement across a mesh boundary: a body starts (partly) through the triangles of boundary {b} (`{}`); move it clear of the mesh", world.boundaries[b as usize].file),
            };
            return Err(BlowUp {
                kind: BlowUpKind::DeepOverlap {
                    other,
                    depth: ratio * size,
                    size,
                    limit: INITIAL_OVERLAP_LIMIT,
                },
                body: body as usize,
                step: world.step_count,
                time: world.time,
                cause,
            });
        }
        Ok(())
    }

    /// The checks during the run: escape and energy growth, and with `full` also the overlap
    /// depth of every touching contact. On a decomposed world each rank checks its own
    /// bodies and contacts and the verdicts are reduced ([`crate::domain::Domain::check`]):
    /// the stages below are the ones it reduces, so it finds the same blow-up.
    pub fn check(&self, world: &World, full: bool) -> Result<(), BlowUp> {
        // Energies, summed exactly (so ranks find the same totals from their shares); a NaN
        // or infinity anywhere in the state shows up in their sums.
        let (ke, pe) = self.energy_sums(world);
        let (kinetic, potential) = (ke.value(), pe.value());
        if !(kinetic.is_finite() && potential.is_finite())
            && let Some(i) = first_non_finite(world)
        {
            return Err(self.blow_up(world, BlowUpKind::NonFinite, i, i, false));
        }
        let available = self.budget - potential;
        if energy_grows(kinetic, available) {
            let (body_kinetic, i) = fastest(world);
            let i = i.unwrap_or(0);
            let kind = BlowUpKind::EnergyGrowth {
                kinetic,
                available,
                body_kinetic,
            };
            return Err(self.blow_up(world, kind, i, i, false));
        }
        if let Some(i) = first_escaped(world) {
            return Err(self.blow_up(world, escape_of(world, i), i, i, false));
        }
        let contacts = self.overlap_candidates(world, full);
        if let Some((ratio, c)) = worst_overlap(contacts.iter().map(|(_, c)| c), |c| {
            self.overlap_ratio(world, c)
        }) && ratio > OVERLAP_LIMIT
        {
            let i = c.body as usize;
            return Err(self.blow_up(world, self.deep_overlap(world, c, ratio), i, i, true));
        }
        Ok(())
    }

    /// The exact sums of the kinetic and the potential energy of the bodies `world` owns
    /// (all but its ghosts; [`World::kinetic_energy`]'s and [`World::potential_energy`]'s
    /// terms, summed exactly rather than in order).
    pub(crate) fn energy_sums(&self, world: &World) -> (ExactSum, ExactSum) {
        let [ke, pe] = ExactSum::par_sums(world.len(), |i| {
            if world.is_ghost(i) {
                return [0.0; 2];
            }
            [world.body_kinetic_energy(i), world.body_potential_energy(i)]
        });
        (ke, pe)
    }

    /// A blow-up of body `i` of `world` (named `body`: its scene id), found now.
    pub(crate) fn blow_up(
        &self,
        world: &World,
        kind: BlowUpKind,
        i: usize,
        body: usize,
        overlap: bool,
    ) -> BlowUp {
        BlowUp {
            kind,
            body,
            step: world.step_count,
            time: world.time,
            cause: self.cause(world, i, body, overlap),
        }
    }

    /// The contacts the overlap check looks at, in contact-list order then the mesh
    /// contacts by body, each with its order within its kind (`0` body pairs, `1` walls,
    /// `2` meshes) and its piece (for a mesh contact, its rank among its body's): every
    /// touching contact of `world`'s own bodies in a full check, otherwise those whose last
    /// force implies a deep overlap. A body pair belongs to its first body.
    pub(crate) fn overlap_candidates(
        &self,
        world: &World,
        full: bool,
    ) -> Vec<((u8, u32), ContactReport)> {
        let c = world.contacts.springs();
        let np = world.contacts.pairs.len();
        let pieces = &world.contacts.pieces;
        let piece = |k: usize| {
            if pieces.len() == world.contacts.len() {
                pieces[k]
            } else {
                0
            }
        };
        let mine = |k: usize| !world.is_ghost(world.contacts.partners(k).0 as usize);
        let suspect = |k: usize| {
            full || (c.forces[k].normal_force.abs() > self.force_floor
                && estimated_depth(world, k) > OVERLAP_LIMIT * self.smallest_size(world, k))
        };
        let mut out: Vec<((u8, u32), ContactReport)> = (0..c.touching.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&k| c.touching[k] && mine(k) && suspect(k))
            .filter_map(|k| Some((((k >= np) as u8, piece(k)), contact_report(world, k)?)))
            .collect();
        let reports = mesh_reports(world, |i| {
            !world.is_ghost(i)
                && if full {
                    world.mesh.body_slots(i).iter().any(|s| s.touching)
                } else {
                    self.deep_mesh_slot(world, i)
                }
        });
        let mut seq = 0;
        let mut last = None;
        for r in reports {
            seq = if last == Some(r.body) { seq + 1 } else { 0 };
            last = Some(r.body);
            out.push(((2, seq), r));
        }
        out
    }

    /// A contact's overlap over the size it is compared with.
    pub(crate) fn overlap_ratio(&self, world: &World, c: &ContactReport) -> f32 {
        c.manifold.max_depth() / self.contact_size(world, c)
    }

    /// The deep overlap of contact `c`, whose ratio is `ratio`.
    pub(crate) fn deep_overlap(&self, world: &World, c: &ContactReport, ratio: f32) -> BlowUpKind {
        let size = self.contact_size(world, c);
        BlowUpKind::DeepOverlap {
            other: c.other,
            depth: ratio * size,
            size,
            limit: OVERLAP_LIMIT,
        }
    }

    /// The report for a step that failed with a non-finite state.
    pub fn non_finite(&self, world: &World, err: &SimError) -> BlowUp {
        let SimError::NonFinite {
            body, step, time, ..
        } = *err;
        BlowUp {
            kind: BlowUpKind::NonFinite,
            body,
            step,
            time,
            cause: self.likely_cause(world, body),
        }
    }

    /// Why a run probably blew up, in words: the time step against the stiffness, initial
    /// overlaps, bodies too fast for the time step.
    pub fn likely_cause(&self, world: &World, body: usize) -> String {
        self.cause(world, body, body, false)
    }

    /// The likely cause for body `i` of `world`, named `body` (its scene id).
    fn cause(&self, world: &World, i: usize, body: usize, overlap: bool) -> String {
        let dt = world.dt as f64;
        let mut causes = Vec::new();
        if let Some(c) = float_spacing_cause(world, i, body) {
            causes.push(c);
        }
        if self.t_c.is_finite() && dt > self.stable_dt {
            causes.push(format!(
                "the time step dt = {dt:.3e} s is above the stability bound {:.3e} s of the stiffest contact (shortest contact duration t_c = {:.3e} s): lower dt (omit it for t_c/50) or the stiffness",
                self.stable_dt, self.t_c
            ));
        } else if self.t_c.is_finite() && dt > self.t_c / 10.0 {
            causes.push(format!(
                "the time step dt = {dt:.3e} s is more than 1/10 of the shortest contact duration t_c = {:.3e} s (too large for the stiffness; the automatic dt is t_c/50)",
                self.t_c
            ));
        }
        if let Some((b, other, ratio)) = self.initial_overlap
            && ratio > 0.05
        {
            causes.push(format!(
                "overlapping initial placement (body {b} and {other} start overlapping by {:.0}% of the body's size)",
                100.0 * ratio
            ));
        }
        if let Some((b, v, travel)) = self.initial_travel.filter(|t| t.2 > 0.2) {
            causes.push(format!(
                "body {b} moves {travel:.2} of its size per step (speed {v:.3e} m/s): too fast for dt = {dt:.3e} s; lower dt so that a body moves a small fraction of its size per step"
            ));
        }
        if causes.is_empty() && overlap {
            let m = world
                .materials
                .list()
                .get(world.consts.material.get(i).copied().unwrap_or(0) as usize);
            causes.push(format!(
                "the contacts are too soft for the load (weight, pressure or impact speed) on body {body}{}: raise the stiffness (youngs_modulus for Hertz), or lower the speeds",
                m.map_or(String::new(), |m| format!(" (material `{}`)", m.name))
            ));
        }
        if causes.is_empty() {
            causes.push(format!(
                "the time step dt = {dt:.3e} s is probably too large for the stiffness (shortest contact duration t_c = {:.3e} s) or the speeds, or bodies started overlapping",
                self.t_c
            ));
        }
        causes.join("; or ")
    }

    /// Whether a mesh slot of body `i` has a normal force that implies a deep overlap (the
    /// cheap check's suspects, as `estimated_depth` picks them from the contact list).
    fn deep_mesh_slot(&self, world: &World, i: usize) -> bool {
        let limit = OVERLAP_LIMIT * self.body_size(world, i);
        world.mesh.body_slots(i).iter().any(|s| {
            s.touching && s.force.normal_force.abs() > self.force_floor && {
                let (params, r_eff, share) = law_of(world, i as u32, Partner::Boundary(s.boundary));
                law::depth_at_force(&params, r_eff, s.force.normal_force, share) > limit
            }
        })
    }

    fn body_size(&self, world: &World, i: usize) -> f32 {
        self.size[world.consts.shape[i] as usize]
    }

    /// The size the overlap of contact `k` of the contact list is compared with.
    fn smallest_size(&self, world: &World, k: usize) -> f32 {
        let (i, other) = world.contacts.partners(k);
        let a = self.body_size(world, i as usize);
        match other {
            Partner::Body(j) => a.min(self.body_size(world, j as usize)),
            Partner::Wall(_) | Partner::Boundary(_) => a,
        }
    }

    fn contact_size(&self, world: &World, c: &ContactReport) -> f32 {
        let a = self.body_size(world, c.body as usize);
        match c.other {
            Partner::Body(j) => a.min(self.body_size(world, j as usize)),
            Partner::Wall(_) | Partner::Boundary(_) => a,
        }
    }

    /// Elastic energy stored in an (initial) overlap, J: the law's spring energy per point.
    fn elastic_energy(&self, world: &World, c: &ContactReport) -> f64 {
        let (params, r_eff, share) = law_of(world, c.body, c.other);
        c.manifold
            .points()
            .iter()
            .map(|p| law::elastic_energy(&params, r_eff, p.depth, share))
            .sum()
    }

    /// Every body lifted by its own size, and moving its own size per second; with moving
    /// boundary meshes (which feed energy in: a drum lifts its bed, a plate bats), also every
    /// body at twice their fastest surface speed and lifted by their size.
    fn floor(&self, world: &World) -> f64 {
        let g = world.gravity.length() as f64;
        let (mut speed, mut lift) = (0.0f64, 0.0f64);
        for b in world.boundaries.iter().filter(|b| b.moves()) {
            let (lo, hi) = b.vertices.iter().fold(
                (
                    glam::Vec3::splat(f32::INFINITY),
                    glam::Vec3::splat(f32::NEG_INFINITY),
                ),
                |(lo, hi), v| (lo.min(*v), hi.max(*v)),
            );
            let size = (hi - lo).length() as f64;
            let (v, travel) = match b.motion {
                crate::mesh_boundary::BoundaryMotion::Translate { velocity } => {
                    let v = velocity.length() as f64;
                    (v, v * (b.end - b.start).min(1e3))
                }
                crate::mesh_boundary::BoundaryMotion::Rotate {
                    angular_velocity, ..
                } => (angular_velocity.length() as f64 * b.reach as f64, 0.0),
                crate::mesh_boundary::BoundaryMotion::Fixed => (0.0, 0.0),
            };
            speed = speed.max(v);
            lift = lift.max(size + travel);
        }
        (0..world.len())
            .map(|i| {
                let (m, s) = (world.consts.mass[i] as f64, self.body_size(world, i) as f64);
                m * g * (s + lift) + 0.5 * m * (s * s + 4.0 * speed * speed)
            })
            .sum()
    }
}

/// Whether a kinetic energy is past what the run can have: more than [`ENERGY_FACTOR`] times
/// the energy `available` (or not finite).
pub(crate) fn energy_grows(kinetic: f64, available: f64) -> bool {
    !kinetic.is_finite() || kinetic > ENERGY_FACTOR * available.max(0.0)
}

/// The first of `world`'s own bodies (lowest index) with a non-finite state.
pub(crate) fn first_non_finite(world: &World) -> Option<usize> {
    (0..world.len()).find(|&i| !world.is_ghost(i) && !world.state.is_finite(i))
}

/// The fastest of `world`'s own bodies: its kinetic energy and index (the first of equals;
/// `-inf` and none when no body's energy is above `-inf`, NaNs never win).
pub(crate) fn fastest(world: &World) -> (f64, Option<usize>) {
    (0..world.len())
        .filter(|&i| !world.is_ghost(i))
        .map(|i| (world.body_kinetic_energy(i), Some(i)))
        .fold(
            (f64::NEG_INFINITY, None),
            |a, b| if b.0 > a.0 { b } else { a },
        )
}

/// The first of `world`'s own bodies (lowest index) entirely on the solid side of a wall.
/// Per wall, how many bodies are behind it first (a count has no loop-carried float
/// dependency, unlike a running minimum); only when some are, which body. Bodies removed by
/// a sink are out of the simulation and are not looked at.
pub(crate) fn first_escaped(world: &World) -> Option<usize> {
    let (x, r) = (&world.state.position, &world.consts.radius);
    let gone = &world.state.removed;
    let ghost = |i: usize| world.is_ghost(i);
    // In parallel pieces (a count, so the same for any split): this runs between steps.
    let escaped = world.walls.iter().any(|w| {
        use rayon::prelude::*;
        let (n, o) = (w.plane.normal.as_dvec3(), w.plane.offset as f64);
        x.par_iter()
            .zip(r)
            .zip(gone)
            .enumerate()
            .with_min_len(1024)
            .map(|(i, ((x, r), g))| (!g & !ghost(i) & (n.dot(*x) - o < -(*r as f64))) as u32)
            .sum::<u32>()
            > 0
    });
    if !escaped {
        return None;
    }
    (0..world.len()).find(|&i| {
        !gone[i] && !ghost(i) && world.walls.iter().any(|w| wall_height(w, x[i]) < -r[i])
    })
}

/// The escape of body `i` of `world`: the wall it is deepest behind (the first of equals).
pub(crate) fn escape_of(world: &World, i: usize) -> BlowUpKind {
    let (wall, h) = world
        .walls
        .iter()
        .enumerate()
        .map(|(k, w)| (k as u32, wall_height(w, world.state.position[i])))
        .fold((0, f32::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
    BlowUpKind::Escaped { wall, distance: -h }
}

/// The deepest of `contacts` by `ratio` and its ratio, as one pass in order finds it: the
/// first contact is taken, then each deeper one (so the first of equals, and a NaN first
/// ratio stays: it is not past the limit).
pub(crate) fn worst_overlap<'a>(
    contacts: impl Iterator<Item = &'a ContactReport>,
    ratio: impl Fn(&ContactReport) -> f32,
) -> Option<(f32, &'a ContactReport)> {
    let mut worst: Option<(f32, &ContactReport)> = None;
    for c in contacts {
        let r = ratio(c);
        if worst.is_none_or(|(w, _)| r > w) {
            worst = Some((r, c));
        }
    }
    worst
}

/// How far `x` is in front of wall `w` (`n . x - d`, in f64, then rounded).
fn wall_height(w: &crate::world::Wall, x: glam::DVec3) -> f32 {
    (w.plane.normal.as_dvec3().dot(x) - w.plane.offset as f64) as f32
}
