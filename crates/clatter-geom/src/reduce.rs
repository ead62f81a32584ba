//! Contact-patch reduction to at most four points, shared by the simulator's narrow phase
//! (f32, [`Vec3`]) and the query API (f64, [`DVec3`]); the WGSL twin is `nrw_reduce`.

use std::cmp::Ordering;
use std::ops::{Mul, Neg, Sub};

use glam::{DVec3, Vec3, Vec3A};

/// The vector and scalar operations of [`reduce`], implemented for glam's `Vec3` and `DVec3`
/// by their own methods (so the f32 results are those of the original f32-only code).
pub(crate) trait PatchVec: Copy + Sub<Output = Self> {
    type S: Copy + Neg<Output = Self::S> + Mul<Output = Self::S>;
    fn dot(self, o: Self) -> Self::S;
    fn cross(self, o: Self) -> Self;
    fn length_squared(self) -> Self::S;
    fn total_cmp(a: &Self::S, b: &Self::S) -> Ordering;
    fn abs(s: Self::S) -> Self::S;
    fn signum(s: Self::S) -> Self::S;
    fn max(a: Self::S, b: Self::S) -> Self::S;
}

macro_rules! patch_vec {
    ($v:ty, $s:ty) => {
        impl PatchVec for $v {
            type S = $s;
            #[inline]
            fn dot(self, o: Self) -> $s {
                <$v>::dot(self, o)
            }
            #[inline]
            fn cross(self, o: Self) -> Self {
                <$v>::cross(self, o)
            }
            #[inline]
            fn length_squared(self) -> $s {
                <$v>::length_squared(self)
            }
            #[inline]
            fn total_cmp(a: &$s, b: &$s) -> Ordering {
                a.total_cmp(b)
            }
            #[inline]
            fn abs(s: $s) -> $s {
                s.abs()
            }
            #[inline]
            fn signum(s: $s) -> $s {
                s.signum()
            }
            #[inline]
            fn max(a: $s, b: $s) -> $s {
                a.max(b)
            }
        }
    };
}

patch_vec!(Vec3, f32);
patch_vec!(DVec3, f64);
// The face clip's points (`narrow::clip`): glam's `Vec3A` gives `Vec3`'s floats (lane-wise
// arithmetic; the dot product in `Vec3`'s order; the cross product's lanes the same
// products, multiplication commuting), so the same keys, candidates and ties.
patch_vec!(Vec3A, f32);

/// Which points of a contact patch `(point, depth)` to keep, and how many (at most four):
/// all of them when there are four or fewer, else the deepest, the one furthest from it, the
/// one making the largest triangle with those two, then the one furthest outside that
/// triangle (so the patch's support polygon is kept). Ties go to the last candidate (Rust's
/// `max_by`); consecutive repeats of an index are dropped (`Vec::dedup`).
pub(crate) fn reduce<V: PatchVec>(pts: &[(V, V::S)], normal: V) -> ([usize; 4], usize) {
    if pts.len() <= 4 {
        return ([0, 1, 2, 3], pts.len());
    }
    let a = last_max::<V>(0..pts.len(), |i| pts[i].1).unwrap_or(0);
    let pa = pts[a].0;
    let b = last_max::<V>(0..pts.len(), |i| (pts[i].0 - pa).length_squared()).unwrap_or(0);
    let pb = pts[b].0;
    let area = |p: V, q: V, r: V| (q - p).cross(r - p).dot(normal);
    let c = last_max::<V>(0..pts.len(), |i| V::abs(area(pa, pb, pts[i].0))).unwrap_or(0);
    let pc = pts[c].0;
    let sign = V::signum(area(pa, pb, pc));
    let gain = |p: V| {
        V::max(
            V::max(-sign * area(pa, pb, p), -sign * area(pb, pc, p)),
            -sign * area(pc, pa, p),
        )
    };
    let d = last_max::<V>(
        (0..pts.len()).filter(|&i| i != a && i != b && i != c),
        |i| gain(pts[i].0),
    );
    let mut idx = [a; 4];
    let mut n = 1;
    for i in [Some(b), Some(c), d].into_iter().flatten() {
        if i != idx[n - 1] {
            idx[n] = i;
            n += 1;
        }
    }
    (idx, n)
}

