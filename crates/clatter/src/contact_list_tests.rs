//! Tests of the contact list (`contact_list.rs`): the springs' carry, the gathers.

use glam::Vec3;

/// The springs carried in pieces of any size against the one merge over the whole
/// list (the definition): pairs that persist, new ones, old ones gone, runs of each
/// across piece edges, old springs shorter than the old list.
#[test]
fn the_springs_carried_in_pieces_are_the_one_merges() {
    let merge = |old: &[[u32; 2]], h: &[Vec3], t: &[f32], new: &[[u32; 2]]| {
        let (mut hist, mut twist, mut k) = (Vec::new(), Vec::new(), 0);
        for p in new {
            while k < old.len() && old[k] < *p {
                k += 1;
            }
            let kept = k < old.len() && old[k] == *p;
            hist.push(if kept {
                h.get(k).copied().unwrap_or(Vec3::ZERO)
            } else {
                Vec3::ZERO
            });
            twist.push(if kept {
                t.get(k).copied().unwrap_or(0.0)
            } else {
                0.0
            });
        }
        (hist, twist)
    };
    // A fixed pseudo-random walk over pairs (i, j): each candidate in old, new, both
    // or neither.
    let mut seed = 12345u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as u32
    };
    let (mut old, mut new) = (Vec::new(), Vec::new());
    for i in 0..900u32 {
        for j in i + 1..i + 6 {
            match next() % 4 {
                0 => old.push([i, j]),
                1 => new.push([i, j]),
                2 => {
                    old.push([i, j]);
                    new.push([i, j]);
                }
                _ => {}
            }
        }
    }
    let hist: Vec<Vec3> = (0..old.len())
        .map(|k| Vec3::new(k as f32, 1.0, -2.0))
        .collect();
    let twist: Vec<f32> = (0..old.len()).map(|k| 0.5 + k as f32).collect();
    let bits = |(h, t): (Vec<Vec3>, Vec<f32>)| -> Vec<u32> {
        let mut out: Vec<u32> = h
            .iter()
            .flat_map(|h| h.to_array())
            .map(f32::to_bits)
            .collect();
        out.extend(t.iter().map(|t| t.to_bits()));
        out
    };
    let mut persisting = 0;
    for short in [0, 37] {
        let (h, t) = (&hist[..hist.len() - short], &twist[..twist.len() - short]);
        let want = merge(&old, h, t, &new);
        persisting = want.1.iter().filter(|&&t| t != 0.0).count();
        let want = bits(want);
        for piece in [1, 2, 7, 64, 1000, 4096] {
            let got = bits(super::carry_springs_in(&old, h, t, &new, piece));
            assert!(got == want, "pieces of {piece}, {short} springs short");
        }
    }
    assert!(
        persisting > 500 && persisting < new.len() - 500,
        "{persisting}"
    );
}

/// `gather8` against the sums written out here in contact order (side a, then side b,
/// then the walls, each by contact index): bodies with no contacts and with up to
/// eleven on a side (blocks of four with their padding, one block and several), forces
/// with -0 and +0 components and sums that cancel to zero (where padding with -0 or
/// adding padding to -0 would show), skipped lanes; every bit.
#[test]
fn gather8_is_the_sums_in_contact_order() {
    gather8_case(true);
}

/// [`gather8_is_the_sums_in_contact_order`] without walls: the last bodies' side-a
/// blocks then reach past the forces' end (the clamped reads of `side_a`).
#[test]
fn gather8_without_walls_is_the_sums_in_contact_order() {
    gather8_case(false);
}

/// `live_places` against the compare it replaced (`BVec4A::splat(m + u < end)`, each
/// place's), mask for mask, for blocks before, across and past a range's end.
#[test]
fn live_places_are_the_compares() {
    use glam::BVec4A;
    for end in 0..12usize {
        for m in 0..16usize {
            let got = super::live_places(m, end);
            for (u, got) in got.iter().enumerate() {
                let want = BVec4A::splat(m + u < end);
                assert_eq!(got.bitmask(), want.bitmask(), "m {m}, end {end}, u {u}");
            }
        }
    }
}

