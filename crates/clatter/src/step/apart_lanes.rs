//! The polyhedron pair loop's first pass (`contacts::skip_apart`) eight pairs at a time,
//! one pair per lane of an AVX2 register: the contact-hint test, the separation bound's
//! test and its subtraction `bound - (moved_i + moved_j)` (the bodies' `BodyBound::moved`
//! read by a gather), the same IEEE operations lane for lane as the scalar test, so the
//! same bounds and the same choice of pairs skipped. About two thirds of a settled pile's
//! list stops here every step; body by body each cost ~25 instructions.

use std::arch::x86_64::*;

use super::FINE_CHUNK;
use super::motion::BodyBound;
use clatter_geom::narrow::{HINT_CONTACT, NO_HINT, SatHint};

/// The first pass over a chunk's pairs `p` (with their hints `hn`, bounds `b` and touching
/// flags `t`, all of one length, at most [`FINE_CHUNK`]): each pair that
/// `contacts::skip_apart` skips has its bound lowered as there; the others' places in the
/// chunk go to `rest` in order. Returns how many went to `rest` and how many of the
/// skipped pairs touch (as the scalar pass counts them). Groups of eight in lanes, the last
/// `len % 8` pairs by the scalar test; all by the scalar test where a body index is not
/// below `bounds.len()` (which then panics there, as before) or `bounds` has 2^28 bodies
/// or more (the gather's `i32` offsets).
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn skip_pass(
    bounds: &[BodyBound],
    p: &[[u32; 2]],
    hn: &[SatHint],
    b: &mut [f32],
    t: &[bool],
    rest: &mut [u8; FINE_CHUNK],
) -> (usize, usize) {
    let n = p.len();
    assert!(n <= FINE_CHUNK && hn.len() == n && b.len() == n && t.len() == n);
    let (mut kept, mut touching) = (0usize, 0usize);
    let mut scalar_from = 0;
    if bounds.len() < 1 << 28 {
        let groups = n / 8;
        let limit = _mm256_set1_epi32(bounds.len() as i32);
        for g in 0..groups {
            let r = 8 * g..8 * g + 8;
            // SAFETY: AVX2 (the caller's); arrays of eight.
            let skipped = unsafe {
                eight(
                    bounds,
                    limit,
                    p[r.clone()].try_into().unwrap(),
                    hn[r.clone()].try_into().unwrap(),
                    (&mut b[r.clone()]).try_into().unwrap(),
                )
            };
            let Some(skipped) = skipped else {
                // An index out of range: this group and the rest by the scalar test.
                scalar_from = 8 * g;
                break;
            };
            touching += (flags(t[r].try_into().unwrap()) & skipped).count_ones() as usize;
            // The group's pairs left, in order, as eight bytes at `rest[kept..]` (those past
            // the count are overwritten later or not read): `kept <= 8 g`, so the eight
            // bytes end by `8 g + 8 <= n`.
            let left = !skipped & 0xff;
            let places = PLACES[left as usize] + 0x0101_0101_0101_0101 * (8 * g) as u64;
            rest[kept..kept + 8].copy_from_slice(&places.to_le_bytes());
            kept += left.count_ones() as usize;
            scalar_from = 8 * g + 8;
        }
    }
    for k in scalar_from..n {
        if super::contacts::skip_apart_in(bounds, p[k], hn[k], &mut b[k]) {
            touching += t[k] as usize;
        } else {
            rest[kept] = k as u8;
            kept += 1;
        }
    }
    (kept, touching)
}

/// Per set of eight lanes (bit l for lane l), the lanes in that set in ascending order as
/// the bytes of a word from its lowest (the rest zero): the places a group's pairs left
/// take, less the group's first place.
static PLACES: [u64; 256] = {
    let mut t = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let (mut l, mut at) = (0, 0);
        while l < 8 {
            if m >> l & 1 != 0 {
                t[m] |= (l as u64) << (8 * at);
                at += 1;
            }
            l += 1;
        }
        m += 1;
    }
    t
};

/// Eight touching flags as the bits of a byte (lane l in bit l).
#[inline]
#[target_feature(enable = "avx2")]
fn flags(t: &[bool; 8]) -> u32 {
    // SAFETY: eight bytes, each 0 or 1 (`bool`).
    let bytes = unsafe { _mm_loadl_epi64(t.as_ptr() as *const __m128i) };
    let zero = _mm_movemask_epi8(_mm_cmpeq_epi8(bytes, _mm_setzero_si128())) as u32;
    !zero & 0xff
}

