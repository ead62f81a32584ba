//! Exact sums of `f64`s ([`ExactSum`]): the sum of any multiset of values, rounded once to
//! the nearest `f64`, whatever the order they were added in and however they were split
//! between partial sums. The blow-up checks sum the bodies' energies this way, so that ranks
//! that each sum their own bodies and add the partial sums (integers, reduced exactly) find
//! bitwise the total one process finds: a plain `f64` sum depends on its order.
//!
//! A finite `f64` is an integer mantissa (53 bits) times a power of two between `2^-1074`
//! and `2^971`, so every finite value is an integer multiple of `2^-1074` below `2^1024`: the
//! sum keeps that integer in 32-bit limbs held in `i64`s (a fixed-point superaccumulator,
//! 2,176 bits), adds each value's mantissa into the (at most) three limbs it spans, and
//! counts NaNs and infinities apart. Adding is a few integer operations per value; the
//! rounding to `f64` ([`ExactSum::value`]) is done once.

/// Bits per limb.
const LIMB_BITS: u32 = 32;
/// Limbs: 2,046 bit positions of a finite `f64` (`2^-1074` to `2^971`), 53 bits of
/// mantissa, and room for the carries of 2^31 ranks' sums of 2^31 values each.
pub const LIMBS: usize = 68;
/// Values added between two carry propagations: each limb then stays far from `i64`'s range.
const ADDS_BEFORE_CARRY: u32 = 1 << 30;
/// Indices per parallel piece of [`ExactSum::par_sums`]: a merge (about 70 limbs) is cheap
/// beside this many adds.
const PAR_MIN: usize = 512;

/// An exact sum of `f64`s (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExactSum {
    /// The sum of the finite values in units of `2^-1074`, little-endian in base `2^32`.
    limbs: [i64; LIMBS],
    /// Values added since the carries were last propagated.
    adds: u32,
    /// NaNs added.
    nan: u64,
    /// `+inf`s added.
    pos_inf: u64,
    /// `-inf`s added.
    neg_inf: u64,
}

impl Default for ExactSum {
    fn default() -> Self {
        ExactSum {
            limbs: [0; LIMBS],
            adds: 0,
            nan: 0,
            pos_inf: 0,
            neg_inf: 0,
        }
    }
}

impl ExactSum {
    /// Words of [`ExactSum::to_words`]: the limbs, then the NaN and infinity counts.
    pub const WORDS: usize = LIMBS + 3;

    /// The exact sum of `values`.
    pub fn of(values: impl IntoIterator<Item = f64>) -> ExactSum {
        let mut s = ExactSum::default();
        for x in values {
            s.add(x);
        }
        s
    }

    /// Adds `x`, exactly.
    pub fn add(&mut self, x: f64) {
        if !x.is_finite() {
            if x.is_nan() {
                self.nan += 1;
            } else if x > 0.0 {
                self.pos_inf += 1;
            } else {
                self.neg_inf += 1;
            }
            return;
        }
        if x == 0.0 {
            return;
        }
        let bits = x.to_bits();
        let biased = ((bits >> 52) & 0x7ff) as u32;
        let fraction = bits & ((1u64 << 52) - 1);
        // x = mantissa * 2^(at - 1074), at >= 0.
        let (mantissa, at) = if biased == 0 {
            (fraction, 0)
        } else {
            (fraction | (1u64 << 52), biased - 1)
        };
        let (k, shift) = ((at / LIMB_BITS) as usize, at % LIMB_BITS);
        let v = (mantissa as u128) << shift;
        let sign = if x < 0.0 { -1 } else { 1 };
        for (j, limb) in self.limbs[k..k + 3].iter_mut().enumerate() {
            *limb += sign * ((v >> (LIMB_BITS * j as u32)) as u64 & 0xffff_ffff) as i64;
        }
        self.adds += 1;
        if self.adds >= ADDS_BEFORE_CARRY {
            self.carry();
        }
    }

