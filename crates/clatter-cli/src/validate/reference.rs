//! The truths that are not closed forms: an independent f64 integration of the contact law of
//! two spheres (or a sphere and a wall plane), written here from the law's definition in
//! docs/scene-format.md and not from `clatter::law` (which is f32 and shared by both
//! backends), plus the closed forms of elastic Hertz impacts.
//!
//! The law integrated here (per docs/scene-format.md and LIGGGHTS' `hertz/history`):
//! - normal: linear `k d`, or Hertz `4/3 E* sqrt(R* d) d`, minus `gamma_n v_n` with
//!   `gamma_n = 2 beta sqrt(S_n m*)` (linear, `S_n = k`) or `2 sqrt(5/6) beta sqrt(S_n m*)`
//!   (Hertz, `S_n = 2 E* sqrt(R* d)`), `beta = -ln e / sqrt(pi^2 + ln^2 e)`; not clamped at 0;
//! - tangential: a spring `-k_t xi` (`k_t = 8 G* sqrt(R* d)` for Hertz, `2/7 k` linear) on
//!   the accumulated tangential displacement `xi` (rotated into the current tangent plane),
//!   minus `gamma_t v_t` (Hertz: `2 sqrt(5/6) beta sqrt(k_t m*)`; linear: `gamma_n / 2`),
//!   the spring limited to `mu F_n / k_t` (it slips there) and the sum capped at `mu F_n`.
//!
//! The oblique-impact checks run perfectly elastic (`e = 1`), where both damping terms vanish,
//! so their truth does not depend on how the tangential damping is defined.

use glam::DVec3;

/// `int_0^1 dx / sqrt(1 - x^(5/2)) = (2/5) B(2/5, 1/2)`: the Hertz contact time is
/// `2 * HERTZ_TIME * d_max / v`.
pub const HERTZ_TIME: f64 = 1.471_639;

/// Effective modulus of two materials (`E`, `nu`).
pub fn e_star(e1: f64, n1: f64, e2: f64, n2: f64) -> f64 {
    1.0 / ((1.0 - n1 * n1) / e1 + (1.0 - n2 * n2) / e2)
}

/// Effective shear modulus of two materials (`E`, `nu`).
pub fn g_star(e1: f64, n1: f64, e2: f64, n2: f64) -> f64 {
    1.0 / (2.0 * (2.0 - n1) * (1.0 + n1) / e1 + 2.0 * (2.0 - n2) * (1.0 + n2) / e2)
}

/// Elastic Hertz impact at normal approach speed `v`: (max overlap, peak force, contact time).
pub fn hertz_impact(m_eff: f64, r_eff: f64, e_star: f64, v: f64) -> (f64, f64, f64) {
    let d = (15.0 * m_eff * v * v / (16.0 * e_star * r_eff.sqrt())).powf(0.4);
    let f = 4.0 / 3.0 * e_star * r_eff.sqrt() * d.powf(1.5);
    (d, f, 2.0 * HERTZ_TIME * d / v)
}

/// The contact law's parameters, in f64.
#[derive(Clone, Copy, Debug)]
pub struct Law {
    /// Hertz (else linear).
    pub hertz: bool,
    /// Linear: k (N/m); Hertz: E* (Pa).
    pub stiffness: f64,
    /// Hertz: G* (Pa).
    pub shear: f64,
    /// Coefficient of restitution.
    pub restitution: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
}

/// A sphere (or, with infinite mass, the wall plane `z = 0` with normal +z).
#[derive(Clone, Copy, Debug)]
pub struct Ball {
    /// kg (`f64::INFINITY`: the wall).
    pub m: f64,
    /// m.
    pub r: f64,
    /// Centre.
    pub x: DVec3,
    /// Velocity.
    pub v: DVec3,
    /// Angular velocity.
    pub w: DVec3,
}

impl Ball {
    /// The wall plane `z = 0`.
    pub fn wall() -> Ball {
        Ball {
            m: f64::INFINITY,
            r: 0.0,
            x: DVec3::ZERO,
            v: DVec3::ZERO,
            w: DVec3::ZERO,
        }
    }

    fn is_wall(&self) -> bool {
        self.m.is_infinite()
    }

    fn inertia(&self) -> f64 {
        0.4 * self.m * self.r * self.r
    }
}

/// What [`impact`] returns.
pub struct Impact {
    /// The bodies after the contact.
    pub a: Ball,
    /// The bodies after the contact.
    pub b: Ball,
    /// `(t, overlap, normal force)` samples during the contact.
    pub history: Vec<(f64, f64, f64)>,
    /// Whether the friction force was at its Coulomb cap at every step in contact (gross
    /// sliding).
    pub sliding_throughout: bool,
}

