//! The data contract of the two backends: the records both store and the constants both use,
//! defined once here. The GPU backend declares them to its shaders with
//! [`GpuRecord::wgsl`] and [`wgsl_constants`], generated from these definitions, so no
//! layout or number is ever retyped in WGSL; `tests` below checks every field's WGSL offset
//! against Rust's.
//!
//! Records are `#[repr(C)]` + [`bytemuck::Pod`], laid out as WGSL lays out the same struct
//! in a storage buffer (a `vec3<f32>` is 16-byte aligned and 12 bytes long, so an `f32` may
//! follow it in the same 16 bytes).

use bytemuck::Pod;
use glam::{Quat, Vec3};

/// A Rust field type with a WGSL twin: its name and its storage-buffer alignment and size.
pub trait WgslType {
    /// The WGSL type.
    const WGSL: &'static str;
    /// Alignment in a WGSL storage buffer, bytes.
    const ALIGN: usize;
    /// Size in a WGSL storage buffer, bytes.
    const SIZE: usize;
}

macro_rules! wgsl_type {
    ($($t:ty => $name:literal, $align:literal, $size:literal;)*) => {$(
        impl WgslType for $t {
            const WGSL: &'static str = $name;
            const ALIGN: usize = $align;
            const SIZE: usize = $size;
        }
    )*};
}

wgsl_type! {
    f32 => "f32", 4, 4;
    u32 => "u32", 4, 4;
    Vec3 => "vec3<f32>", 16, 12;
    [f32; 4] => "vec4<f32>", 16, 16;
    [u32; 4] => "vec4<u32>", 16, 16;
}

/// One field of a [`GpuRecord`]: its name, WGSL type and layout on both sides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    /// Field name (the same in Rust and WGSL).
    pub name: &'static str,
    /// WGSL type.
    pub wgsl: &'static str,
    /// Byte offset in the Rust struct.
    pub offset: usize,
    /// WGSL alignment, bytes.
    pub align: usize,
    /// WGSL size, bytes.
    pub size: usize,
}

/// A `#[repr(C)]` record shared with the shaders (made by [`gpu_record!`](crate::gpu_record)).
pub trait GpuRecord: Pod {
    /// The struct's name in both languages.
    const NAME: &'static str;
    /// The fields in declaration order.
    fn fields() -> Vec<Field>;
    /// The WGSL declaration of the struct.
    fn wgsl() -> String {
        let mut s = format!("struct {} {{\n", Self::NAME);
        for f in Self::fields() {
            s += &format!("    {}: {},\n", f.name, f.wgsl);
        }
        s + "}\n"
    }
}

/// Declares a `#[repr(C)]`, `Pod` record and its [`GpuRecord`] description in one go, so the
/// WGSL declaration is generated from the Rust definition. Field types must implement
/// [`WgslType`].
#[macro_export]
macro_rules! gpu_record {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $( $(#[$fmeta:meta])* pub $field:ident : $ty:ty, )*
        }
    ) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $( $(#[$fmeta])* pub $field: $ty, )*
        }

        impl $crate::contract::GpuRecord for $name {
            const NAME: &'static str = stringify!($name);
            fn fields() -> Vec<$crate::contract::Field> {
                vec![$(
                    $crate::contract::Field {
                        name: stringify!($field),
                        wgsl: <$ty as $crate::contract::WgslType>::WGSL,
                        offset: std::mem::offset_of!($name, $field),
                        align: <$ty as $crate::contract::WgslType>::ALIGN,
                        size: <$ty as $crate::contract::WgslType>::SIZE,
                    },
                )*]
            }
        }
    };
}

/// Where a record's layout differs from WGSL's: `None` when every field sits at the offset
/// WGSL gives it and the sizes agree, else a description of the first difference.
pub fn layout_mismatch<R: GpuRecord>() -> Option<String> {
    let mut offset = 0usize;
    let mut align = 1usize;
    for f in R::fields() {
        offset = offset.next_multiple_of(f.align);
        align = align.max(f.align);
        if offset != f.offset {
            return Some(format!(
                "{}.{}: WGSL offset {offset}, Rust offset {}",
                R::NAME,
                f.name,
                f.offset
            ));
        }
        offset += f.size;
    }
    let size = offset.next_multiple_of(align);
    (size != std::mem::size_of::<R>()).then(|| {
        format!(
            "{}: WGSL size {size}, Rust size {}",
            R::NAME,
            std::mem::size_of::<R>()
        )
    })
}