    /// The exact sums of `K` terms of each index `0..n`, `terms(i)` (a zero adds nothing),
    /// computed in parallel over chunks of indices and merged: bitwise the sums of adding
    /// them one by one, since an exact sum does not depend on order or grouping. The energy
    /// samples and blow-up checks run this between steps, where a serial loop over the
    /// bodies would leave all but one thread idle.
    pub fn par_sums<const K: usize>(
        n: usize,
        terms: impl Fn(usize) -> [f64; K] + Sync,
    ) -> [ExactSum; K] {
        use rayon::prelude::*;
        let zero = || std::array::from_fn(|_| ExactSum::default());
        // One accumulator per piece of `PAR_MIN` indices, added to in place (a `fold` would
        // move its `K` sums of ~570 bytes through every index).
        (0..n.div_ceil(PAR_MIN))
            .into_par_iter()
            .map(|piece| {
                let mut s: [ExactSum; K] = zero();
                for i in piece * PAR_MIN..n.min((piece + 1) * PAR_MIN) {
                    for (s, x) in s.iter_mut().zip(terms(i)) {
                        s.add(x);
                    }
                }
                s
            })
            .reduce(zero, |mut a, b| {
                for (a, b) in a.iter_mut().zip(&b) {
                    a.merge(b);
                }
                a
            })
    }

    /// Adds every value `other` holds: the sum of the union.
    pub fn merge(&mut self, other: &ExactSum) {
        self.carry();
        let mut o = other.clone();
        o.carry();
        for (a, b) in self.limbs.iter_mut().zip(o.limbs) {
            *a += b;
        }
        self.nan += o.nan;
        self.pos_inf += o.pos_inf;
        self.neg_inf += o.neg_inf;
        self.carry();
    }

    /// Propagates the carries: every limb but the top one in `[0, 2^32)`, the top one signed.
    fn carry(&mut self) {
        for k in 0..LIMBS - 1 {
            let c = self.limbs[k] >> LIMB_BITS;
            self.limbs[k] -= c << LIMB_BITS;
            self.limbs[k + 1] += c;
        }
        self.adds = 0;
    }

    /// The sum as words to be added element-wise (wrapping, as an MPI sum of unsigned
    /// integers adds them) with other ranks' words: the carried limbs, then the counts of
    /// NaNs, `+inf`s and `-inf`s. The element-wise sum of any ranks' words, read back by
    /// [`ExactSum::from_words`], is the sum of all their values (up to 2^31 ranks).
    pub fn to_words(&self) -> Vec<u64> {
        let mut s = self.clone();
        s.carry();
        let mut w: Vec<u64> = s.limbs.iter().map(|&l| l as u64).collect();
        w.extend([s.nan, s.pos_inf, s.neg_inf]);
        w
    }

    /// The sum whose words ([`ExactSum::to_words`], or the element-wise sum of several
    /// ranks') are `words`; `None` when there are not [`ExactSum::WORDS`] of them.
    pub fn from_words(words: &[u64]) -> Option<ExactSum> {
        if words.len() != Self::WORDS {
            return None;
        }
        let mut s = ExactSum::default();
        for (l, &w) in s.limbs.iter_mut().zip(words) {
            *l = w as i64;
        }
        (s.nan, s.pos_inf, s.neg_inf) = (words[LIMBS], words[LIMBS + 1], words[LIMBS + 2]);
        s.carry();
        Some(s)
    }

