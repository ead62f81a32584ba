//! Materials and how two of them combine into the parameters of one contact.
//!
//! Combination rules (identical materials always get the material's own values):
//! - linear stiffness: `k = 2 k1 k2 / (k1 + k2)` (two springs in series, scaled by 2);
//! - Hertz: the physical effective moduli `1/E* = (1-v1^2)/E1 + (1-v2^2)/E2` and
//!   `1/G* = 2(2-v1)(1+v1)/E1 + 2(2-v2)(1+v2)/E2` (for one material these are what the
//!   Hertz-Mindlin law uses for that material);
//! - the coefficients of the table [`material_coefficients!`](crate::material_coefficients)
//!   (restitution, friction, rolling and spinning friction): each by its row's [`Combine`]
//!   rule, today all geometric means (`sqrt(e1 e2)`, ...);
//! - cohesion (DMT surface energy): geometric mean, none if either material has none.
//!
//! Linear and Hertz materials cannot be mixed in one scene (a scene error says so).

/// The normal contact law of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactLaw {
    /// Linear spring-dashpot: normal force `k * overlap` plus damping.
    Linear {
        /// Normal stiffness, N/m.
        stiffness: f32,
    },
    /// Hertz-Mindlin: normal force `4/3 E* sqrt(R* d) d` plus damping.
    Hertz {
        /// Young's modulus, Pa.
        youngs_modulus: f32,
        /// Poisson ratio, dimensionless, in [0, 0.5).
        poisson_ratio: f32,
    },
}

/// Adhesion between touching bodies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cohesion {
    /// Derjaguin-Muller-Toporov: a constant attractive normal force `2 pi gamma R*` while
    /// the bodies overlap (`R*` the effective radius), so the force needed to pull a contact
    /// apart is `2 pi gamma R*`.
    Dmt {
        /// Surface energy (work of adhesion) `gamma`, J/m^2.
        surface_energy: f32,
    },
}

/// The allowed values of a material coefficient ([`Coefficient::range`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Range {
    /// Finite and `>= 0`.
    NonNegative,
    /// In `(0, 1]`.
    UnitInterval,
}

impl Range {
    /// `None` when `v` is allowed, else what is wrong (the scene error's message).
    pub fn check(self, v: f64) -> Option<String> {
        match self {
            Range::NonNegative => (!(v.is_finite() && v >= 0.0))
                .then(|| format!("must be a finite number >= 0, got {v}")),
            Range::UnitInterval => (!(v.is_finite() && v > 0.0 && v <= 1.0))
                .then(|| format!("must be in (0, 1], got {v}")),
        }
    }

    /// The range in words, for documentation (`>= 0`, `in (0, 1]`).
    pub fn describe(self) -> &'static str {
        match self {
            Range::NonNegative => ">= 0",
            Range::UnitInterval => "in (0, 1]",
        }
    }
}

/// How two materials' values of a coefficient combine into their pair's
/// ([`Coefficient::combine`]); identical materials always get their own value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Combine {
    /// `sqrt(a b)`: zero when either is zero.
    GeometricMean,
}

impl Combine {
    /// The pair's value from the two materials' values.
    #[inline]
    pub fn apply(self, a: f32, b: f32) -> f32 {
        match self {
            Combine::GeometricMean => {
                // In f32 where the product is a normal number (the bits every run has had);
                // below that in f64: two restitutions of 1e-30 multiply to 0 in f32, and the
                // pair's damping from ln(0) was NaN at the first contact.
                let p = a * b;
                if p >= f32::MIN_POSITIVE || p == 0.0 && (a == 0.0 || b == 0.0) {
                    p.sqrt()
                } else {
                    ((a as f64) * (b as f64)).sqrt() as f32
                }
            }
        }
    }
}

/// One material coefficient, as declared in the table
/// [`material_coefficients!`](crate::material_coefficients): what the scene reader, the
/// Python builder and the documentation know about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficient {
    /// The name: the [`Material`] field, the scene key, the [`PairParams`] field and the
    /// Python keyword.
    pub name: &'static str,
    /// The value when a scene leaves it out.
    pub default: f32,
    /// The allowed values.
    pub range: Range,
    /// SI unit (`""`: dimensionless).
    pub unit: &'static str,
    /// What it is (the doc of the table's row).
    pub doc: &'static str,
    /// How a pair combines two materials' values.
    pub combine: Combine,
}