/// One shared constant, written out for WGSL by [`wgsl_constants`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Constant {
    /// An `f32` constant.
    F32(&'static str, f32),
    /// A `u32` constant.
    U32(&'static str, u32),
}

impl Constant {
    /// `const NAME: T = value;`, with the exact value (an `f32` printed as the shortest
    /// decimal of its `f64` widening, which converts back to the same `f32` exactly).
    pub fn wgsl(&self) -> String {
        match *self {
            Constant::F32(name, v) => format!("const {name}: f32 = {:?};\n", v as f64),
            Constant::U32(name, v) => format!("const {name}: u32 = {v}u;\n"),
        }
    }
}

/// WGSL `const` declarations for `constants`.
pub fn wgsl_constants(constants: &[Constant]) -> String {
    constants.iter().map(Constant::wgsl).collect()
}

// ---------------------------------------------------------------------------------------
// The contact law's constants.

/// Tangential stiffness over normal stiffness in the linear law (2/7: tangential and normal
/// oscillations of a sphere contact equally fast).
pub const LINEAR_TANGENTIAL_RATIO: f32 = 2.0 / 7.0;
/// Tangential damping over normal damping (LAMMPS's default `gammat = gamman / 2`).
pub const TANGENTIAL_DAMPING_RATIO: f32 = 0.5;
/// Fraction of the law each manifold point carries in a contact with a sphere (one point).
pub const SPHERE_POINT_SHARE: f32 = 1.0;
/// Fraction of the law each of up to four points carries in a polyhedron-polyhedron or
/// polyhedron-wall contact (a full face contact has the material's stiffness).
pub const POLYHEDRON_POINT_SHARE: f32 = 0.25;
/// [`PairParams::model`]: linear spring-dashpot.
pub const MODEL_LINEAR: u32 = 0;
/// [`PairParams::model`]: Hertz normal law with Mindlin-type tangential stiffness.
pub const MODEL_HERTZ: u32 = 1;

/// [`PairParams::cohesion_model`]: no cohesion.
pub const COHESION_NONE: u32 = 0;
/// [`PairParams::cohesion_model`]: DMT adhesion, a constant pull `2 pi gamma R*` while the
/// bodies overlap.
pub const COHESION_DMT: u32 = 1;

/// The contact law's constants as both backends see them.
pub const LAW_CONSTANTS: &[Constant] = &[
    Constant::F32("LINEAR_TANGENTIAL_RATIO", LINEAR_TANGENTIAL_RATIO),
    Constant::F32("TANGENTIAL_DAMPING_RATIO", TANGENTIAL_DAMPING_RATIO),
    Constant::F32("SPHERE_POINT_SHARE", SPHERE_POINT_SHARE),
    Constant::F32("POLYHEDRON_POINT_SHARE", POLYHEDRON_POINT_SHARE),
    Constant::U32("MODEL_LINEAR", MODEL_LINEAR),
    Constant::U32("MODEL_HERTZ", MODEL_HERTZ),
    Constant::U32("COHESION_NONE", COHESION_NONE),
    Constant::U32("COHESION_DMT", COHESION_DMT),
];

// ---------------------------------------------------------------------------------------
// The records.

gpu_record! {
    /// One body's integrated state, 112 bytes; the GPU stores one per body, the CPU the same
    /// fields as arrays ([`crate::bodies::BodyStates`], the position in f64). The centre of
    /// mass is a double-single pair: `position` (the f32 nearest) plus `position_lo` (the
    /// rest), see [`crate::bodies::split_position`]. The `w` of `position` is 1.0 for a
    /// body removed by a sink ([`crate::sink`]), else 0.0; the other `w`s are unused. The renderer reads `position` (byte 0) and `orientation` (byte 32) straight
    /// from the GPU's buffer.
    pub struct BodyState {
        /// Centre of mass, m.
        pub position: [f32; 4],
        /// Linear velocity, m/s.
        pub velocity: [f32; 4],
        /// Orientation of the principal frame, quaternion `x, y, z, w`.
        pub orientation: [f32; 4],
        /// Rounding carried by the compensated orientation update, quaternion `x, y, z, w`.
        pub residual: [f32; 4],
        /// Angular momentum about the centre of mass (world frame), kg m^2/s.
        pub angular_momentum: [f32; 4],
        /// Angular velocity (world frame), rad/s.
        pub omega: [f32; 4],
        /// The low part of the centre of mass (double-single with `position`), m.
        pub position_lo: [f32; 4],
    }
}

/// Byte size of [`BodyState`].
pub const BODY_STATE_SIZE: u64 = std::mem::size_of::<BodyState>() as u64;
/// Byte offset of `position` in [`BodyState`].
pub const BODY_POSITION_OFFSET: u64 = std::mem::offset_of!(BodyState, position) as u64;
/// Byte offset of `orientation` in [`BodyState`].
pub const BODY_ORIENTATION_OFFSET: u64 = std::mem::offset_of!(BodyState, orientation) as u64;

impl BodyState {
    /// Packs one body's state.
    pub fn new(
        position: Vec3,
        velocity: Vec3,
        orientation: Quat,
        residual: Quat,
        angular_momentum: Vec3,
        omega: Vec3,
    ) -> BodyState {
        let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
        let q4 = |q: Quat| [q.x, q.y, q.z, q.w];
        BodyState {
            position: v4(position),
            velocity: v4(velocity),
            orientation: q4(orientation),
            residual: q4(residual),
            angular_momentum: v4(angular_momentum),
            omega: v4(omega),
            position_lo: [0.0; 4],
        }
    }
}

/// The `xyz` of a packed vector.
pub fn vec3_of(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// The quaternion of a packed `x, y, z, w`.
pub fn quat_of(a: [f32; 4]) -> Quat {
    Quat::from_xyzw(a[0], a[1], a[2], a[3])
}

gpu_record! {
    /// One body's constants, 48 bytes (the CPU keeps the same as arrays,
    /// [`crate::bodies::BodyConstants`]).
    pub struct BodyConsts {
        /// `1 / principal moments` in xyz, `1 / mass` in w.
        pub inv_inertia: [f32; 4],
        /// kg.
        pub mass: f32,
        /// Bounding radius, m.
        pub radius: f32,
        /// Volume-equivalent sphere radius (the Hertz law's radius), m.
        pub equivalent_radius: f32,
        /// Unused.
        pub pad0: f32,
        /// Shape index.
        pub shape: u32,
        /// Material index.
        pub material: u32,
        /// 1 when the shape is a sphere.
        pub is_sphere: u32,
        /// 1 when the three principal moments are equal.
        pub isotropic: u32,
    }
}

/// The material coefficients: every per-material number of the contact law that is one `f32`
/// read from the scene's `[[material]]` table and combined per pair into the [`PairParams`]
/// field of the same name. This one table is the list; from it come the
/// [`Material`](crate::Material) field and its default, the descriptors
/// [`COEFFICIENTS`](crate::material::COEFFICIENTS) (name, default, allowed range, unit,
/// doc, combination rule), the scene file's key and its check, the pair combination in
/// [`PairParams::combine`] and the Python builder's keyword (`Scene.material`).
///
/// A row: the doc (the material field's, the scene key's and the Python keyword's), then
/// `name { default, range, unit, combine }` with `range` a
/// [`Range`](crate::material::Range) and `combine` a
/// [`Combine`](crate::material::Combine). A new coefficient is a row here and a field of
/// the same name in [`PairParams`] below (the pair's combined value, which the law reads);
/// the build fails until both exist.
///
/// The table is handed to a macro of the caller's (`material_coefficients!(then)` expands
/// to `then! { rows }`), so each consumer declares what it derives next to its own code.
#[macro_export]
macro_rules! material_coefficients {
    ($then:ident) => {
        $then! {
            /// Coefficient of restitution, in (0, 1]; sets the normal damping.
            restitution { default: 0.5, range: UnitInterval, unit: "", combine: GeometricMean }
            /// Coulomb friction coefficient (>= 0), capping the tangential spring force.
            friction { default: 0.3, range: NonNegative, unit: "", combine: GeometricMean }
            /// Rolling friction coefficient `mu_r` (>= 0, dimensionless; 0: none).
            rolling_friction { default: 0.0, range: NonNegative, unit: "", combine: GeometricMean }
            /// Spinning friction coefficient `mu_s` (>= 0, dimensionless; 0: none).
            spinning_friction { default: 0.0, range: NonNegative, unit: "", combine: GeometricMean }
        }
    };
}

gpu_record! {
    /// The combined contact parameters of two materials (or a material and a wall): the one
    /// table of the contact law's parameters. Both backends index it by
    /// `material_a * materials + material_b`; a new law term with a new material coefficient
    /// is a row in [`material_coefficients!`](crate::material_coefficients) and a field of
    /// the same name here (taking a `pad` while there is one, so that the size stays a
    /// multiple of 16 bytes), combined by [`PairParams::combine`] with the row's rule.
    pub struct PairParams {
        /// [`MODEL_LINEAR`] or [`MODEL_HERTZ`].
        pub model: u32,
        /// Linear: normal stiffness k (N/m). Hertz: effective modulus E* (Pa).
        pub stiffness: f32,
        /// Hertz only: effective shear modulus G* (Pa).
        pub shear: f32,
        /// Linear: `2 (-ln e) / sqrt(pi^2 + ln^2 e)`, so that `eta = factor * sqrt(m_eff k)`.
        /// Hertz: `2 sqrt(5/6) (-ln e) / sqrt(pi^2 + ln^2 e)` (Tsuji's damping).
        pub damping_factor: f32,
        /// Combined Coulomb friction coefficient.
        pub friction: f32,
        /// Combined restitution (the damping is derived from it).
        pub restitution: f32,
        /// Combined rolling friction coefficient `mu_r` (dimensionless): the constant
        /// directional torque `mu_r R* Fn` against relative rolling (0: none).
        pub rolling_friction: f32,
        /// [`COHESION_NONE`] or [`COHESION_DMT`].
        pub cohesion_model: u32,
        /// Combined surface energy (work of adhesion) `gamma`, J/m^2 (DMT).
        pub surface_energy: f32,
        /// Combined spinning friction coefficient `mu_s` (dimensionless): the constant
        /// torque `mu_s R* Fn` against relative spin about the contact normal (0: none).
        pub spinning_friction: f32,
        /// Unused.
        pub pad1: f32,
        /// Unused.
        pub pad2: f32,
    }
}

impl WgslType for PairParams {
    const WGSL: &'static str = "PairParams";
    const ALIGN: usize = 4;
    const SIZE: usize = std::mem::size_of::<PairParams>();
}

gpu_record! {
    /// Everything the contact law takes about a pair besides its manifold, motions and
    /// springs: the pair's [`PairParams`], its effective mass and radius, the share of the
    /// law each manifold point carries, and the step. Built per contact by the contacts
    /// stage (`law::contact_force`'s first argument, in Rust and WGSL alike).
    pub struct PairContext {
        /// The combined law parameters of the pair's materials.
        pub params: PairParams,
        /// Effective mass `m_a m_b / (m_a + m_b)` (a body against a wall: its mass), kg.
        pub m_eff: f32,
        /// Effective radius `r_a r_b / (r_a + r_b)` (a body against a wall: its radius), m.
        pub r_eff: f32,
        /// The share of the law each manifold point carries (`law::point_share`).
        pub share: f32,
        /// The time step, s.
        pub dt: f32,
    }
}

gpu_record! {
    /// What one contact does, 48 bytes: the force on side b (side a gets exactly its
    /// negative), the total normal force, and the torques on both sides about their centres
    /// of mass.
    pub struct ContactForce {
        /// Force on side b, N.
        pub force_b: Vec3,
        /// Total normal force, N (positive when pushing apart).
        pub normal_force: f32,
        /// Torque on side a, N m.
        pub torque_a: Vec3,
        /// Unused.
        pub pad0: f32,
        /// Torque on side b, N m.
        pub torque_b: Vec3,
        /// Unused.
        pub pad1: f32,
    }
}

impl WgslType for ContactForce {
    const WGSL: &'static str = "ContactForce";
    const ALIGN: usize = 16;
    const SIZE: usize = std::mem::size_of::<ContactForce>();
}

impl WgslType for PairContext {
    const WGSL: &'static str = "PairContext";
    const ALIGN: usize = 4;
    const SIZE: usize = std::mem::size_of::<PairContext>();
}

impl ContactForce {
    /// A contact's force and torques.
    pub fn new(force_b: Vec3, torque_a: Vec3, torque_b: Vec3, normal_force: f32) -> Self {
        ContactForce {
            force_b,
            normal_force,
            torque_a,
            torque_b,
            ..Default::default()
        }
    }
}

gpu_record! {
    /// A wall plane and its material as the GPU stores it (from a [`crate::Wall`]).
    pub struct WallRecord {
        /// Unit normal in xyz, offset in w: the half-space `normal . x <= offset` is solid.
        pub plane: [f32; 4],
        /// Material index.
        pub material: u32,
        /// Unused.
        pub pad0: u32,
        /// Unused.
        pub pad1: u32,
        /// Unused.
        pub pad2: u32,
    }
}

impl From<&crate::Wall> for WallRecord {
    fn from(w: &crate::Wall) -> Self {
        let n = w.plane.normal;
        WallRecord {
            plane: [n.x, n.y, n.z, w.plane.offset],
            material: w.material,
            ..Default::default()
        }
    }
}

/// What a touching polyhedron pair remembers of its contact, as both backends encode it in
/// the pair's hint word ([`clatter_geom::narrow::SatHint`]; the CPU keeps it in
/// `Springs::hints`, the GPU in `pair_memory`'s first word, the margin in the second): the
/// reference face of A (`HINT_CONTACT | face`) or of B (`HINT_FACE_B | HINT_CONTACT |
/// face`), or an edge contact (`HINT_EDGE_CONTACT`); `NO_HINT` when nothing is remembered.
pub const PAIR_MEMORY_CONSTANTS: &[Constant] = {
    use clatter_geom::narrow as n;
    &[
        Constant::U32("NO_HINT", n::NO_HINT),
        Constant::U32("HINT_FACE_B", n::HINT_FACE_B),
        Constant::U32("HINT_KIND", n::HINT_KIND),
        Constant::U32("HINT_CONTACT", n::HINT_CONTACT),
        Constant::U32("HINT_EDGE_CONTACT", n::HINT_EDGE_CONTACT),
        Constant::F32("TURN_ROUNDING", TURN_ROUNDING),
    ]
};

/// How far a body's stored orientation can turn in a step beyond `|w| dt` through the
/// rounding of its update, in radians (`2^-21`, a third above the `6 * 2^-24` derived at
/// the CPU's `axis_motion_bound`, step/remembered.rs): the margin of a remembered contact
/// shrinks by it on both bodies each step (WGSL `axis_motion_bound`, contacts.wgsl).
pub const TURN_ROUNDING: f32 = 1.0 / 2_097_152.0;

/// The WGSL declarations of every record above and of the law's constants.
pub fn wgsl_records() -> String {
    [
        wgsl_constants(LAW_CONSTANTS),
        wgsl_constants(PAIR_MEMORY_CONSTANTS),
        BodyState::wgsl(),
        BodyConsts::wgsl(),
        PairParams::wgsl(),
        PairContext::wgsl(),
        ContactForce::wgsl(),
        WallRecord::wgsl(),
    ]
    .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_record_has_the_wgsl_layout() {
        for m in [
            layout_mismatch::<BodyState>(),
            layout_mismatch::<BodyConsts>(),
            layout_mismatch::<PairParams>(),
            layout_mismatch::<PairContext>(),
            layout_mismatch::<ContactForce>(),
            layout_mismatch::<WallRecord>(),
        ] {
            assert_eq!(m, None);
        }
        assert_eq!(BODY_STATE_SIZE, 112);
        assert_eq!(std::mem::size_of::<ContactForce>(), 48);
    }

    gpu_record! {
        /// A record whose Rust layout puts `b` where WGSL would not.
        pub struct Misaligned {
            pub a: f32,
            pub pad: f32,
            pub b: [f32; 2],
        }
    }
    impl WgslType for [f32; 2] {
        const WGSL: &'static str = "vec2<f32>";
        const ALIGN: usize = 8;
        const SIZE: usize = 8;
    }

    gpu_record! {
        /// `b` is a vec3 (16-byte aligned in WGSL) at offset 4 in Rust.
        pub struct Vec3AfterScalar {
            pub a: f32,
            pub b: Vec3,
        }
    }

    #[test]
    fn a_misplaced_field_is_found() {
        assert_eq!(layout_mismatch::<Misaligned>(), None);
        let m = layout_mismatch::<Vec3AfterScalar>().expect("mismatch");
        assert!(m.contains("Vec3AfterScalar.b"), "{m}");
    }

    #[test]
    fn constants_are_written_exactly() {
        let s = Constant::F32("X", LINEAR_TANGENTIAL_RATIO).wgsl();
        let value: f64 = s
            .trim_start_matches("const X: f32 = ")
            .trim_end_matches(";\n")
            .parse()
            .expect("a number");
        assert_eq!(value as f32, LINEAR_TANGENTIAL_RATIO);
        assert_eq!(value, LINEAR_TANGENTIAL_RATIO as f64);
        assert_eq!(Constant::U32("Y", 7).wgsl(), "const Y: u32 = 7u;\n");
        assert!(ContactForce::wgsl().contains("    force_b: vec3<f32>,\n    normal_force: f32,"));
    }
}
