//! Bodies, structure of arrays, split as the GPU splits them: the state the step integrates
//! ([`BodyStates`], the GPU's [`BodyState`] records) and the constants it reads
//! ([`BodyConstants`], the GPU's [`BodyConsts`]). A body is an index into every array.
//! The conversions to and from the records live here, once.

use glam::{DVec3, Quat, Vec3};

use crate::contract::{BodyConsts, BodyState, quat_of, vec3_of};

/// The integrated state of every body.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BodyStates {
    /// Centre of mass, m, kept to 48 bits (an `f64` on the grid of [`crate::precise::snap`],
    /// exactly the GPU's double-single pair): a step's displacement is kept anywhere in a
    /// large domain (the f32 spacing at 100 m is 7.6e-6 m). Relative geometry (pair
    /// offsets, wall and mesh distances) is taken from differences of these and rounded to
    /// f32 only after subtracting ([`crate::World::offset_of`], [`crate::precise`]).
    pub position: Vec<DVec3>,
    /// Linear velocity, m/s.
    pub velocity: Vec<Vec3>,
    /// Orientation of the principal frame (see [`crate::World::user_orientation`]).
    pub orientation: Vec<Quat>,
    /// Rounding carried over from the orientation updates (compensated summation), so that
    /// rotations whose per-step increment is below the precision of `orientation` still
    /// turn the body.
    pub orientation_residual: Vec<Quat>,
    /// Angular momentum about the centre of mass (world frame): the integrated quantity.
    pub angular_momentum: Vec<Vec3>,
    /// Angular velocity (world frame), derived from the angular momentum.
    pub omega: Vec<Vec3>,
    /// Whether the body has been taken out by a sink ([`crate::sink`]): it stays in the
    /// arrays, frozen, but is no longer integrated and touches nothing. On the GPU this is
    /// the `w` of [`BodyState::position`] (1.0 = removed).
    pub removed: Vec<bool>,
}

impl BodyStates {
    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Body `i`'s position rounded to f32 (for binning, drawing and other absolute uses).
    #[inline]
    pub fn position_f32(&self, i: usize) -> Vec3 {
        self.position[i].as_vec3()
    }

    /// Body `i`'s state as a record (the position as a double-single pair: `position` the
    /// f32 nearest, `position_lo` the f32 nearest the rest).
    pub fn record(&self, i: usize) -> BodyState {
        let (hi, lo) = split_position(self.position[i]);
        let mut r = BodyState::new(
            hi,
            self.velocity[i],
            self.orientation[i],
            self.orientation_residual[i],
            self.angular_momentum[i],
            self.omega[i],
        );
        r.position[3] = if self.removed[i] { 1.0 } else { 0.0 };
        r.position_lo = [lo.x, lo.y, lo.z, 0.0];
        r
    }

    /// Sets body `i`'s state from a record.
    pub fn set_record(&mut self, i: usize, s: &BodyState) {
        self.position[i] = join_position(vec3_of(s.position), vec3_of(s.position_lo));
        self.velocity[i] = vec3_of(s.velocity);
        self.orientation[i] = quat_of(s.orientation);
        self.orientation_residual[i] = quat_of(s.residual);
        self.angular_momentum[i] = vec3_of(s.angular_momentum);
        self.omega[i] = vec3_of(s.omega);
        self.removed[i] = s.position[3] != 0.0;
    }

    /// Whether every field of body `i` is finite.
    pub fn is_finite(&self, i: usize) -> bool {
        self.position[i].is_finite()
            && self.velocity[i].is_finite()
            && self.orientation[i].is_finite()
            && self.angular_momentum[i].is_finite()
            && self.omega[i].is_finite()
    }
}

/// A double-precision position as a double-single pair `(hi, lo)`: `hi` the nearest f32,
/// `lo` the nearest f32 to the rest (what the GPU keeps; 48 bits of mantissa).
#[inline]
pub fn split_position(x: DVec3) -> (Vec3, Vec3) {
    let p = crate::precise::split(x);
    (p.hi, p.lo)
}

/// The inverse of [`split_position`]: `hi + lo` in f64.
#[inline]
pub fn join_position(hi: Vec3, lo: Vec3) -> DVec3 {
    crate::precise::join(crate::precise::Ds3 { hi, lo })
}

/// The constants of every body.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BodyConstants {
    /// Shape index.
    pub shape: Vec<u32>,
    /// Material index.
    pub material: Vec<u32>,
    /// Whether the shape is a sphere.
    pub is_sphere: Vec<bool>,
    /// Mass, kg.
    pub mass: Vec<f32>,
    /// Principal moments of inertia, kg m^2.
    pub inertia: Vec<Vec3>,
    /// `1 / mass`.
    pub inv_mass: Vec<f32>,
    /// `1 / inertia`, per principal axis.
    pub inv_inertia: Vec<Vec3>,
    /// Bounding radius, m.
    pub radius: Vec<f32>,
    /// Volume-equivalent sphere radius (the Hertz law's radius), m.
    pub equivalent_radius: Vec<f32>,
}

impl BodyConstants {
    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.mass.is_empty()
    }

    /// Body `i`'s constants as a record.
    pub fn record(&self, i: usize) -> BodyConsts {
        let inv = self.inv_inertia[i];
        BodyConsts {
            inv_inertia: [inv.x, inv.y, inv.z, self.inv_mass[i]],
            mass: self.mass[i],
            radius: self.radius[i],
            equivalent_radius: self.equivalent_radius[i],
            pad0: 0.0,
            shape: self.shape[i],
            material: self.material[i],
            is_sphere: self.is_sphere[i] as u32,
            isotropic: (inv.x == inv.y && inv.y == inv.z) as u32,
        }
    }

    /// The largest bounding radius (0 without bodies).
    pub fn max_radius(&self) -> f32 {
        self.radius.iter().copied().fold(0.0, f32::max)
    }
}
