//! The pose of a turning mesh boundary, computed the same way, operation for operation, on
//! both executors (twin of `clatter-gpu/shaders/common/turn.wgsl`): the angle `rate u mod 2 pi`
//! as a double-single from the motion's elapsed time `u`, its sine and cosine by Cephes'
//! `sinf`/`cosf` (a range reduction and two polynomials), the quaternion, and the
//! translation that keeps the centre in place.
//!
//! Only `+`, `-`, `*` (correctly rounded in IEEE 754 and in Vulkan's precision rules), exact
//! conversions and `floor` are used, so the results are bitwise those of the WGSL twin.
//! Library `sin`/`cos` are not: libm differs between platforms, and WGSL's own promise only
//! an absolute error of 2^-11. A GPU compiler may fuse a product and a sum into one
//! multiply-add (one rounding instead of two); the WGSL twin multiplies each product that
//! feeds a sum by `params.one` (1.0, unknown to the compiler), so a fused operation sees an
//! already rounded product and gives the same bits. Rust never fuses on its own.

use glam::{Quat, Vec3};

use crate::precise::two_prod;

/// 2 pi as a double-single (hi, lo): `TAU_HI + TAU_LO` is 2 pi to about 2^-48.
pub const TAU_HI: f32 = std::f32::consts::TAU;
/// The rest of 2 pi beyond [`TAU_HI`].
pub const TAU_LO: f32 = -1.748_455_5e-7;
/// 1 / (2 pi), to guess the number of whole turns.
pub const INV_TAU: f32 = 0.159_154_94;

/// 4 / pi (Cephes' `FOPI`).
pub const FOPI: f32 = 1.273_239_5;
/// pi / 4 in three parts (Cephes' `DP1..3`): `j DP1` and `j DP2` are exact for the small
/// octant counts `j` used here.
pub const DP: [f32; 3] = [0.785_156_25, 2.418_756_5e-4, 3.774_895e-8];
/// Cephes' `sinf` polynomial in `z^2` (highest first): `sin z = z + z^3 (S0 z^4 + S1 z^2 + S2)`.
pub const SIN: [f32; 3] = [-1.951_529_6e-4, 8.332_161e-3, -1.666_665_5e-1];
/// Cephes' `cosf` polynomial: `cos z = 1 - z^2/2 + z^4 (C0 z^4 + C1 z^2 + C2)`.
pub const COS: [f32; 3] = [2.443_315_7e-5, -1.388_731_6e-3, 4.166_664_6e-2];

/// `(rate u) mod 2 pi` rounded to f32, in `[0, 2 pi]`, for the elapsed time `u = u.0 + u.1`
/// (a double-single): good to about `2^-46 rate u` however long the motion has run.
///
/// `rate u.0` exactly (two_prod) less the whole turns `k 2 pi` exactly: the difference of the
/// leading parts is exact (they are within a few turns of each other), the small parts are
/// summed apart and added last.
#[inline]
pub fn turn_angle(rate: f32, u: (f32, f32)) -> f32 {
    let (a, a_err) = two_prod(rate, u.0);
    let a_lo = a_err + rate * u.1;
    // Whole turns (maybe one off: corrected below).
    let k = (a * INV_TAU).floor();
    let (p, p_err) = two_prod(k, TAU_HI);
    let p_lo = p_err + k * TAU_LO;
    let (mut hi, mut lo) = (a - p, a_lo - p_lo);
    let r = hi + lo;
    if r < 0.0 {
        hi += TAU_HI;
        lo += TAU_LO;
    } else if r >= TAU_HI {
        hi -= TAU_HI;
        lo -= TAU_LO;
    }
    hi + lo
}

/// `(sin x, cos x)` for `0 <= x < 4` (Cephes' `sinf`/`cosf`): within a few ulps of the
/// exact values (a test holds them against f64 over `[0, 3.2]`).
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let mut j = (x * FOPI) as u32;
    if j & 1 == 1 {
        j += 1;
    }
    let y = j as f32;
    let z = ((x - y * DP[0]) - y * DP[1]) - y * DP[2];
    let zz = z * z;
    let s = ((SIN[0] * zz + SIN[1]) * zz + SIN[2]) * zz * z + z;
    let c = ((COS[0] * zz + COS[1]) * zz + COS[2]) * zz * zz - 0.5 * zz + 1.0;
    match j & 7 {
        0 => (s, c),
        2 => (c, -s),
        4 => (-s, -c),
        _ => (-c, s),
    }
}

/// The rotation by `angle` (in `[0, 2 pi]`) about the unit `axis` (as glam's
/// `Quat::from_axis_angle`, with [`sin_cos`]).
#[inline]
pub fn axis_angle(axis: Vec3, angle: f32) -> Quat {
    let (s, c) = sin_cos(angle * 0.5);
    Quat::from_xyzw(axis.x * s, axis.y * s, axis.z * s, c)
}

/// `a x b`, each component's two products rounded before they are subtracted.
#[inline]
fn cross(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    )
}

/// `v` rotated by the unit quaternion `q`: `v + w t + u x t` with `t = 2 u x v` (WGSL's
/// `quat_rotate`), component by component in this order.
#[inline]
pub fn rotate(q: Quat, v: Vec3) -> Vec3 {
    let u = Vec3::new(q.x, q.y, q.z);
    let t = 2.0 * cross(u, v);
    let c = cross(u, t);
    Vec3::new(
        (v.x + q.w * t.x) + c.x,
        (v.y + q.w * t.y) + c.y,
        (v.z + q.w * t.z) + c.z,
    )
}

