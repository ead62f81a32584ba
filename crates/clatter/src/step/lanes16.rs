//! Sixteen lanes of `f32` in an AVX-512 register, and the plain law of one-point sphere
//! contacts sixteen at a time ([`law16`]): the AVX-512 build of [`super::lanes`]' `F8`
//! operations and of [`super::law_lanes::law`], for [`super::sphere_lanes16`].
//!
//! Why: the sphere pairs' law waits on its divisions and square roots (sph19, sph21), and
//! a CPU with a 512-bit divider (Zen 5) does sixteen in the time of eight. Each operation
//! here is the IEEE operation its `F8` twin does (`vdivps`, `vsqrtps`, `vmaxps` with the
//! constant second, ordered or unordered compares as there), lane for lane, and a mask
//! picks the same value a blend picks, so a lane gives the AVX2 build's bits, which are the
//! scalar code's. Where the law's inputs and outputs meet memory, the sixteen lanes are two
//! halves of eight ([`F16::join`], [`F16::half`]) and the AVX2 loads and stores serve.

use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

use glam::Vec3;

use super::lanes::{F8, M8, V3, load_vec3};
use super::law_lanes::{Law8, Pair8, lane_law, pair_constants};

/// Sixteen `f32` lanes. Values exist only inside AVX-512 functions (`avx512f`,
/// `avx512dq`, `avx512vl`), so the CPU has those wherever one is used.
#[derive(Clone, Copy)]
pub(super) struct F16(pub(super) __m512);

/// Sixteen lane masks, one bit a lane, from comparisons of [`F16`]s.
#[derive(Clone, Copy)]
pub(super) struct M16(pub(super) __mmask16);

macro_rules! binary {
    ($($trait:ident $method:ident $op:ident;)*) => {$(
        impl $trait for F16 {
            type Output = F16;
            #[inline(always)]
            fn $method(self, rhs: F16) -> F16 {
                // SAFETY: an `F16` exists only where the CPU has AVX-512 (see `F16`).
                F16(unsafe { $op(self.0, rhs.0) })
            }
        }
    )*};
}

binary! {
    Add add _mm512_add_ps;
    Sub sub _mm512_sub_ps;
    Mul mul _mm512_mul_ps;
    Div div _mm512_div_ps;
}

impl Neg for F16 {
    type Output = F16;
    /// The sign bit flipped, as Rust's `-x`.
    #[inline(always)]
    fn neg(self) -> F16 {
        // SAFETY: see `F16`.
        F16(unsafe { _mm512_xor_ps(self.0, _mm512_set1_ps(-0.0)) })
    }
}

impl F16 {
    #[inline(always)]
    pub(super) fn splat(v: f32) -> F16 {
        // SAFETY: see `F16`.
        F16(unsafe { _mm512_set1_ps(v) })
    }

    /// Lanes 0 to 7 from `lo`, 8 to 15 from `hi`.
    #[inline(always)]
    pub(super) fn join(lo: F8, hi: F8) -> F16 {
        // SAFETY: see `F16`.
        F16(unsafe { _mm512_insertf32x8::<1>(_mm512_castps256_ps512(lo.0), hi.0) })
    }

    /// Lanes 0 to 7 (`H = 0`) or 8 to 15 (`H = 1`).
    #[inline(always)]
    pub(super) fn half<const H: i32>(self) -> F8 {
        // SAFETY: see `F16`.
        F8(unsafe { _mm512_extractf32x8_ps::<H>(self.0) })
    }

    #[inline(always)]
    pub(super) fn sqrt(self) -> F16 {
        // SAFETY: see `F16`.
        F16(unsafe { _mm512_sqrt_ps(self.0) })
    }

    /// `|x|`: the sign bit cleared, as Rust's `abs`.
    #[inline(always)]
    pub(super) fn abs(self) -> F16 {
        // SAFETY: see `F16`.
        F16(unsafe { _mm512_andnot_ps(_mm512_set1_ps(-0.0), self.0) })
    }

    /// `self > c ? self : c`: Rust's `self.max(c)` for a constant `c` that is not NaN
    /// (`vmaxps` with `c` second, as `F8::max_const`).
    #[inline(always)]
    pub(super) fn max_const(self, c: f32) -> F16 {
        // SAFETY: see `F16`.
        F16(unsafe { _mm512_max_ps(self.0, _mm512_set1_ps(c)) })
    }