/// Declares, from the coefficient table, `Material` (with one `f32` field per coefficient),
/// [`COEFFICIENTS`], the named access to the coefficients and their pair combination.
macro_rules! material_from_table {
    ($(
        $(#[doc = $doc:literal])*
        $name:ident {
            default: $default:literal,
            range: $range:ident,
            unit: $unit:literal,
            combine: $combine:ident $(,)?
        }
    )*) => {
        /// A material: density, contact law, cohesion and the coefficients of
        /// [`COEFFICIENTS`] (restitution, friction, rolling and spinning friction, ...).
        #[derive(Debug, Clone, PartialEq)]
        pub struct Material {
            /// Name used by scene files.
            pub name: String,
            /// kg/m^3.
            pub density: f32,
            /// Normal force law.
            pub law: ContactLaw,
            $(
                $(#[doc = $doc])*
                pub $name: f32,
            )*
            /// Adhesion, if any.
            pub cohesion: Option<Cohesion>,
        }

        /// Every material coefficient, in the table's order (the order of the scene keys
        /// and of the Python keywords).
        pub const COEFFICIENTS: &[Coefficient] = &[$(
            Coefficient {
                name: stringify!($name),
                default: $default,
                range: Range::$range,
                unit: $unit,
                doc: concat!($($doc, "\n",)*),
                combine: Combine::$combine,
            },
        )*];

        impl Material {
            /// A material with every coefficient at its default and no cohesion.
            pub fn with_defaults(name: impl Into<String>, density: f32, law: ContactLaw) -> Material {
                Material {
                    name: name.into(),
                    density,
                    law,
                    $($name: $default,)*
                    cohesion: None,
                }
            }

            /// The value of coefficient `name` ([`COEFFICIENTS`]), `None` for an unknown name.
            pub fn coefficient(&self, name: &str) -> Option<f32> {
                match name {
                    $(stringify!($name) => Some(self.$name),)*
                    _ => None,
                }
            }

            /// Coefficient `name` to change it, `None` for an unknown name.
            pub fn coefficient_mut(&mut self, name: &str) -> Option<&mut f32> {
                match name {
                    $(stringify!($name) => Some(&mut self.$name),)*
                    _ => None,
                }
            }
        }

        impl PairParams {
            /// The pair's combined value of coefficient `name` ([`COEFFICIENTS`]), `None` for
            /// an unknown name.
            pub fn coefficient(&self, name: &str) -> Option<f32> {
                match name {
                    $(stringify!($name) => Some(self.$name),)*
                    _ => None,
                }
            }

            /// Sets every coefficient of the pair from those of `a` and `b`, each by its
            /// rule.
            fn combine_coefficients(&mut self, a: &Material, b: &Material) {
                $(self.$name = Combine::$combine.apply(a.$name, b.$name);)*
            }
        }
    };
}

crate::material_coefficients!(material_from_table);

impl Material {
    /// A material with the given law, restitution and friction, the other coefficients at
    /// their defaults (no rolling or spinning friction) and no cohesion.
    pub fn new(
        name: impl Into<String>,
        density: f32,
        law: ContactLaw,
        restitution: f32,
        friction: f32,
    ) -> Material {
        Material {
            restitution,
            friction,
            ..Material::with_defaults(name, density, law)
        }
    }
}

pub use crate::contract::PairParams;
use crate::contract::{COHESION_DMT, COHESION_NONE, MODEL_HERTZ, MODEL_LINEAR};

impl PairParams {
    /// Whether the normal law is Hertz (else linear).
    pub fn is_hertz(&self) -> bool {
        self.model == MODEL_HERTZ
    }

    /// Combines two materials with the rules in this module's documentation.
    pub fn combine(a: &Material, b: &Material) -> PairParams {
        let mut coefficients = PairParams::default();
        coefficients.combine_coefficients(a, b);
        let e = coefficients.restitution;
        let ln_e = (e as f64).ln();
        let base = 2.0 * (-ln_e) / (std::f64::consts::PI.powi(2) + ln_e * ln_e).sqrt();
        // Adhesion between two materials: the geometric mean of the surface energies (the
        // Berthelot rule), none when either has none.
        let (cohesion_model, surface_energy) = match (a.cohesion, b.cohesion) {
            (
                Some(Cohesion::Dmt { surface_energy: g1 }),
                Some(Cohesion::Dmt { surface_energy: g2 }),
            ) => (COHESION_DMT, (g1 * g2).sqrt()),
            _ => (COHESION_NONE, 0.0),
        };
        match (a.law, b.law) {
            (
                ContactLaw::Hertz {
                    youngs_modulus: e1,
                    poisson_ratio: v1,
                },
                ContactLaw::Hertz {
                    youngs_modulus: e2,
                    poisson_ratio: v2,
                },
            ) => {
                let (e1, v1, e2, v2) = (e1 as f64, v1 as f64, e2 as f64, v2 as f64);
                let e_star = 1.0 / ((1.0 - v1 * v1) / e1 + (1.0 - v2 * v2) / e2);
                let g_star =
                    1.0 / (2.0 * (2.0 - v1) * (1.0 + v1) / e1 + 2.0 * (2.0 - v2) * (1.0 + v2) / e2);
                PairParams {
                    model: MODEL_HERTZ,
                    stiffness: e_star as f32,
                    shear: g_star as f32,
                    damping_factor: (base * (5.0f64 / 6.0).sqrt()) as f32,
                    cohesion_model,
                    surface_energy,
                    ..coefficients
                }
            }
            _ => {
                let k = |m: &Material| match m.law {
                    ContactLaw::Linear { stiffness } => stiffness as f64,
                    ContactLaw::Hertz { .. } => f64::NAN,
                };
                let (k1, k2) = (k(a), k(b));
                PairParams {
                    model: MODEL_LINEAR,
                    stiffness: (2.0 * k1 * k2 / (k1 + k2)) as f32,
                    shear: 0.0,
                    damping_factor: base as f32,
                    cohesion_model,
                    surface_energy,
                    ..coefficients
                }
            }
        }
    }

    /// Duration of a linear contact with effective mass `m_eff`:
    /// `t_c = pi / sqrt(k/m - (eta/2m)^2)`. For Hertz, the duration of a head-on impact at
    /// `speed` with effective radius `r_eff` (undamped estimate `2.87 (m^2/(R E*^2 v))^(1/5)`).
    pub fn contact_duration(&self, m_eff: f64, r_eff: f64, speed: f64) -> f64 {
        if self.is_hertz() {
            let e = self.stiffness as f64;
            2.87 * (m_eff * m_eff / (r_eff * e * e * speed.max(1e-3))).powf(0.2)
        } else {
            let k = self.stiffness as f64;
            let eta = self.damping_factor as f64 * (m_eff * k).sqrt();
            let w2 = k / m_eff - (eta / (2.0 * m_eff)).powi(2);
            std::f64::consts::PI / w2.max(1e-30).sqrt()
        }
    }
}

/// The materials of a world and the combined parameters of every pair of them
/// ([`PairParams::combine`]), the table both backends index by `a * len + b`.
#[derive(Debug, Clone, PartialEq)]
pub struct Materials {
    list: Vec<Material>,
    table: Vec<PairParams>,
}

impl Materials {
    /// The materials and their pair table.
    pub fn new(list: Vec<Material>) -> Materials {
        let table = list
            .iter()
            .flat_map(|a| list.iter().map(move |b| PairParams::combine(a, b)))
            .collect();
        Materials { list, table }
    }

    /// The materials, by index.
    pub fn list(&self) -> &[Material] {
        &self.list
    }

    /// Number of materials.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Combined parameters of materials `a` and `b`.
    #[inline]
    pub fn pair(&self, a: u32, b: u32) -> &PairParams {
        &self.table[a as usize * self.list.len() + b as usize]
    }

    /// Every pair's parameters, row `a`, column `b` (as the GPU stores them).
    pub fn table(&self) -> &[PairParams] {
        &self.table
    }

    /// Whether every pair's law is plain ([`crate::law::is_plain`]: linear, without
    /// cohesion, rolling or spinning resistance), so the contact stages may use the law's
    /// plain forms.
    pub fn all_plain(&self) -> bool {
        self.table.iter().all(crate::law::is_plain)
    }
}