/// `contacts::skip_apart` for eight pairs: the bits of those skipped (their bounds
/// lowered; the others' left as they were), or `None` (nothing written) where a body
/// index is not below `limit` (the bounds' length, below 2^28).
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn eight(
    bounds: &[BodyBound],
    limit: __m256i,
    p: &[[u32; 2]; 8],
    hn: &[SatHint; 8],
    b: &mut [f32; 8],
) -> Option<u32> {
    // SAFETY (loads): 16 `u32`s of pairs, 8 hints, 8 bounds.
    let (p0, p1, hint, bound) = unsafe {
        (
            _mm256_loadu_si256(p.as_ptr() as *const __m256i),
            _mm256_loadu_si256(p.as_ptr().add(4) as *const __m256i),
            _mm256_loadu_si256(hn.as_ptr() as *const __m256i),
            _mm256_loadu_ps(b.as_ptr()),
        )
    };
    // (i0 j0 i1 j1 ..) to (i0 i1 i2 i3 j0 j1 j2 j3), then the i's and j's of both halves.
    let evens = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    let (q0, q1) = (
        _mm256_permutevar8x32_epi32(p0, evens),
        _mm256_permutevar8x32_epi32(p1, evens),
    );
    let i = _mm256_permute2x128_si256::<0x20>(q0, q1);
    let j = _mm256_permute2x128_si256::<0x31>(q0, q1);
    // Every index below `limit` (as unsigned: `min(x, limit - 1) == x`).
    let last = _mm256_sub_epi32(limit, _mm256_set1_epi32(1));
    let inside = _mm256_and_si256(
        _mm256_cmpeq_epi32(_mm256_min_epu32(i, last), i),
        _mm256_cmpeq_epi32(_mm256_min_epu32(j, last), j),
    );
    if _mm256_movemask_epi8(inside) != -1 {
        return None;
    }
    // `is_contact_hint`: a face hint with the contact bit (bits 31 and 29: `01`), or kind
    // `11` (the top three bits set) other than `NO_HINT`.
    let face = _mm256_cmpeq_epi32(
        _mm256_and_si256(hint, _mm256_set1_epi32((1u32 << 31 | HINT_CONTACT) as i32)),
        _mm256_set1_epi32(HINT_CONTACT as i32),
    );
    let top = _mm256_and_si256(
        _mm256_cmpeq_epi32(_mm256_srli_epi32::<29>(hint), _mm256_set1_epi32(7)),
        _mm256_xor_si256(
            _mm256_cmpeq_epi32(hint, _mm256_set1_epi32(NO_HINT as i32)),
            _mm256_set1_epi32(-1),
        ),
    );
    let contact = _mm256_castsi256_ps(_mm256_or_si256(face, top));
    // `moved` of each body: word `WORD` of its record (records of eight words, 32 bytes).
    const WORD: i32 = (std::mem::offset_of!(BodyBound, moved) / 4) as i32;
    const _: () = assert!(std::mem::size_of::<BodyBound>() == 32 && WORD < 8);
    let base = bounds.as_ptr() as *const f32;
    let at = |x: __m256i| _mm256_add_epi32(_mm256_slli_epi32::<3>(x), _mm256_set1_epi32(WORD));
    // SAFETY: every index is below `bounds.len()` (tested above), below 2^28 (the caller's),
    // so each offset `8 x + WORD` (in `f32`s) is an `i32` and reads that record's `moved`.
    let (mi, mj) = unsafe {
        (
            _mm256_i32gather_ps::<4>(base, at(i)),
            _mm256_i32gather_ps::<4>(base, at(j)),
        )
    };
    // `left = bound - (moved_i + moved_j)`; skipped where no contact hint, `bound > 0` and
    // `left > 0` (ordered: a NaN is not skipped).
    let left = _mm256_sub_ps(bound, _mm256_add_ps(mi, mj));
    let zero = _mm256_setzero_ps();
    let skip = _mm256_andnot_ps(
        contact,
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(bound, zero),
            _mm256_cmp_ps::<_CMP_GT_OQ>(left, zero),
        ),
    );
    // SAFETY: eight `f32`s; only the skipped lanes are written.
    unsafe { _mm256_maskstore_ps(b.as_mut_ptr(), _mm256_castps_si256(skip), left) };
    Some(_mm256_movemask_ps(skip) as u32)
}