/// Integrates the contact of `a` (a sphere or [`Ball::wall`]) and `b` with semi-implicit
/// Euler at `dt` until they separate (the bodies must start just apart and approach).
pub fn impact(law: &Law, mut a: Ball, mut b: Ball, dt: f64) -> Impact {
    let beta = {
        let l = law.restitution.ln();
        -l / (std::f64::consts::PI.powi(2) + l * l).sqrt()
    };
    let m_eff = if a.is_wall() {
        b.m
    } else {
        a.m * b.m / (a.m + b.m)
    };
    let r_eff = if a.is_wall() {
        b.r
    } else {
        a.r * b.r / (a.r + b.r)
    };
    let mut xi = DVec3::ZERO;
    let mut touched = false;
    let mut sliding = true;
    let mut history = Vec::new();
    let mut t = 0.0;
    for _ in 0..100_000_000u64 {
        let (n, depth, point) = if a.is_wall() {
            let n = DVec3::Z;
            let d = b.r - b.x.z;
            (n, d, b.x - n * (b.r - 0.5 * d))
        } else {
            let c = b.x - a.x;
            let dist = c.length();
            let n = c / dist;
            let d = a.r + b.r - dist;
            (n, d, a.x + n * (a.r - 0.5 * d))
        };
        let (mut fa, mut fb, mut ta, mut tb) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        if depth > 0.0 {
            touched = true;
            let va = a.v + a.w.cross(point - a.x);
            let vb = b.v + b.w.cross(point - b.x);
            let vrel = vb - va;
            let (fs, k, kt) = if law.hertz {
                let c = (r_eff * depth).sqrt();
                (
                    4.0 / 3.0 * law.stiffness * c * depth,
                    2.0 * law.stiffness * c,
                    8.0 * law.shear * c,
                )
            } else {
                (
                    law.stiffness * depth,
                    law.stiffness,
                    2.0 / 7.0 * law.stiffness,
                )
            };
            let factor = if law.hertz {
                2.0 * (5.0f64 / 6.0).sqrt() * beta
            } else {
                2.0 * beta
            };
            let gamma_n = factor * (m_eff * k).sqrt();
            let gamma_t = if law.hertz {
                factor * (m_eff * kt).sqrt()
            } else {
                0.5 * gamma_n
            };
            let fn_ = fs - gamma_n * vrel.dot(n);
            let vt = vrel - n * vrel.dot(n);
            let along = xi.dot(n);
            if along != 0.0 {
                let l0 = xi.length_squared();
                xi -= n * along;
                let l1 = xi.length_squared();
                if l1 > 0.0 {
                    xi *= (l0 / l1).sqrt();
                }
            }
            xi += vt * dt;
            let cap = law.friction * fn_.max(0.0);
            // As law.rs: the spring slips at the Coulomb force, then the sum is capped.
            let spring = kt * xi.length();
            if spring > cap {
                xi *= cap / spring;
            }
            let mut ft = -kt * xi - gamma_t * vt;
            if ft.length() > cap {
                ft *= cap / ft.length();
            }
            // Gross sliding: the friction at its cap (to rounding) while the contact presses.
            if fn_ > 0.0 && ft.length() < cap * (1.0 - 1e-9) {
                sliding = false;
            }
            let f = n * fn_ + ft;
            fb = f;
            fa = -f;
            tb = (point - b.x).cross(f);
            ta = (point - a.x).cross(-f);
            history.push((t, depth, fn_));
        } else if touched {
            break;
        } else {
            xi = DVec3::ZERO;
        }
        if !a.is_wall() {
            a.v += fa / a.m * dt;
            a.w += ta / a.inertia() * dt;
            a.x += a.v * dt;
        }
        b.v += fb / b.m * dt;
        b.w += tb / b.inertia() * dt;
        b.x += b.v * dt;
        t += dt;
    }
    Impact {
        a,
        b,
        history,
        sliding_throughout: sliding,
    }
}

