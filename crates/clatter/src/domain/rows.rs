//! The records ranks exchange, as little-endian bytes: a body's state (every field the step
//! integrates, so a copy steps bitwise as the original), a body pair's springs and a body-wall
//! pair's springs (what a rebuild carries over). Bodies are named by their global id (their
//! index in the scene).

use glam::{DVec3, Quat, Vec3};

use crate::bodies::BodyStates;
use crate::contract::ContactForce;
use crate::mesh_boundary::MeshSlot;
use crate::world::World;

/// The size of a state written by [`Writer::state`]: position (3 f64), velocity,
/// orientation, its residual, angular momentum, angular velocity (f32) and the removed flag.
pub(crate) const STATE_BYTES: usize = 24 + 12 + 16 + 16 + 12 + 12 + 4;

/// The size of a sphere's ghost state written by [`Writer::sphere_state`]: position (3
/// f64), velocity, angular velocity (f32) and the removed flag: what the step reads of a
/// ghost sphere (`super::ghosts`).
pub(crate) const SPHERE_STATE_BYTES: usize = 24 + 12 + 12 + 4;

/// The size of a body's constants written by [`Writer::consts`]: shape, material, sphere
/// flag, mass, inertia, inverse mass and inertia, bounding and equivalent radius, reach.
pub(crate) const CONST_BYTES: usize = 4 * 14;

/// The size of a mesh contact slot written by [`Writer::slot`].
pub(crate) const SLOT_BYTES: usize = 12 + 12 + 12 + 4 + 40;

/// Appends little-endian fields to a message.
#[derive(Default)]
pub(crate) struct Writer(pub Vec<u8>);