#[cfg(test)]
mod tests {
    use super::super::FINE_CHUNK;
    use super::super::contacts::skip_apart_in;
    use super::super::motion::BodyBound;
    use clatter_geom::narrow::{HINT_CONTACT, HINT_EDGE_CONTACT, NO_HINT, SatHint};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The lanes' pass against the scalar test pair by pair (`skip_apart_in` over the chunk
    /// in order, as the pair loop ran it before): every bound's bits, the pairs left (in
    /// order) and the count of skipped pairs touching, on chunks of every length up to
    /// [`FINE_CHUNK`] (groups of eight and tails), with hints of every kind (faces with and
    /// without the contact bit, edges, kind `11` with and without it, `NO_HINT`), bounds
    /// positive, `+-0`, negative, NaN and infinite, and motions that leave a bound just
    /// above, at and below zero, NaN and infinite. Not vacuous: pairs are skipped, kept for
    /// their hint, their bound and their motion.
    #[test]
    fn the_lanes_skip_the_pairs_the_scalar_test_skips() {
        if !crate::step::avx2() {
            eprintln!("no AVX2 here: nothing to compare");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(38);
        let hints: [SatHint; 9] = [
            0,
            5,
            HINT_CONTACT | 3,
            1 << 30 | 7,
            1 << 30 | HINT_CONTACT | 2,
            1 << 31 | 9,
            0xe000_0000 | 4,
            HINT_EDGE_CONTACT,
            NO_HINT,
        ];
        let (mut skipped, mut kept) = (0usize, 0usize);
        for case in 0..3000 {
            let bodies = rng.random_range(1..40usize);
            let bounds: Vec<BodyBound> = (0..bodies)
                .map(|_| BodyBound {
                    moved: match rng.random_range(0..12) {
                        0 => f32::NAN,
                        1 => f32::INFINITY,
                        2 => 0.0,
                        _ => rng.random_range(0.0..1e-3),
                    },
                    ..Default::default()
                })
                .collect();
            let n = case % (FINE_CHUNK + 1);
            let p: Vec<[u32; 2]> = (0..n)
                .map(|_| {
                    let i = rng.random_range(0..bodies as u32);
                    [i, rng.random_range(0..bodies as u32)]
                })
                .collect();
            let hn: Vec<SatHint> = (0..n)
                .map(|_| hints[rng.random_range(0..hints.len())])
                .collect();
            let b: Vec<f32> = (0..n)
                .enumerate()
                .map(|(k, _)| {
                    let [i, j] = p[k];
                    let sum = bounds[i as usize].moved + bounds[j as usize].moved;
                    match rng.random_range(0..14) {
                        0 => f32::NAN,
                        1 => 0.0,
                        2 => -0.0,
                        3 => -1e-4,
                        4 => f32::INFINITY,
                        5 => sum,
                        6 => f32::from_bits(sum.to_bits() + 1),
                        _ => rng.random_range(0.0..2e-3),
                    }
                })
                .collect();
            let t: Vec<bool> = (0..n).map(|_| rng.random_bool(0.3)).collect();
            // The scalar pass.
            let mut want_b = b.clone();
            let (mut want_rest, mut want_touching) = (Vec::new(), 0usize);
            for k in 0..n {
                if skip_apart_in(&bounds, p[k], hn[k], &mut want_b[k]) {
                    want_touching += t[k] as usize;
                } else {
                    want_rest.push(k as u8);
                }
            }
            // The lanes'.
            let mut got_b = b.clone();
            let mut rest = [0u8; FINE_CHUNK];
            // SAFETY: the CPU has AVX2 (tested above).
            let (got_kept, got_touching) =
                unsafe { super::skip_pass(&bounds, &p, &hn, &mut got_b, &t, &mut rest) };
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got_b), bits(&want_b), "case {case}: bounds");
            assert_eq!(&rest[..got_kept], &want_rest[..], "case {case}: pairs left");
            assert_eq!(got_touching, want_touching, "case {case}: touching");
            skipped += n - want_rest.len();
            kept += want_rest.len();
        }
        assert!(skipped > 10_000 && kept > 10_000, "{skipped} {kept}");
    }

    /// A body index past the bounds is not read by a gather: the pass falls to the scalar
    /// test, which panics at the index as the pair loop did.
    #[test]
    #[should_panic]
    fn an_index_past_the_bounds_panics() {
        if !crate::step::avx2() {
            panic!("no AVX2 here: the scalar test's panic stands in");
        }
        let bounds = vec![BodyBound::default(); 4];
        let mut p = [[0u32, 1]; 8];
        p[5] = [2, 4];
        let mut b = [1.0f32; 8];
        let mut rest = [0u8; FINE_CHUNK];
        // SAFETY: the CPU has AVX2 (tested above).
        unsafe { super::skip_pass(&bounds, &p, &[0; 8], &mut b, &[false; 8], &mut rest) };
    }
}