/// The index of `indices` whose `key` is largest by `total_cmp`, the last of equals: what
/// `indices.max_by(|&i, &j| total_cmp(&key(i), &key(j)))` returns, with each key computed
/// once instead of once per comparison side (the same pure expression, so the same keys).
#[inline(always)]
fn last_max<V: PatchVec>(
    mut indices: impl Iterator<Item = usize>,
    key: impl Fn(usize) -> V::S,
) -> Option<usize> {
    let mut best = indices.next()?;
    let mut best_key = key(best);
    for i in indices {
        let k = key(i);
        // `max_by` keeps the later element unless the earlier compares greater.
        if V::total_cmp(&best_key, &k) != Ordering::Greater {
            best = i;
            best_key = k;
        }
    }
    Some(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The narrow phase's f32 reduction before it was shared, kept as the reference.
    fn reference(pts: &[(Vec3, f32)], normal: Vec3) -> Vec<usize> {
        if pts.len() <= 4 {
            return (0..pts.len()).collect();
        }
        let a = (0..pts.len())
            .max_by(|&i, &j| pts[i].1.total_cmp(&pts[j].1))
            .unwrap_or(0);
        let pa = pts[a].0;
        let b = (0..pts.len())
            .max_by(|&i, &j| {
                (pts[i].0 - pa)
                    .length_squared()
                    .total_cmp(&(pts[j].0 - pa).length_squared())
            })
            .unwrap_or(0);
        let pb = pts[b].0;
        let area = |p: Vec3, q: Vec3, r: Vec3| (q - p).cross(r - p).dot(normal);
        let c = (0..pts.len())
            .max_by(|&i, &j| {
                area(pa, pb, pts[i].0)
                    .abs()
                    .total_cmp(&area(pa, pb, pts[j].0).abs())
            })
            .unwrap_or(0);
        let pc = pts[c].0;
        let sign = area(pa, pb, pc).signum();
        let gain = |p: Vec3| {
            (-sign * area(pa, pb, p))
                .max(-sign * area(pb, pc, p))
                .max(-sign * area(pc, pa, p))
        };
        let d = (0..pts.len())
            .filter(|&i| i != a && i != b && i != c)
            .max_by(|&i, &j| gain(pts[i].0).total_cmp(&gain(pts[j].0)));
        let mut idx = vec![a, b, c];
        if let Some(d) = d {
            idx.push(d);
        }
        idx.dedup();
        idx
    }

    #[test]
    fn f32_matches_the_reference() {
        let mut r = ChaCha8Rng::seed_from_u64(7);
        for case in 0..20_000 {
            let n = r.random_range(1..20usize);
            // Coarse values give ties, repeats and collinear points.
            let coarse = case % 3 == 0;
            let v = |r: &mut ChaCha8Rng| {
                if coarse {
                    r.random_range(-2..=2) as f32 * 0.5
                } else {
                    r.random_range(-1.0f32..1.0)
                }
            };
            let normal = Vec3::new(v(&mut r), v(&mut r), 1.0).normalize();
            let pts: Vec<(Vec3, f32)> = (0..n)
                .map(|_| {
                    let p = Vec3::new(v(&mut r), v(&mut r), v(&mut r) * 0.01);
                    (p, v(&mut r).abs())
                })
                .collect();
            let (idx, count) = reduce(&pts, normal);
            assert_eq!(
                idx[..count],
                reference(&pts, normal)[..],
                "case {case}: {pts:?}"
            );
        }
    }

    /// The reduction of `Vec3A` points (the face clip's fixed buffers) chooses what that of
    /// the same `Vec3` points chooses, on patches of 5 to 19 points (the clip's largest)
    /// whose coordinates are below `1e18` in magnitude (where the clip uses it: no overflow,
    /// no NaN): coarse coordinates (ties, repeats, collinear points), zeros of either sign,
    /// fine ones, large (`1e17`) and tiny ones.
    #[test]
    fn vec3a_chooses_as_vec3() {
        let mut r = ChaCha8Rng::seed_from_u64(32);
        let odd = [0.0, -0.0, 1e17, -1e17, -1e-30, 1e-30];
        let mut ties = 0;
        for case in 0..40_000 {
            let n = r.random_range(5..20usize);
            let coarse = case % 3 == 0;
            let v = |r: &mut ChaCha8Rng| {
                if case % 50 == 0 && r.random_range(0..8) == 0 {
                    odd[r.random_range(0..odd.len())]
                } else if coarse {
                    r.random_range(-2..=2) as f32 * 0.5
                } else {
                    r.random_range(-1.0f32..1.0)
                }
            };
            let normal = Vec3::new(v(&mut r), v(&mut r), 1.0).normalize();
            let pts: Vec<(Vec3, f32)> = (0..n)
                .map(|_| {
                    let p = Vec3::new(v(&mut r), v(&mut r), v(&mut r) * 0.01);
                    (p, v(&mut r).abs())
                })
                .collect();
            let wide: Vec<(Vec3A, f32)> = pts.iter().map(|&(p, d)| (p.into(), d)).collect();
            let want = reduce(&pts, normal);
            assert_eq!(reduce(&wide, normal.into()), want, "case {case}: {pts:?}");
            // Patches whose deepest point is tied (the last of equals must win both ways).
            let deepest = pts.iter().map(|p| p.1).fold(f32::NEG_INFINITY, f32::max);
            ties += (pts.iter().filter(|p| p.1 == deepest).count() > 1) as usize;
        }
        assert!(ties > 100, "{ties}");
    }
}