    /// The sum rounded to the nearest `f64` (ties to even), as IEEE addition rounds the sum
    /// of two values: NaN if a NaN or both infinities were added, an infinity if one was
    /// (or the sum is beyond `f64`'s range), else the correctly rounded finite sum.
    pub fn value(&self) -> f64 {
        if self.nan > 0 || (self.pos_inf > 0 && self.neg_inf > 0) {
            return f64::NAN;
        }
        if self.pos_inf > 0 {
            return f64::INFINITY;
        }
        if self.neg_inf > 0 {
            return f64::NEG_INFINITY;
        }
        let mut s = self.clone();
        s.carry();
        let negative = s.limbs[LIMBS - 1] < 0;
        if negative {
            for l in s.limbs.iter_mut() {
                *l = -*l;
            }
            s.carry();
        }
        let Some(h) = s.limbs.iter().rposition(|&l| l != 0) else {
            return 0.0;
        };
        // The top four limbs (128 bits) and whether anything below them is set.
        let limb = |k: isize| {
            if k < 0 {
                0u128
            } else {
                s.limbs[k as usize] as u128
            }
        };
        let h = h as isize;
        let acc = (limb(h) << 96) | (limb(h - 1) << 64) | (limb(h - 2) << 32) | limb(h - 3);
        let sticky = h > 3 && s.limbs[..(h - 3) as usize].iter().any(|&l| l != 0);
        // acc * 2^scale, scale the exponent of acc's lowest bit.
        let scale = LIMB_BITS as i64 * (h as i64 - 3) - 1074;
        let top = 127 - acc.leading_zeros() as i64 + scale;
        let low = (top - 52).max(-1074);
        let drop = (low - scale) as u32;
        let mut mantissa = if drop >= 128 { 0 } else { acc >> drop };
        if drop > 0 {
            let rest = acc & ((1u128 << drop) - 1);
            let half = 1u128 << (drop - 1);
            if rest > half || (rest == half && (sticky || mantissa & 1 == 1)) {
                mantissa += 1;
            }
        }
        let magnitude = mantissa as f64 * pow2(low);
        if negative { -magnitude } else { magnitude }
    }
}

