use super::{DeepPairs, EdgeMemory, GrownLevels, LEVELS, SERVED_LINES};
use crate::narrow::test_shapes::xorshift;
use std::mem::{align_of, offset_of, size_of, size_of_val};

/// The fields every search reads (the header and `levels`) lie in the first four cache
/// lines of a memory, and every memory of an array starts a line (see `EdgeMemory`):
/// each field's end, from its offset and its own size, against 256 bytes.
#[test]
fn a_memorys_searched_fields_lie_in_its_first_four_cache_lines() {
    let m = EdgeMemory::default();
    assert_eq!(align_of::<EdgeMemory>(), 64);
    let ends = [
        offset_of!(EdgeMemory, shapes) + size_of_val(&m.shapes),
        offset_of!(EdgeMemory, rot) + size_of_val(&m.rot),
        offset_of!(EdgeMemory, offset) + size_of_val(&m.offset),
        offset_of!(EdgeMemory, len) + size_of_val(&m.len),
        offset_of!(EdgeMemory, directions) + size_of_val(&m.directions),
        offset_of!(EdgeMemory, winner) + size_of_val(&m.winner),
        offset_of!(EdgeMemory, levels) + size_of_val(&m.levels),
    ];
    for end in ends {
        assert!(end <= 256, "a searched field ends at byte {end}");
    }
    // A Gauss-map memory's first pairs follow on the next line.
    assert!(offset_of!(EdgeMemory, pairs) < 256);
}

/// The cache lines the served paths read of a memory (what `EdgeMemory`'s comment says):
/// the anchor ([`super::Anchor`], read by a remembered face and a remembered edge alike)
/// within one line; the face's clip record starting a line, its plan's fields in that line
/// (`slack_tests`), so that a remembered face reads two lines of the memory (three when its
/// record's own certificate does not stand and the anchored one is read); the search by
/// direction's header in line 0, so that a remembered edge reads line 0, the anchor's line
/// and the lines of the levels it takes. The line of each, from the offsets.
#[test]
fn the_served_paths_read_few_lines_of_a_memory() {
    let m = EdgeMemory::default();
    let line = |at: usize| at / 64;
    let (anchor, face) = (offset_of!(EdgeMemory, anchor), offset_of!(EdgeMemory, face));
    let anchor_end = anchor + size_of_val(&m.anchor) - 1;
    assert_eq!(
        line(anchor),
        line(anchor_end),
        "the anchor, bytes {anchor}..={anchor_end}"
    );
    assert_eq!(face % 64, 0, "the clip record starts a line");
    assert_ne!(
        line(anchor),
        line(face),
        "the anchor and the record: two lines"
    );
    let header_end = offset_of!(EdgeMemory, winner) + size_of_val(&m.winner) - 1;
    assert_eq!(line(header_end), 0, "the header ends at byte {header_end}");
    assert_eq!(size_of::<EdgeMemory>() % 64, 0);
    eprintln!(
        "EdgeMemory {} bytes: levels {}, pairs {}, sphere {}, anchor {anchor} (line {}), face {face} (line {})",
        size_of::<EdgeMemory>(),
        offset_of!(EdgeMemory, levels),
        offset_of!(EdgeMemory, pairs),
        offset_of!(EdgeMemory, sphere),
        line(anchor),
        line(face),
    );
}

/// The lines [`EdgeMemory::prefetch`] asks for ([`SERVED_LINES`]) hold every byte the
/// served paths read of a memory, from the fields' own offsets and sizes: the header
/// (shapes, pose, kind, winner), the levels of codes 2 to 9 (those a settled pile's
/// searches take), the anchor whole and the face record's first line (its plan); and each
/// line is one of the memory's own, named once.
#[test]
fn prefetched_lines_hold_what_the_served_paths_read() {
    let m = EdgeMemory::default();
    let held =
        |at: usize, len: usize| (at / 64..=(at + len - 1) / 64).all(|l| SERVED_LINES.contains(&l));
    let mut read = vec![
        (offset_of!(EdgeMemory, shapes), size_of_val(&m.shapes)),
        (offset_of!(EdgeMemory, rot), size_of_val(&m.rot)),
        (offset_of!(EdgeMemory, offset), size_of_val(&m.offset)),
        (
            offset_of!(EdgeMemory, directions),
            size_of_val(&m.directions),
        ),
        (offset_of!(EdgeMemory, winner), size_of_val(&m.winner)),
        (offset_of!(EdgeMemory, anchor), size_of_val(&m.anchor)),
        (offset_of!(EdgeMemory, face), 64),
    ];
    for code in 2..=9 {
        read.push((offset_of!(EdgeMemory, levels) + 16 * (code - 1), 16));
    }
    for (at, len) in read {
        assert!(held(at, len), "bytes {at}..{} not prefetched", at + len);
    }
    for (i, line) in SERVED_LINES.iter().enumerate() {
        assert!(
            *line < size_of::<EdgeMemory>() / 64,
            "line {line} past the memory"
        );
        assert!(!SERVED_LINES[..i].contains(line), "line {line} twice");
    }
    // A hint only: the memory reads the same after it.
    let before = format!("{m:?}");
    m.prefetch();
    assert_eq!(format!("{m:?}"), before);
}