    /// `self > rhs` (false where either is NaN).
    #[inline(always)]
    pub(super) fn gt(self, rhs: F16) -> M16 {
        // SAFETY: see `F16`.
        M16(unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, rhs.0) })
    }

    /// `self < rhs` (false where either is NaN).
    #[inline(always)]
    pub(super) fn lt(self, rhs: F16) -> M16 {
        // SAFETY: see `F16`.
        M16(unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, rhs.0) })
    }

    /// `self == rhs` (false where either is NaN).
    #[inline(always)]
    pub(super) fn eq(self, rhs: F16) -> M16 {
        // SAFETY: see `F16`.
        M16(unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, rhs.0) })
    }

    /// `self != rhs` (true where either is NaN).
    #[inline(always)]
    pub(super) fn ne(self, rhs: F16) -> M16 {
        // SAFETY: see `F16`.
        M16(unsafe { _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(self.0, rhs.0) })
    }

    /// `m ? a : b` per lane.
    #[inline(always)]
    pub(super) fn select(m: M16, a: F16, b: F16) -> F16 {
        // SAFETY: see `F16`.
        F16(unsafe { _mm512_mask_blend_ps(m.0, b.0, a.0) })
    }
}

impl M16 {
    /// Lanes 0 to 7 from `lo`, 8 to 15 from `hi`.
    #[inline(always)]
    pub(super) fn join(lo: M8, hi: M8) -> M16 {
        M16((lo.bits() | hi.bits() << 8) as u16)
    }

    /// Lanes 0 to 7 (`H = 0`) or 8 to 15 (`H = 1`) as an AVX2 mask (all bits set: true).
    #[inline(always)]
    pub(super) fn half<const H: u32>(self) -> M8 {
        // SAFETY: see `F16`.
        M8(unsafe { _mm256_castsi256_ps(_mm256_movm_epi32((self.0 >> (8 * H)) as u8)) })
    }

    #[inline(always)]
    pub(super) fn and(self, rhs: M16) -> M16 {
        M16(self.0 & rhs.0)
    }

    #[inline(always)]
    pub(super) fn or(self, rhs: M16) -> M16 {
        M16(self.0 | rhs.0)
    }

    /// `!self & rhs`.
    #[inline(always)]
    pub(super) fn and_not(self, rhs: M16) -> M16 {
        M16(!self.0 & rhs.0)
    }

    /// Lane `l`'s mask in bit `l`.
    #[inline(always)]
    pub(super) fn bits(self) -> u32 {
        self.0 as u32
    }
}

/// Sixteen [`Vec3`]s, one per lane; glam's operations component by component, as [`V3`].
#[derive(Clone, Copy)]
pub(super) struct W3 {
    pub(super) x: F16,
    pub(super) y: F16,
    pub(super) z: F16,
}

impl Add for W3 {
    type Output = W3;
    #[inline(always)]
    fn add(self, r: W3) -> W3 {
        W3 {
            x: self.x + r.x,
            y: self.y + r.y,
            z: self.z + r.z,
        }
    }
}

impl Sub for W3 {
    type Output = W3;
    #[inline(always)]
    fn sub(self, r: W3) -> W3 {
        W3 {
            x: self.x - r.x,
            y: self.y - r.y,
            z: self.z - r.z,
        }
    }
}