/// `2^e` for `e` in `-1074..`: infinity above `f64`'s range.
fn pow2(e: i64) -> f64 {
    if e > 1023 {
        f64::INFINITY
    } else if e >= -1022 {
        f64::from_bits(((e + 1023) as u64) << 52)
    } else {
        f64::from_bits(1u64 << (e + 1074))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator of `f64`s over many binades, both signs.
    fn values(seed: u64, n: usize, spread: i32) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let m = (s >> 11) as f64 / (1u64 << 53) as f64;
                let e = ((s >> 3) % (2 * spread as u64 + 1)) as i32 - spread;
                let sign = if s & 1 == 0 { 1.0 } else { -1.0 };
                sign * m * 2f64.powi(e)
            })
            .collect()
    }

    #[test]
    fn two_values_round_as_ieee_addition() {
        // IEEE addition is the exact sum rounded to nearest, ties to even: an independent
        // truth for every pair, subnormals and huge values included.
        let mut xs = values(1, 400, 60);
        xs.extend(values(2, 200, 1000));
        xs.extend([
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            f64::MAX,
            -f64::MAX,
            1.0,
            1.0 + f64::EPSILON,
            2f64.powi(53),
            -1.0,
        ]);
        for &a in &xs {
            for &b in xs.iter().step_by(7) {
                let got = ExactSum::of([a, b]).value();
                let want = a + b;
                assert!(
                    got == want && (want != 0.0 || got.is_sign_positive()),
                    "{a:e} + {b:e}: {got:e} against {want:e}"
                );
            }
        }
    }

    #[test]
    fn parallel_sums_are_the_serial_ones_bit_for_bit() {
        // Against adding one by one, for lengths around the parallel pieces' size, with huge
        // cancelling terms (order-sensitive in f64), zeros, NaNs and infinities, and in a
        // pool of 3 threads so the pieces really are split and merged.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .expect("a pool of 3 threads");
        let mut xs = values(7, 5000, 400);
        xs[100] = 1e300;
        xs[4000] = -1e300;
        xs[2500] = 0.0;
        for n in [
            0,
            1,
            PAR_MIN - 1,
            PAR_MIN,
            PAR_MIN + 1,
            3 * PAR_MIN + 5,
            5000,
        ] {
            let (a, b) = (&xs[..n], &xs[xs.len() - n..]);
            let [sa, sb] = pool.install(|| ExactSum::par_sums(n, |i| [a[i], -b[i] * 3.0]));
            let want_a = ExactSum::of(a.iter().copied()).value();
            let want_b = ExactSum::of(b.iter().map(|x| -x * 3.0)).value();
            assert_eq!(sa.value().to_bits(), want_a.to_bits(), "n = {n}");
            assert_eq!(sb.value().to_bits(), want_b.to_bits(), "n = {n}");
        }
        let mut ys = values(8, 3000, 20);
        ys[17] = f64::NAN;
        ys[2999] = f64::INFINITY;
        let [s] = pool.install(|| ExactSum::par_sums(ys.len(), |i| [ys[i]]));
        assert!(s.value().is_nan());
        ys[17] = 1.0;
        let [s] = pool.install(|| ExactSum::par_sums(ys.len(), |i| [ys[i]]));
        assert_eq!(s.value(), f64::INFINITY);
    }

    #[test]
    fn ties_and_cancellation_are_exact() {
        // 1 + 2^-53 is a tie (to even: 1); with 2^-105 more it rounds up.
        let e = 2f64.powi(-53);
        assert_eq!(ExactSum::of([1.0, e]).value(), 1.0);
        assert_eq!(
            ExactSum::of([1.0, e, 2f64.powi(-105)]).value(),
            1.0 + 2.0 * e
        );
        // Cancellation leaves the small terms, which a running f64 sum loses.
        let xs = [1e300, 3.5, -1e300, 1e-300, 2f64.powi(-1074)];
        assert_eq!(ExactSum::of(xs).value(), 3.5);
        assert_eq!(ExactSum::of([1e300, 1e-300, -1e300]).value(), 1e-300);
        assert_eq!(ExactSum::of([f64::MAX, f64::MAX]).value(), f64::INFINITY);
        assert_eq!(
            ExactSum::of([f64::MAX, f64::MAX, -f64::MAX]).value(),
            f64::MAX
        );
        assert!(ExactSum::of([1.0, f64::NAN]).value().is_nan());
        assert!(
            ExactSum::of([f64::INFINITY, f64::NEG_INFINITY])
                .value()
                .is_nan()
        );
        assert_eq!(
            ExactSum::of([-1.0, f64::NEG_INFINITY]).value(),
            f64::NEG_INFINITY
        );
        assert_eq!(ExactSum::of([]).value(), 0.0);
        // Integers: the sum of 1..=n exactly, as long as it fits 53 bits.
        let n = 1_000_000u64;
        assert_eq!(
            ExactSum::of((1..=n).map(|i| i as f64)).value(),
            (n * (n + 1) / 2) as f64
        );
    }

    #[test]
    fn order_and_split_do_not_matter() {
        let xs = values(3, 5000, 80);
        let whole = ExactSum::of(xs.iter().copied()).value();
        let mut reversed = xs.clone();
        reversed.reverse();
        assert_eq!(ExactSum::of(reversed).value().to_bits(), whole.to_bits());
        // Split among "ranks", reduced as words with wrapping sums (as MPI would).
        for ranks in [2, 3, 7] {
            let mut words = vec![0u64; ExactSum::WORDS];
            for r in 0..ranks {
                let part = ExactSum::of(xs.iter().skip(r).step_by(ranks).copied());
                for (w, p) in words.iter_mut().zip(part.to_words()) {
                    *w = w.wrapping_add(p);
                }
            }
            let got = ExactSum::from_words(&words).map(|s| s.value());
            assert_eq!(
                got.map(f64::to_bits),
                Some(whole.to_bits()),
                "{ranks} ranks"
            );
            let mut merged = ExactSum::default();
            for r in 0..ranks {
                merged.merge(&ExactSum::of(xs.iter().skip(r).step_by(ranks).copied()));
            }
            assert_eq!(merged.value().to_bits(), whole.to_bits());
        }
        assert_eq!(ExactSum::from_words(&[0; 3]), None);
    }
}