/// The pose after turning by `angle` at a rotation about `axis` through `centre`: the
/// rotation and the translation `centre - q centre` that keeps the centre in place.
#[inline]
pub fn turn_pose(axis: Vec3, centre: Vec3, angle: f32) -> (Quat, Vec3) {
    let q = axis_angle(axis, angle);
    (q, centre - rotate(q, centre))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place of `want` (f64 rounded to f32).
    fn ulps(got: f32, want: f64) -> f64 {
        let w = want as f32;
        let ulp = (f32::from_bits(w.abs().to_bits() + 1) - w.abs()) as f64;
        (got as f64 - want).abs() / ulp
    }

    #[test]
    fn constants_are_the_f64_values_rounded() {
        use std::f64::consts::{PI, TAU};
        assert_eq!(TAU_LO, (TAU - TAU_HI as f64) as f32);
        assert_eq!(INV_TAU, (1.0 / TAU) as f32);
        assert_eq!(FOPI, (4.0 / PI) as f32);
        // DP1 + DP2 + DP3 is pi/4 to f32's product precision, DP1 and DP2 short.
        let dp: f64 = DP.iter().map(|&d| d as f64).sum();
        assert!((dp - PI / 4.0).abs() < 1e-15, "{}", dp - PI / 4.0);
        assert_eq!(DP[0].to_bits() & 0xffff, 0);
        assert_eq!(DP[1].to_bits() & 0xff, 0);
    }

    #[test]
    fn sin_cos_is_within_a_few_ulps_of_f64() {
        // Every 97th f32 in [0, 3.2] (the half angles used are in [0, pi]), plus the octant
        // edges where the reduction switches.
        let mut worst = (0.0f64, 0.0f64, 0.0f32);
        let mut check = |x: f32| {
            let (s, c) = sin_cos(x);
            let (ws, wc) = (x as f64).sin_cos();
            // Near a zero of sin or cos the relative error is not the measure: an absolute
            // error of an ulp of 1 is.
            let es = if ws.abs() < 0.5 {
                ulps(s, ws).min((s as f64 - ws).abs() / f32::EPSILON as f64 * 2.0)
            } else {
                ulps(s, ws)
            };
            let ec = if wc.abs() < 0.5 {
                ulps(c, wc).min((c as f64 - wc).abs() / f32::EPSILON as f64 * 2.0)
            } else {
                ulps(c, wc)
            };
            if es.max(ec) > worst.0.max(worst.1) {
                worst = (es, ec, x);
            }
        };
        let mut x = 0.0f32;
        while x <= 3.2 {
            check(x);
            x = f32::from_bits(x.to_bits() + 97);
        }
        for k in 0..5 {
            let e = (k as f64 * std::f64::consts::FRAC_PI_4) as f32;
            for d in -64i32..=64 {
                let b = (e.to_bits() as i64 + d as i64).max(0) as u32;
                check(f32::from_bits(b));
            }
        }
        eprintln!(
            "sin_cos: worst sin {} ulp, cos {} ulp (x = {})",
            worst.0, worst.1, worst.2
        );
        assert!(
            worst.0 <= 2.0 && worst.1 <= 2.0,
            "sin {} ulp, cos {} ulp at x = {}",
            worst.0,
            worst.1,
            worst.2
        );
    }

    #[test]
    fn turn_angle_is_the_f64_angle_to_the_last_bit() {
        use std::f64::consts::TAU;
        let mut worst = 0.0f64;
        for &rate in &[
            0.0f32,
            1e-3,
            0.5,
            1.0,
            3.7,
            std::f32::consts::PI,
            31.4,
            1000.0,
        ] {
            let mut u = 0.0f64;
            let dt = 1.234_567e-5f32 as f64;
            for n in 0..20_000u32 {
                // Elapsed times as both executors keep them: sums of dt, exact in 48 bits,
                // plus some long runs.
                let t = if n % 2 == 0 { u } else { u * 997.0 };
                let hi = t as f32;
                let lo = (t - hi as f64) as f32;
                let got = turn_angle(rate, (hi, lo));
                let exact = (rate as f64 * (hi as f64 + lo as f64)).rem_euclid(TAU);
                assert!((0.0..=TAU_HI).contains(&got), "{got}");
                // The angle's error measured on the circle (0 and 2 pi are one point): half
                // an ulp (rounded to nearest) plus the double-single's own error.
                let d = (got as f64 - exact).abs();
                let d = d.min(TAU - d);
                let e = exact as f32;
                let ulp = (f32::from_bits(e.to_bits() + 1) - e) as f64;
                let slack = 2f64.powi(-46) * rate as f64 * (hi as f64 + lo as f64);
                worst = worst.max((d - slack).max(0.0) / ulp);
                u += dt;
            }
        }
        eprintln!("turn_angle: worst {worst} ulp beyond the double-single's error");
        assert!(worst <= 0.5, "{worst} ulp");
    }

    #[test]
    fn turn_pose_matches_glam_to_rounding() {
        let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
        let centre = Vec3::new(0.2, -1.0, 0.4);
        for k in 0..1000 {
            let angle = k as f32 * 0.00631;
            let (q, t) = turn_pose(axis, centre, angle);
            let g = Quat::from_axis_angle(axis, angle);
            assert!((q - g).length() < 1e-6, "{q} {g}");
            let p = Vec3::new(0.7, 0.1, -0.3);
            let want = g * p + (centre - g * centre);
            assert!((rotate(q, p) + t - want).length() < 1e-5);
            assert!((rotate(q, centre) + t - centre).length() < 1e-6);
        }
    }
}