/// Rigid-body gross sliding (Coulomb impulse ratio): the bodies after an impact whose
/// friction is at its cap throughout, with normal restitution `e`. The normal is +z (from a
/// to b), the contact point at `b.x - b.r z` (`a.x + a.r z`).
pub fn gross_sliding(mu: f64, e: f64, a: Ball, b: Ball) -> (Ball, Ball) {
    let n = DVec3::Z;
    let m_eff = if a.is_wall() {
        b.m
    } else {
        a.m * b.m / (a.m + b.m)
    };
    let (ra, rb) = (n * a.r, -n * b.r);
    let vrel = (b.v + b.w.cross(rb)) - (a.v + a.w.cross(ra));
    let vn = vrel.dot(n);
    let slip = vrel - n * vn;
    let jn = -(1.0 + e) * m_eff * vn;
    let jt = -mu * jn * slip.normalize_or_zero();
    let j = n * jn + jt;
    let (mut a2, mut b2) = (a, b);
    b2.v += j / b.m;
    b2.w += rb.cross(j) / b.inertia();
    if !a.is_wall() {
        a2.v -= j / a.m;
        a2.w += ra.cross(-j) / a.inertia();
    }
    (a2, b2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ball(m: f64, r: f64, z: f64, v: DVec3, w: DVec3) -> Ball {
        Ball {
            m,
            r,
            x: DVec3::new(0.0, 0.0, z),
            v,
            w,
        }
    }

    /// The constant of the Hertz contact time, by quadrature of `1 / sqrt(1 - x^(5/2))`
    /// (substituting `x = 1 - u^2` to remove the end singularity).
    #[test]
    fn hertz_time_constant() {
        let n = 200_000;
        let mut sum = 0.0;
        for i in 0..n {
            let u = (i as f64 + 0.5) / n as f64;
            let x: f64 = 1.0 - u * u;
            sum += 2.0 * u / (1.0 - x.powf(2.5)).sqrt() / n as f64;
        }
        assert!((sum - HERTZ_TIME).abs() < 1e-5, "{sum}");
    }

    /// The f64 integration of an elastic head-on Hertz impact reproduces the closed forms.
    #[test]
    fn elastic_impact_matches_hertz_closed_forms() {
        let (m, r, v, e_star) = (0.01, 0.01, 1.0, 1e9);
        let law = Law {
            hertz: true,
            stiffness: e_star,
            shear: 0.0,
            restitution: 1.0,
            friction: 0.0,
        };
        let (d, f, tc) = hertz_impact(m, r, e_star, v);
        let b = ball(m, r, r + 1e-12, DVec3::new(0.0, 0.0, -v), DVec3::ZERO);
        let out = impact(&law, Ball::wall(), b, tc / 100_000.0);
        let dm = out.history.iter().map(|s| s.1).fold(0.0, f64::max);
        let fm = out.history.iter().map(|s| s.2).fold(0.0, f64::max);
        let tm = out.history.len() as f64 * tc / 100_000.0;
        assert!((dm / d - 1.0).abs() < 1e-4, "{dm} {d}");
        assert!((fm / f - 1.0).abs() < 1e-4, "{fm} {f}");
        assert!((tm / tc - 1.0).abs() < 1e-3, "{tm} {tc}");
        assert!((out.b.v.z / v - 1.0).abs() < 1e-6, "elastic: {}", out.b.v.z);
    }

    /// A damped linear impact meets its restitution (the closed form of the linear law).
    #[test]
    fn linear_impact_meets_restitution() {
        for e in [0.1, 0.5, 0.9] {
            let law = Law {
                hertz: false,
                stiffness: 1e4,
                shear: 0.0,
                restitution: e,
                friction: 0.0,
            };
            let b = ball(
                0.01,
                0.01,
                0.01 + 1e-12,
                DVec3::new(0.0, 0.0, -1.0),
                DVec3::ZERO,
            );
            let out = impact(&law, Ball::wall(), b, 1e-7);
            assert!((out.b.v.z / e - 1.0).abs() < 1e-3, "e {e}: {}", out.b.v.z);
        }
    }

    /// At a steep angle the integration slides throughout and agrees with the closed form.
    #[test]
    fn steep_oblique_impact_slides_as_the_closed_form() {
        let law = Law {
            hertz: true,
            stiffness: 6e10,
            shear: 2.5e10,
            restitution: 1.0,
            friction: 0.1,
        };
        let t = 70f64.to_radians();
        let b = ball(
            2.6e-4,
            0.0025,
            0.0025 + 1e-12,
            DVec3::new(3.9 * t.sin(), 0.0, -3.9 * t.cos()),
            DVec3::ZERO,
        );
        let (_, _, tc) = hertz_impact(b.m, b.r, law.stiffness, 3.9 * t.cos());
        let out = impact(&law, Ball::wall(), b, tc / 20_000.0);
        assert!(out.sliding_throughout);
        let (_, s) = gross_sliding(law.friction, 1.0, Ball::wall(), b);
        assert!(
            (out.b.v.x - s.v.x).abs() < 1e-3 * b.v.x,
            "{} {}",
            out.b.v.x,
            s.v.x
        );
        assert!(
            (out.b.w.y - s.w.y).abs() * b.r < 2e-3 * b.v.x,
            "{} {}",
            out.b.w.y,
            s.w.y
        );
        // Near normal incidence it sticks.
        let t = 5f64.to_radians();
        let b = Ball {
            v: DVec3::new(3.9 * t.sin(), 0.0, -3.9 * t.cos()),
            ..b
        };
        assert!(!impact(&law, Ball::wall(), b, tc / 20_000.0).sliding_throughout);
    }
}