impl Writer {
    pub fn u32(&mut self, x: u32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    pub fn f32(&mut self, x: f32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    /// `b` with its length before it.
    pub fn bytes(&mut self, b: &[u8]) {
        self.u32(b.len() as u32);
        self.0.extend_from_slice(b);
    }
    pub fn f64(&mut self, x: f64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    pub fn vec3(&mut self, v: Vec3) {
        self.f32(v.x);
        self.f32(v.y);
        self.f32(v.z);
    }
    pub fn quat(&mut self, q: Quat) {
        self.f32(q.x);
        self.f32(q.y);
        self.f32(q.z);
        self.f32(q.w);
    }

    pub fn dvec3(&mut self, v: DVec3) {
        self.f64(v.x);
        self.f64(v.y);
        self.f64(v.z);
    }
    /// A contact's force (without the padding).
    pub fn force(&mut self, f: &ContactForce) {
        self.vec3(f.force_b);
        self.f32(f.normal_force);
        self.vec3(f.torque_a);
        self.vec3(f.torque_b);
    }

    /// A body's mesh contact slot.
    pub fn slot(&mut self, m: &MeshSlot) {
        self.u32(m.boundary);
        self.u32(m.piece);
        self.u32(m.touching as u32);
        self.vec3(m.normal);
        self.vec3(m.history);
        self.f32(m.twist);
        self.force(&m.force);
    }

    /// Body `i`'s constants (what the step reads of it besides its state: they travel with
    /// the body, so no rank keeps every body's), bit for bit.
    pub fn consts(&mut self, w: &World, i: usize) {
        let c = &w.consts;
        self.u32(c.shape[i]);
        self.u32(c.material[i]);
        self.u32(c.is_sphere[i] as u32);
        self.f32(c.mass[i]);
        self.vec3(c.inertia[i]);
        self.f32(c.inv_mass[i]);
        self.vec3(c.inv_inertia[i]);
        self.f32(c.radius[i]);
        self.f32(c.equivalent_radius[i]);
        self.f32(w.reach.get(i).copied().unwrap_or(0.0));
    }

    /// Body `i`'s state: the fields of [`STATE_BYTES`] in order, assembled in a fixed-size
    /// record and appended at once (ghost states go out every step: one capacity check
    /// per state, not one per field).
    pub fn state(&mut self, s: &BodyStates, i: usize) {
        let mut r = [0u8; STATE_BYTES];
        // At the fixed offsets `fields` reads (constant ranges of an array: plain stores).
        let mut f64_at = |a: usize, x: f64| r[a..a + 8].copy_from_slice(&x.to_le_bytes());
        let x = s.position[i];
        f64_at(0, x.x);
        f64_at(8, x.y);
        f64_at(16, x.z);
        let (v, q, r0) = (s.velocity[i], s.orientation[i], s.orientation_residual[i]);
        let (l, w) = (s.angular_momentum[i], s.omega[i]);
        let floats = [
            v.x, v.y, v.z, q.x, q.y, q.z, q.w, r0.x, r0.y, r0.z, r0.w, l.x, l.y, l.z, w.x, w.y, w.z,
        ];
        for (k, f) in floats.into_iter().enumerate() {
            r[24 + 4 * k..28 + 4 * k].copy_from_slice(&f.to_le_bytes());
        }
        r[92..96].copy_from_slice(&(s.removed[i] as u32).to_le_bytes());
        self.0.extend_from_slice(&r);
    }

    /// Body `i`'s ghost sphere state: the fields of [`SPHERE_STATE_BYTES`] in order, in
    /// one fixed-size record (as [`Writer::state`]).
    pub fn sphere_state(&mut self, s: &BodyStates, i: usize) {
        let mut r = [0u8; SPHERE_STATE_BYTES];
        let x = s.position[i];
        for (k, c) in [x.x, x.y, x.z].into_iter().enumerate() {
            r[8 * k..8 * k + 8].copy_from_slice(&c.to_le_bytes());
        }
        let (v, w) = (s.velocity[i], s.omega[i]);
        for (k, f) in [v.x, v.y, v.z, w.x, w.y, w.z].into_iter().enumerate() {
            r[24 + 4 * k..28 + 4 * k].copy_from_slice(&f.to_le_bytes());
        }
        r[48..52].copy_from_slice(&(s.removed[i] as u32).to_le_bytes());
        self.0.extend_from_slice(&r);
    }
}

/// Reads little-endian fields from a message written by [`Writer`]. Messages come from
/// ranks of the same binary, so a short message is a bug: it panics.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, at: 0 }
    }
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        out.copy_from_slice(&self.bytes[self.at..self.at + N]);
        self.at += N;
        out
    }
    /// A reader of `bytes` from byte `at` on.
    pub fn at(bytes: &'a [u8], at: usize) -> Self {
        Reader { bytes, at }
    }
    /// Where the next field starts.
    pub fn position(&self) -> usize {
        self.at
    }
    /// Skips a state written by [`Writer::state`].
    pub fn skip_state(&mut self) {
        self.at += STATE_BYTES;
    }
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    pub fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    pub fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    /// Bytes written by [`Writer::bytes`].
    pub fn bytes(&mut self) -> &'a [u8] {
        let n = self.u32() as usize;
        let b = &self.bytes[self.at..self.at + n];
        self.at += n;
        b
    }
    pub fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32())
    }
    pub fn quat(&mut self) -> Quat {
        let (x, y, z, w) = (self.f32(), self.f32(), self.f32(), self.f32());
        Quat::from_xyzw(x, y, z, w)
    }

    pub fn dvec3(&mut self) -> DVec3 {
        DVec3::new(self.f64(), self.f64(), self.f64())
    }
    /// A force written by [`Writer::force`].
    pub fn force(&mut self) -> ContactForce {
        ContactForce {
            force_b: self.vec3(),
            normal_force: self.f32(),
            torque_a: self.vec3(),
            torque_b: self.vec3(),
            ..ContactForce::default()
        }
    }

    /// A slot written by [`Writer::slot`].
    pub fn slot(&mut self) -> MeshSlot {
        MeshSlot {
            boundary: self.u32(),
            piece: self.u32(),
            touching: self.u32() != 0,
            normal: self.vec3(),
            history: self.vec3(),
            twist: self.f32(),
            force: self.force(),
        }
    }
    /// Constants written by [`Writer::consts`], into body `i` of `w` (whose reach is kept
    /// only in a world with composites, as [`World::new`] keeps it).
    pub fn consts(&mut self, w: &mut World, i: usize) {
        let c = &mut w.consts;
        c.shape[i] = self.u32();
        c.material[i] = self.u32();
        c.is_sphere[i] = self.u32() != 0;
        c.mass[i] = self.f32();
        c.inertia[i] = self.vec3();
        c.inv_mass[i] = self.f32();
        c.inv_inertia[i] = self.vec3();
        c.radius[i] = self.f32();
        c.equivalent_radius[i] = self.f32();
        let reach = self.f32();
        if let Some(r) = w.reach.get_mut(i) {
            *r = reach;
        }
    }
    /// Skips constants written by [`Writer::consts`].
    pub fn skip_consts(&mut self) {
        self.at += CONST_BYTES;
    }
    /// Skips `n` slots.
    pub fn skip_slots(&mut self, n: usize) {
        self.at += n * SLOT_BYTES;
    }

    /// A state written by [`Writer::state`], into body `i` of `s`. The record is taken
    /// whole (one bounds check) and its fields read at fixed offsets.
    pub fn state(&mut self, s: &mut BodyStates, i: usize) {
        let record: &[u8; STATE_BYTES] = self.bytes[self.at..self.at + STATE_BYTES]
            .try_into()
            .expect("a whole state");
        self.at += STATE_BYTES;
        fields(record, s, i);
    }
}

impl Reader<'_> {
    /// A ghost sphere's state written by [`Writer::sphere_state`], into body `i` of `s`:
    /// position, velocity, angular velocity and removed flag; the other fields of `s` are
    /// left as they are.
    pub fn sphere_state(&mut self, s: &mut BodyStates, i: usize) {
        let record: &[u8; SPHERE_STATE_BYTES] = self.bytes[self.at..self.at + SPHERE_STATE_BYTES]
            .try_into()
            .expect("a whole sphere state");
        self.at += SPHERE_STATE_BYTES;
        let f64_at = |a: usize| f64_in(record, a);
        let f32_at = |a: usize| f32_in(record, a);
        s.position[i] = DVec3::new(f64_at(0), f64_at(8), f64_at(16));
        s.velocity[i] = Vec3::new(f32_at(24), f32_at(28), f32_at(32));
        s.omega[i] = Vec3::new(f32_at(36), f32_at(40), f32_at(44));
        s.removed[i] = u32::from_le_bytes(record[48..52].try_into().expect("4 bytes")) != 0;
    }
}