impl Mul<F16> for W3 {
    type Output = W3;
    /// `v * s` (glam's `Vec3 * f32`, and `f32 * Vec3`: products commute).
    #[inline(always)]
    fn mul(self, s: F16) -> W3 {
        W3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

impl Div<F16> for W3 {
    type Output = W3;
    #[inline(always)]
    fn div(self, s: F16) -> W3 {
        W3 {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }
}

impl W3 {
    /// glam's `dot`: `(x x' + y y') + z z'`.
    #[inline(always)]
    pub(super) fn dot(self, r: W3) -> F16 {
        self.x * r.x + self.y * r.y + self.z * r.z
    }

    #[inline(always)]
    pub(super) fn length_squared(self) -> F16 {
        self.dot(self)
    }

    /// glam's `cross`, term for term.
    #[inline(always)]
    pub(super) fn cross(self, r: W3) -> W3 {
        W3 {
            x: self.y * r.z - r.y * self.z,
            y: self.z * r.x - r.z * self.x,
            z: self.x * r.y - r.x * self.y,
        }
    }

    #[inline(always)]
    pub(super) fn select(m: M16, a: W3, b: W3) -> W3 {
        W3 {
            x: F16::select(m, a.x, b.x),
            y: F16::select(m, a.y, b.y),
            z: F16::select(m, a.z, b.z),
        }
    }

    #[inline(always)]
    pub(super) fn splat(v: Vec3) -> W3 {
        W3 {
            x: F16::splat(v.x),
            y: F16::splat(v.y),
            z: F16::splat(v.z),
        }
    }

    /// Lanes 0 to 7 from `lo`, 8 to 15 from `hi`.
    #[inline(always)]
    pub(super) fn join(lo: V3, hi: V3) -> W3 {
        W3 {
            x: F16::join(lo.x, hi.x),
            y: F16::join(lo.y, hi.y),
            z: F16::join(lo.z, hi.z),
        }
    }

    /// Lanes 0 to 7 (`H = 0`) or 8 to 15 (`H = 1`).
    #[inline(always)]
    pub(super) fn half<const H: i32>(self) -> V3 {
        V3 {
            x: self.x.half::<H>(),
            y: self.y.half::<H>(),
            z: self.z.half::<H>(),
        }
    }
}

/// [`Pair8`] sixteen wide: the same constants, each by the same operations.
#[derive(Clone, Copy)]
pub(super) struct Pair16 {
    pub(super) friction: F16,
    pub(super) m_eff: F16,
    pub(super) eta: F16,
    pub(super) half_eta: F16,
    /// `1 / (m_eff + eta dt / 2)`.
    pub(super) per_mass: F16,
    /// Steps too long for the in-step normal law (the explicit law's lanes).
    pub(super) explicit: M16,
    pub(super) k: F16,
    pub(super) kt: F16,
    pub(super) eta_t: F16,
}

impl Pair16 {
    /// [`Pair8::of`] on sixteen lanes.
    #[inline(always)]
    pub(super) fn of(
        stiffness: F16,
        damping_factor: F16,
        friction: F16,
        m_eff: F16,
        dt: f32,
    ) -> Pair16 {
        pair_constants!(F16, Pair16; stiffness, damping_factor, friction, m_eff, dt)
    }

    /// The same constants in both halves (a uniform world's, computed once a chunk).
    #[inline(always)]
    pub(super) fn twice(p: &Pair8) -> Pair16 {
        let j = |v: F8| F16::join(v, v);
        Pair16 {
            k: j(p.k),
            friction: j(p.friction),
            m_eff: j(p.m_eff),
            eta: j(p.eta),
            half_eta: j(p.half_eta),
            per_mass: j(p.per_mass),
            explicit: M16::join(p.explicit, p.explicit),
            kt: j(p.kt),
            eta_t: j(p.eta_t),
        }
    }
}

/// [`Law8`] sixteen wide.
pub(super) struct Law16 {
    pub(super) f: W3,
    pub(super) fn_: F16,
    pub(super) xi: W3,
    pub(super) cov_after: F16,
    pub(super) h: W3,
    pub(super) cov: F16,
    pub(super) scalar: M16,
    pub(super) done: M16,
}

impl Law16 {
    /// Lanes 0 to 7 (`H = 0`) or 8 to 15 (`H = 1`), for [`super::law_lanes::store`].
    #[inline(always)]
    pub(super) fn half<const H: i32>(&self) -> Law8 {
        let m = |m: M16| {
            if H == 0 { m.half::<0>() } else { m.half::<1>() }
        };
        Law8 {
            f: self.f.half::<H>(),
            fn_: self.fn_.half::<H>(),
            xi: self.xi.half::<H>(),
            cov_after: self.cov_after.half::<H>(),
            h: self.h.half::<H>(),
            cov: self.cov.half::<H>(),
            scalar: m(self.scalar),
            done: m(self.done),
        }
    }
}

/// [`super::law_lanes::law`] on sixteen contacts (`n`, `depth`, `vrel`, the pairs'
/// constants `p`; `touch` the lanes that touch), with their springs `hist` and coverages
/// `coverage` as stored; nothing is written. The same operations in the same order, lane
/// for lane (see the module docs); the lanes left to the scalar code the same.
///
/// # Safety
/// AVX-512 (`avx512f`, `avx512dq`, `avx512vl`).
#[inline(always)]
pub(super) unsafe fn law16(
    (n, depth, vrel): (W3, F16, W3),
    p: &Pair16,
    touch: M16,
    dt: f32,
    hist: &[Vec3; 16],
    coverage: &[f32; 16],
) -> Law16 {
    // SAFETY: 16 `f32`s.
    let cov = F16(unsafe { _mm512_loadu_ps(coverage.as_ptr()) });
    let (lo, hi) = (
        <&[Vec3; 8]>::try_from(&hist[..8]).expect("8"),
        <&[Vec3; 8]>::try_from(&hist[8..]).expect("8"),
    );
    // SAFETY: AVX2 (implied by AVX-512F).
    let h = unsafe { W3::join(load_vec3(lo), load_vec3(hi)) };
    lane_law!(F16, W3, Law16; n, depth, vrel, p, touch, touch.and_not(touch), dt, cov, h)
}