/// The level codes against the levels written out as `-r / 2^(c + 1)` in f64: the code
/// is the smallest (deepest level) whose level is still at or above the separation, so
/// the level bounds the separation from above as tightly as the levels allow.
#[test]
fn depth_codes_name_the_deepest_level_above_the_separation() {
    let level = |c: u8, r: f32| -(r as f64) / 2f64.powi(c as i32 + 1);
    for r in [0.02f32, 0.013, 1.0, 7.5] {
        let mut s = -2.0 * r;
        while s < 0.0 {
            let code = DeepPairs::code(s, r);
            // The smallest code whose level is at or above `s`, by scanning them all.
            let want = (1..=LEVELS).find(|&c| level(c, r) >= s as f64).unwrap_or(0);
            assert_eq!(code, want, "r {r}, s {s}");
            if code != 0 {
                assert!(DeepPairs::level(code, r) as f64 == level(code, r));
            }
            s += r * 1.37e-3;
        }
        assert_eq!(DeepPairs::code(f32::NAN, r), 0);
        assert_eq!(DeepPairs::code(0.0, r), 0);
    }
}

/// The bisection against the codes tested one by one (`code_by_steps`, the rule it
/// replaced), bitwise the same code: every level of many radii sums (0, subnormal,
/// tiny, usual, huge, infinite, NaN) and the floats next to it on both sides, and
/// random separations from far below the deepest level to above the shallowest.
#[test]
fn bisected_codes_are_the_codes_tested_one_by_one() {
    let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
    let mut radii = vec![
        0.0f32,
        f32::from_bits(1),
        1e-38,
        1e-30,
        0.013,
        0.02,
        1.0,
        7.5,
        3e38,
        f32::INFINITY,
        f32::NAN,
    ];
    for _ in 0..200 {
        radii.push(f32::from_bits((next() as u32) & 0x7fff_ffff));
    }
    let mut checked = 0;
    for &r in &radii {
        let mut ss = vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0];
        for c in 0..=LEVELS + 1 {
            let l = -(r * 2f32.powi(-(c as i32) - 1));
            ss.extend([l, l.next_up(), l.next_down()]);
        }
        for _ in 0..2000 {
            // Separations from about -4 r to r, spread over the levels' scales.
            let u = (next() >> 40) as f32 / (1u64 << 24) as f32;
            let scale = 2f32.powi(-((next() % 16) as i32));
            ss.push(r * (1.0 - 5.0 * u) * scale);
        }
        for &s in &ss {
            assert_eq!(
                DeepPairs::code(s, r),
                DeepPairs::code_by_steps(s, r),
                "s {s:e}, r {r:e}"
            );
            checked += 1;
        }
    }
    assert!(checked > 400_000);
}

/// [`GrownLevels::top`] against the loop it replaced ([`DeepPairs::top`], kept as the
/// oracle), bitwise the same code: every start code (0 to past the last), radii sums
/// and growths of every scale (0, subnormal, usual, huge, infinite, NaN, negative,
/// raw bit patterns), and floors at every grown level and the floats next to it, as
/// well as random ones.
#[test]
fn grown_levels_give_the_tops_of_the_loop_over_the_codes() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(34);
    let mut any = move || -> f32 {
        let bits = rng.random::<u32>();
        match rng.random::<u32>() % 8 {
            0 => [0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1e-40][bits as usize % 6],
            1 => f32::from_bits(bits),
            // Usual sizes, either sign.
            _ => (bits as f32 / u32::MAX as f32 - 0.3) * 2f32.powi((bits % 24) as i32 - 16),
        }
    };
    // The lanes hold codes 1 to 11 and a NaN.
    assert_eq!(LEVELS, 11);
    let mut checked = 0;
    for case in 0..20_000 {
        let (grown, r) = if case % 4 == 0 {
            (any(), any())
        } else {
            // The searches' sizes: a small growth, a positive radii sum.
            (any().abs() * 1e-3, any().abs())
        };
        let levels = GrownLevels::new(grown, r);
        let mut floors = vec![any(), any(), any(), 0.0, -0.0, f32::NAN, -grown];
        for c in 1..=LEVELS {
            let l = DeepPairs::level(c, r) + grown;
            floors.extend([l, l.next_up(), l.next_down()]);
        }
        for &floor in &floors {
            for from in 0..=LEVELS + 2 {
                assert_eq!(
                    levels.top(from, floor),
                    DeepPairs::top(from, grown, r, floor),
                    "from {from}, grown {grown:e}, r {r:e}, floor {floor:e}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 5_000_000);
}

/// `up_to` of a finished recording against the levels as recorded, read pair by pair
/// (pair `k` is in the set when some code from 1 to `top`, at most [`LEVELS`], has its
/// bit), on random levels for every `top` up to past the last code.
#[test]
fn joined_levels_give_the_pairs_at_every_code_up_to_the_top() {
    use rand::{Rng, SeedableRng};
    let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(33);
    let mut next = move || r.random::<u64>();
    let mut m = EdgeMemory::default();
    for _ in 0..300 {
        for level in m.levels.iter_mut() {
            // Sparse and dense sets alike.
            let (x, y) = (next() as u128, next() as u128);
            *level = if next() % 2 == 0 {
                (x << 64) | y
            } else {
                x & y & (y >> 3)
            };
        }
        let recorded = m.levels;
        m.join_levels();
        for top in 0..=LEVELS + 2 {
            let mut want = 0u128;
            for k in 0..128 {
                let codes = 1..=top.min(LEVELS);
                if codes
                    .into_iter()
                    .any(|c| (recorded[c as usize - 1] >> k) & 1 != 0)
                {
                    want |= 1 << k;
                }
            }
            assert_eq!(m.up_to(top), want, "top {top}");
        }
    }
}