/// [`Reader::state`]'s fields, read at their fixed offsets in the record (constant ranges
/// of an array: no bounds check, no reader state; ghost states are read every step).
#[inline(always)]
fn fields(record: &[u8; STATE_BYTES], s: &mut BodyStates, i: usize) {
    let f64_at = |a: usize| f64_in(record, a);
    let f32_at = |a: usize| f32_in(record, a);
    let vec3_at = |a: usize| Vec3::new(f32_at(a), f32_at(a + 4), f32_at(a + 8));
    let quat_at =
        |a: usize| Quat::from_xyzw(f32_at(a), f32_at(a + 4), f32_at(a + 8), f32_at(a + 12));
    // The offsets of `Writer::state`: position (3 f64), velocity, orientation, its
    // residual, angular momentum, angular velocity, removed flag.
    s.position[i] = DVec3::new(f64_at(0), f64_at(8), f64_at(16));
    s.velocity[i] = vec3_at(24);
    s.orientation[i] = quat_at(36);
    s.orientation_residual[i] = quat_at(52);
    s.angular_momentum[i] = vec3_at(68);
    s.omega[i] = vec3_at(80);
    s.removed[i] = u32::from_le_bytes(record[92..96].try_into().expect("4 bytes")) != 0;
}

/// A mesh slot as it arrives through a message ([`Writer::slot`] then [`Reader::slot`]):
/// the same fields, the force's padding zeroed. A slot that stays on its rank at a rebuild
/// is copied through this, so it is what a message to the rank itself would have given.
pub(crate) fn travelled(m: &MeshSlot) -> MeshSlot {
    MeshSlot {
        force: ContactForce {
            force_b: m.force.force_b,
            normal_force: m.force.normal_force,
            torque_a: m.force.torque_a,
            torque_b: m.force.torque_b,
            ..ContactForce::default()
        },
        ..*m
    }
}

/// A contact's springs on the move between ranks at a rebuild: the contact by global ids
/// (`[body, body]` or `[body, wall]`) and piece code, its tangential and twisting springs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SpringRow {
    pub key: [u32; 2],
    pub piece: u32,
    pub history: Vec3,
    pub twist: f32,
}

impl SpringRow {
    pub fn write(&self, w: &mut Writer) {
        w.u32(self.key[0]);
        w.u32(self.key[1]);
        w.u32(self.piece);
        w.vec3(self.history);
        w.f32(self.twist);
    }
    pub fn read(r: &mut Reader) -> SpringRow {
        SpringRow {
            key: [r.u32(), r.u32()],
            piece: r.u32(),
            history: r.vec3(),
            twist: r.f32(),
        }
    }
}

/// A contact with everything it carries, for gathering the whole contact list
/// ([`super::Domain::gather`]); `hint` and `bound` only for body pairs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ContactRow {
    pub key: [u32; 2],
    pub piece: u32,
    pub history: Vec3,
    pub twist: f32,
    pub force: ContactForce,
    pub touching: bool,
    pub hint: u32,
    pub bound: f32,
}

impl ContactRow {
    pub fn write(&self, w: &mut Writer, pair: bool) {
        w.u32(self.key[0]);
        w.u32(self.key[1]);
        w.u32(self.piece);
        w.vec3(self.history);
        w.f32(self.twist);
        w.force(&self.force);
        w.u32(self.touching as u32);
        if pair {
            w.u32(self.hint);
            w.f32(self.bound);
        }
    }
    pub fn read(r: &mut Reader, pair: bool) -> ContactRow {
        let key = [r.u32(), r.u32()];
        let piece = r.u32();
        let history = r.vec3();
        let twist = r.f32();
        let force = r.force();
        let touching = r.u32() != 0;
        let (hint, bound) = if pair { (r.u32(), r.f32()) } else { (0, 0.0) };
        ContactRow {
            key,
            piece,
            history,
            twist,
            force,
            touching,
            hint,
            bound,
        }
    }
}

/// The little-endian `f64` at byte `a` of a fixed-size record (inlined with a constant `a`,
/// so no bounds check is left).
#[inline(always)]
fn f64_in<const N: usize>(record: &[u8; N], a: usize) -> f64 {
    let b: [u8; 8] = record[a..a + 8].try_into().expect("8 bytes");
    f64::from_le_bytes(b)
}

/// The little-endian `f32` at byte `a` of a fixed-size record (see [`f64_in`]).
#[inline(always)]
fn f32_in<const N: usize>(record: &[u8; N], a: usize) -> f32 {
    let b: [u8; 4] = record[a..a + 4].try_into().expect("4 bytes");
    f32::from_le_bytes(b)
}