/// The check of [`gather8_is_the_sums_in_contact_order`], with walls or without.
fn gather8_case(with_walls: bool) {
    use super::Contacts;
    use crate::contract::ContactForce;
    let mut seed = 777u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as u32
    };
    let bodies = 64usize;
    let mut pairs = Vec::new();
    for i in 0..bodies as u32 {
        // Degrees 0 to 11 as side a.
        let degree = next() % 12;
        for j in i + 1..bodies as u32 {
            if (pairs.iter().filter(|p: &&[u32; 2]| p[0] == i).count() as u32) < degree
                && next() % 3 == 0
            {
                pairs.push([i, j]);
            }
        }
    }
    let walls: Vec<[u32; 2]> = (0..bodies as u32)
        .filter(|i| with_walls && i % 5 == 0)
        .flat_map(|i| (0..i % 3).map(move |w| [i, w]))
        .collect();
    let mut c = Contacts::new(bodies, pairs, walls, Vec::new(), Vec::new());
    let values = [0.0, -0.0, -0.0, 1.5, -1.5, 0.25, -3.0e-7];
    for f in c.springs.forces.iter_mut() {
        let mut v = || values[next() as usize % values.len()];
        *f = ContactForce {
            force_b: Vec3::new(v(), v(), v()),
            normal_force: v(),
            torque_a: Vec3::new(v(), v(), v()),
            pad0: v(),
            torque_b: Vec3::new(v(), v(), v()),
            pad1: v(),
        };
    }
    let (wf, wt) = written_out_sums(&c, bodies);
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    let (mut padded, mut zero_sums) = (0, 0);
    for i in 0..bodies - 7 {
        let skip = if i % 3 == 0 { 0b0100_1001 } else { 0 };
        let (f, t) = c.gather8_with::<true>(i, skip);
        let (f2, t2) = c.gather8_with::<false>(i, skip);
        let lane_bits = |v: &[glam::Vec4; 8]| v.map(|x| x.to_array().map(f32::to_bits));
        assert_eq!(
            lane_bits(&f),
            lane_bits(&f2),
            "padded against unpadded, bodies {i}.."
        );
        assert_eq!(
            lane_bits(&t),
            lane_bits(&t2),
            "padded against unpadded, bodies {i}.."
        );
        for l in 0..8 {
            let b = i + l;
            let (want_f, want_t) = if skip >> l & 1 != 0 {
                (Vec3::ZERO, Vec3::ZERO)
            } else {
                (wf[b], wt[b])
            };
            assert_eq!(bits(f[l].truncate()), bits(want_f), "force, body {b}");
            assert_eq!(bits(t[l].truncate()), bits(want_t), "torque, body {b}");
        }
        let a = (c.pairs_as_a[i + 1] - c.pairs_as_a[i]) as usize;
        padded += (!a.is_multiple_of(4) && a > 4) as usize;
        zero_sums += [wf[i], wt[i]]
            .iter()
            .flat_map(|v| v.to_array())
            .filter(|&x| x == 0.0)
            .count();
    }
    assert!(padded > 3 && zero_sums > 10, "{padded} {zero_sums}");
}

/// Each body's force and torque summed over every contact of `c` written out, in the
/// gathers' order (side a of each body pair, then side b, then the walls), each in contact
/// order: the definition the gathers are held to.
fn written_out_sums(c: &super::Contacts, bodies: usize) -> (Vec<Vec3>, Vec<Vec3>) {
    let (mut wf, mut wt) = (vec![Vec3::ZERO; bodies], vec![Vec3::ZERO; bodies]);
    let n = c.len();
    for side in 0..3 {
        for k in 0..n {
            let f = c.springs.forces[k];
            match (side, c.partners(k)) {
                (0, (i, super::Partner::Body(_))) => {
                    wf[i as usize] -= f.force_b;
                    wt[i as usize] += f.torque_a;
                }
                (1, (_, super::Partner::Body(j))) => {
                    wf[j as usize] += f.force_b;
                    wt[j as usize] += f.torque_b;
                }
                (2, (i, super::Partner::Wall(_))) => {
                    wf[i as usize] += f.force_b;
                    wt[i as usize] += f.torque_b;
                }
                _ => {}
            }
        }
    }
    (wf, wt)
}
