//! The near list's making ([`make`]), in parallel pieces: the serial loop's list.

use glam::Vec3;
use rayon::prelude::*;

use super::{MAKE_CHUNK, MARGIN, Near};
use crate::contact_list::{ContactSprings, Contacts};
use crate::contract::ContactForce;
use crate::world::World;

/// A near list from the broad phase's list (whose springs are current) at the current
/// positions (split): in parallel pieces of [`MAKE_CHUNK`] on more than one thread, else in
/// one serial pass ([`make_serial`]: the same list, with none of the pieces' extra passes,
/// which cost a one-thread step, the one each MPI rank runs, about 0.5% of its instructions).
pub(super) fn make(world: &World) -> Near {
    if rayon::current_num_threads() == 1 {
        make_serial(world)
    } else {
        make_in(world, MAKE_CHUNK)
    }
}

/// Whether slot `k`'s spring holds nothing: not touching, and history, twist and forces
/// all zero bits (such a pair may be left out of the near list and start afresh).
fn at_rest(sp: &ContactSprings, k: usize) -> bool {
    !sp.touching[k]
        && sp.history[k].to_array().map(f32::to_bits) == [0; 3]
        && sp.twist[k].to_bits() == 0
        && bytemuck::bytes_of(&sp.forces[k]) == bytemuck::bytes_of(&ContactForce::default())
}

/// [`make`] in one pass over the broad phase's list, pair by pair in list order, each
/// left-out pair's half gap folded into both its bodies' slack at once: the definition
/// the pieces of [`make_in`] reproduce (the same arrays, bit for bit; the slack is the
/// minimum of the same values, see there).
fn make_serial(world: &World) -> Near {
    let c = &world.contacts;
    let sp = &c.springs;
    let np = c.pairs.len();
    let nb = world.len();
    let margin = MARGIN * world.skin;
    let x = world.position_pairs.as_slice();
    let radius = &world.consts.radius;
    let is_zero = |k: usize| at_rest(sp, k);
    // Per body, half the smallest gap of its pairs left out; per slot, the near pairs
    // before it (and the total last).
    // Each pair written at the next free place and kept by counting it (`n`): written by
    // index into arrays of the list's length (no capacity test per push), cut to `n` after.
    let mut slack = vec![f32::INFINITY; nb];
    let mut rank = vec![0u32; np + 1];
    let (mut slots, mut pairs) = (vec![0u32; np], vec![[0u32; 2]; np]);
    let mut n = 0;
    for (k, &[i, j]) in c.pairs.iter().enumerate() {
        rank[k] = n as u32;
        let (iu, ju) = (i as usize, j as usize);
        // The step's own offset (`sphere_pair`'s), its squared length in `f32`.
        let d: Vec3 = world.offset_in(x, iu, ju);
        let reach = radius[iu] + radius[ju] + margin;
        let d2 = d.length_squared();
        // Not `<`: a NaN distance keeps the pair.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(d2 >= reach * reach) || !is_zero(k) {
            slots[n] = k as u32;
            pairs[n] = [i, j];
            n += 1;
        } else {
            // At least `margin` (up to rounding, allowed for below).
            let half_gap = 0.5 * (d2.sqrt() - radius[iu] - radius[ju]);
            slack[iu] = slack[iu].min(half_gap);
            slack[ju] = slack[ju].min(half_gap);
        }
    }
    rank[np] = n as u32;
    slots.truncate(n);
    pairs.truncate(n);
    // The near pairs' springs, forces and flags, then every wall pair's (collected from
    // iterators of known length: no capacity test per element).
    fn picked<T: Copy>(slots: &[u32], all: &[T], np: usize) -> Vec<T> {
        let near = slots.iter().map(|&s| all[s as usize]);
        near.chain(all[np..].iter().copied()).collect()
    }
    let history = picked(&slots, &sp.history, np);
    let twist = picked(&slots, &sp.twist, np);
    let forces = picked(&slots, &sp.forces, np);
    let touching = picked(&slots, &sp.touching, np);
    // The gather tables, from the list's (the slots ascend, so each body's pairs keep
    // their order).
    let pairs_as_a = c.pairs_as_a.iter().map(|&a| rank[a as usize]).collect();
    let mut b_pair_start = Vec::with_capacity(nb + 1);
    let mut b_pairs = Vec::with_capacity(n);
    b_pair_start.push(0);
    for i in 0..nb {
        let range = c.b_pair_start[i] as usize..c.b_pair_start[i + 1] as usize;
        for &k in &c.b_pairs[range] {
            let k = k as usize;
            if rank[k + 1] != rank[k] {
                b_pairs.push(rank[k]);
            }
        }
        b_pair_start.push(b_pairs.len() as u32);
    }
    let wall_contacts_of = c
        .wall_contacts_of
        .iter()
        .map(|&w| w - np as u32 + n as u32)
        .collect();
    let springs = ContactSprings {
        history,
        twist,
        forces,
        touching,
        // Spheres keep no hints or bounds.
        hints: Vec::new(),
        separation_bound: Vec::new(),
    };
    let tables = Tables {
        pairs_as_a,
        b_pair_start,
        b_pairs: crate::contact_list::pad_b_pairs(b_pairs),
        wall_contacts_of,
    };
    // Less an allowance for the rounding (as in `make_in`).
    let allowance = 1e-5 * (2.0 * world.consts.max_radius() + world.skin) as f64;
    let reach2 = slack
        .iter()
        .map(|&s| {
            let r = s as f64 - allowance;
            if r > 0.0 { r * r } else { -1.0 }
        })
        .collect();
    let made_at = world.state.position.clone();
    assemble(world, slots, rank, pairs, springs, tables, made_at, reach2)
}

/// A near list's gather tables (what `Contacts::new` builds for its pairs).
struct Tables {
    pairs_as_a: Vec<u32>,
    b_pair_start: Vec<u32>,
    b_pairs: Vec<u32>,
    wall_contacts_of: Vec<u32>,
}

/// The near list of [`make_serial`]'s or [`make_in`]'s parts.
#[allow(clippy::too_many_arguments)]
fn assemble(
    world: &World,
    slots: Vec<u32>,
    rank: Vec<u32>,
    pairs: Vec<[u32; 2]>,
    springs: ContactSprings,
    tables: Tables,
    made_at: Vec<glam::DVec3>,
    reach2: Vec<f64>,
) -> Near {
    let list = Contacts {
        pairs,
        wall_pairs: world.contacts.wall_pairs.clone(),
        springs,
        pairs_as_a: tables.pairs_as_a,
        b_pair_start: tables.b_pair_start,
        b_pairs: tables.b_pairs,
        wall_contacts_of: tables.wall_contacts_of,
        pieces: Vec::new(),
        near: None,
        view: std::sync::OnceLock::new(),
        wall_gap: Default::default(),
    };
    Near {
        slots,
        rank,
        list,
        made_at,
        reach2,
    }
}

/// [`make`] in parallel pieces of `piece` pairs and bodies (any positive size: the same
/// list). Serial, the making left the second thread waiting for a few percent of a sphere
/// step's time. Why the same bits whatever the pieces:
///
/// - which pairs are kept, and each left-out pair's half gap, depend on that pair alone;
///   each piece's kept slots ascend and the pieces are joined in order, so the slots are
///   the serial loop's;
/// - a body's slack is the smallest half gap of its pairs left out, taken per body over its
///   pairs (the gather tables) instead of per pair over the list: the minimum of the same
///   values, which are never NaN (a left-out pair's distance passed `>=`) nor -0 (a
///   difference of a square root and positive radii is -0 only from -0 operands), so the
///   same value in any order;
/// - every other array is a per-slot or per-body copy or map, joined in order.
fn make_in(world: &World, piece: usize) -> Near {
    let c = &world.contacts;
    let sp = &c.springs;
    let np = c.pairs.len();
    let nb = world.len();
    let margin = MARGIN * world.skin;
    let x = world.position_pairs.as_slice();
    let radius = &world.consts.radius;
    let is_zero = |k: usize| at_rest(sp, k);
    // 1. Per slot of the broad phase's list, half the gap of a pair left out (infinite for
    //    a pair kept); per piece, its kept slots and pairs.
    let mut gap = vec![f32::INFINITY; np];
    let kept: Vec<(Vec<u32>, Vec<[u32; 2]>)> = c
        .pairs
        .par_chunks(piece)
        .zip(gap.par_chunks_mut(piece))
        .enumerate()
        .map(|(p, (pairs, gap))| {
            let first = p * piece;
            let (mut slots, mut kept) = (Vec::new(), Vec::new());
            for (k, (&[i, j], g)) in pairs.iter().zip(gap.iter_mut()).enumerate() {
                let (iu, ju) = (i as usize, j as usize);
                // The step's own offset (`sphere_pair`'s), its squared length in `f32`.
                let d: Vec3 = world.offset_in(x, iu, ju);
                let reach = radius[iu] + radius[ju] + margin;
                let d2 = d.length_squared();
                // Not `<`: a NaN distance keeps the pair.
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                if !(d2 >= reach * reach) || !is_zero(first + k) {
                    slots.push((first + k) as u32);
                    kept.push([i, j]);
                } else {
                    // At least `margin` (up to rounding, allowed for below).
                    *g = 0.5 * (d2.sqrt() - radius[iu] - radius[ju]);
                }
            }
            (slots, kept)
        })
        .collect();
    // 2. Per slot, the near pairs before it (and the total last), piece by piece from the
    //    pieces' counts.
    let mut before = Vec::with_capacity(kept.len());
    let mut n = 0;
    for (slots, _) in &kept {
        before.push(n);
        n += slots.len();
    }
    let mut rank = vec![0u32; np + 1];
    rank[..np]
        .par_chunks_mut(piece)
        .zip(kept.par_iter().zip(before.par_iter()))
        .enumerate()
        .for_each(|(p, (rank, ((slots, _), &before)))| {
            let first = p * piece;
            let mut m = 0;
            for (k, r) in rank.iter_mut().enumerate() {
                *r = (before + m) as u32;
                m += (slots.get(m) == Some(&((first + k) as u32))) as usize;
            }
        });
    rank[np] = n as u32;
    let (slots, pairs): (Vec<Vec<u32>>, Vec<Vec<[u32; 2]>>) = kept.into_iter().unzip();
    let (slots, pairs) = (slots.concat(), pairs.concat());
    // 3. The near pairs' springs, forces and flags, then every wall pair's.
    let total = n + c.wall_pairs.len();
    let (mut history, mut twist) = (Vec::with_capacity(total), Vec::with_capacity(total));
    let (mut forces, mut touching) = (Vec::with_capacity(total), Vec::with_capacity(total));
    history.par_extend(slots.par_iter().map(|&s| sp.history[s as usize]));
    twist.par_extend(slots.par_iter().map(|&s| sp.twist[s as usize]));
    forces.par_extend(slots.par_iter().map(|&s| sp.forces[s as usize]));
    touching.par_extend(slots.par_iter().map(|&s| sp.touching[s as usize]));
    history.extend_from_slice(&sp.history[np..]);
    twist.extend_from_slice(&sp.twist[np..]);
    forces.extend_from_slice(&sp.forces[np..]);
    touching.extend_from_slice(&sp.touching[np..]);
    // 4. Per piece of bodies: the gather tables, from the list's (what `Contacts::new`
    //    builds for the near pairs; the slots ascend, so each body's pairs keep their
    //    order), and how far each body may move: half the smallest gap of its pairs left
    //    out, less an allowance for the rounding of the offsets and distances (relative
    //    errors of a few `f32` ulps of the largest reach) on both sides.
    let allowance = 1e-5 * (2.0 * world.consts.max_radius() + world.skin) as f64;
    let per_body: Vec<(Vec<u32>, Vec<u32>, Vec<f64>)> = (0..nb.div_ceil(piece))
        .into_par_iter()
        .map(|p| {
            let bodies = p * piece..((p + 1) * piece).min(nb);
            let mut ends = Vec::with_capacity(bodies.len());
            let mut b_pairs = Vec::new();
            let mut reach2 = Vec::with_capacity(bodies.len());
            for i in bodies {
                let mut slack = f32::INFINITY;
                for &g in &gap[c.pairs_as_a[i] as usize..c.pairs_as_a[i + 1] as usize] {
                    slack = slack.min(g);
                }
                let range = c.b_pair_start[i] as usize..c.b_pair_start[i + 1] as usize;
                for &k in &c.b_pairs[range] {
                    let k = k as usize;
                    slack = slack.min(gap[k]);
                    if rank[k + 1] != rank[k] {
                        b_pairs.push(rank[k]);
                    }
                }
                ends.push(b_pairs.len() as u32);
                let r = slack as f64 - allowance;
                reach2.push(if r > 0.0 { r * r } else { -1.0 });
            }
            (ends, b_pairs, reach2)
        })
        .collect();
    let mut b_pair_start = Vec::with_capacity(nb + 1);
    b_pair_start.push(0);
    let mut b_before = 0;
    for (ends, b_pairs, _) in &per_body {
        b_pair_start.extend(ends.iter().map(|&e| b_before + e));
        b_before += b_pairs.len() as u32;
    }
    let (mut b_pairs, mut reach2) = (Vec::with_capacity(n), Vec::with_capacity(nb));
    for (_, b, r) in per_body {
        b_pairs.extend_from_slice(&b);
        reach2.extend_from_slice(&r);
    }
    let pairs_as_a = c.pairs_as_a.par_iter().map(|&a| rank[a as usize]).collect();
    let wall_contacts_of = c
        .wall_contacts_of
        .par_iter()
        .map(|&w| w - np as u32 + n as u32)
        .collect();
    let springs = ContactSprings {
        history,
        twist,
        forces,
        touching,
        // Spheres keep no hints or bounds.
        hints: Vec::new(),
        separation_bound: Vec::new(),
    };
    let tables = Tables {
        pairs_as_a,
        b_pair_start,
        b_pairs: crate::contact_list::pad_b_pairs(b_pairs),
        wall_contacts_of,
    };
    let mut made_at = Vec::with_capacity(nb);
    made_at.par_extend(world.state.position.par_iter().copied());
    assemble(world, slots, rank, pairs, springs, tables, made_at, reach2)
}

#[cfg(test)]
mod tests {
    use crate::World;
    use crate::contact_list::ContactSprings;

    use super::super::tests::world;

    /// The serial making, pair by pair in list order (the definition the pieces must give):
    /// the slots, each slot's rank, the pairs and the springs copied, the gather tables,
    /// each body's squared reach.
    #[allow(clippy::type_complexity)]
    fn made_serially(
        world: &World,
    ) -> (
        Vec<u32>,
        Vec<u32>,
        Vec<[u32; 2]>,
        Vec<u32>,
        Vec<u32>,
        Vec<u32>,
        Vec<f64>,
    ) {
        use super::super::MARGIN;
        use crate::contract::ContactForce;
        let c = &world.contacts;
        let sp = &c.springs;
        let x = world.position_pairs.as_slice();
        let radius = &world.consts.radius;
        let margin = MARGIN * world.skin;
        let mut slack = vec![f32::INFINITY; world.len()];
        let (mut slots, mut rank, mut pairs) = (Vec::new(), Vec::new(), Vec::new());
        for (k, &[i, j]) in c.pairs.iter().enumerate() {
            rank.push(slots.len() as u32);
            let (iu, ju) = (i as usize, j as usize);
            let d2 = world.offset_in(x, iu, ju).length_squared();
            let reach = radius[iu] + radius[ju] + margin;
            let zero = !sp.touching[k]
                && sp.history[k].to_array().map(f32::to_bits) == [0; 3]
                && sp.twist[k].to_bits() == 0
                && bytemuck::bytes_of(&sp.forces[k])
                    == bytemuck::bytes_of(&ContactForce::default());
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(d2 >= reach * reach) || !zero {
                slots.push(k as u32);
                pairs.push([i, j]);
            } else {
                let half_gap = 0.5 * (d2.sqrt() - radius[iu] - radius[ju]);
                slack[iu] = slack[iu].min(half_gap);
                slack[ju] = slack[ju].min(half_gap);
            }
        }
        rank.push(slots.len() as u32);
        let pairs_as_a = c.pairs_as_a.iter().map(|&a| rank[a as usize]).collect();
        let (mut b_pair_start, mut b_pairs) = (vec![0], Vec::new());
        for i in 0..world.len() {
            for &k in &c.b_pairs[c.b_pair_start[i] as usize..c.b_pair_start[i + 1] as usize] {
                if rank[k as usize + 1] != rank[k as usize] {
                    b_pairs.push(rank[k as usize]);
                }
            }
            b_pair_start.push(b_pairs.len() as u32);
        }
        // The gather's padding after the side-b pairs (`pad_b_pairs`).
        let b_pairs = crate::contact_list::pad_b_pairs(b_pairs);
        let allowance = 1e-5 * (2.0 * world.consts.max_radius() + world.skin) as f64;
        let reach2 = slack
            .iter()
            .map(|&s| {
                let r = s as f64 - allowance;
                if r > 0.0 { r * r } else { -1.0 }
            })
            .collect();
        (
            slots,
            rank,
            pairs,
            pairs_as_a,
            b_pair_start,
            b_pairs,
            reach2,
        )
    }

    /// Every bit of a contact list's springs, forces and flags.
    fn spring_bits(sp: &ContactSprings) -> Vec<u32> {
        let mut out: Vec<u32> = sp
            .history
            .iter()
            .flat_map(|h| h.to_array())
            .map(f32::to_bits)
            .collect();
        out.extend(sp.twist.iter().map(|t| t.to_bits()));
        out.extend(
            sp.forces
                .iter()
                .flat_map(|f| bytemuck::cast::<_, [u32; 12]>(*f)),
        );
        out.extend(sp.touching.iter().map(|&t| t as u32));
        out
    }

    /// The near list made in parallel pieces of any size (one pair or body, a few, more
    /// than the list) and by `make_serial` (the one-thread path) against the serial making
    /// kept here, every array bitwise, at many moments of a pour (pairs and bodies left out
    /// or not, reaches finite and infinite); and written back over garbage, in pieces and
    /// serially, the broad phase's springs exactly.
    #[test]
    fn the_near_list_made_in_pieces_is_the_serial_ones() {
        let mut w = world();
        let (mut checked, mut left_out, mut finite) = (0, 0, 0);
        for step in 0..900 {
            w.step().expect("a stable run");
            if step % 60 != 7 {
                continue;
            }
            let mut v = w.clone();
            v.contacts.end_near();
            v.split_positions();
            let want = made_serially(&v);
            let (slots, rank, pairs, pairs_as_a, b_pair_start, b_pairs, reach2) = &want;
            left_out += v.contacts.pairs.len() - slots.len();
            finite += reach2.iter().filter(|r| r.is_finite()).count();
            // Pieces of 0: the serial making.
            for piece in [0, 1, 3, 8, 61, 4096] {
                let near = if piece == 0 {
                    super::make_serial(&v)
                } else {
                    super::make_in(&v, piece)
                };
                let l = &near.list;
                assert_eq!(&near.slots, slots, "slots, step {step}, pieces of {piece}");
                assert_eq!(&near.rank, rank, "ranks, step {step}, pieces of {piece}");
                assert_eq!(&l.pairs, pairs, "pairs, step {step}, pieces of {piece}");
                assert_eq!(&l.pairs_as_a, pairs_as_a, "pairs as a, step {step}");
                assert_eq!(&l.b_pair_start, b_pair_start, "b starts, step {step}");
                assert_eq!(
                    &l.b_pairs, b_pairs,
                    "b pairs, step {step}, pieces of {piece}"
                );
                let bits = |r: &[f64]| r.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&near.reach2),
                    bits(reach2),
                    "reach, step {step}, {piece}"
                );
                assert_eq!(
                    bits(
                        &near
                            .made_at
                            .iter()
                            .flat_map(|p| p.to_array())
                            .collect::<Vec<_>>()
                    ),
                    bits(
                        &v.state
                            .position
                            .iter()
                            .flat_map(|p| p.to_array())
                            .collect::<Vec<_>>()
                    )
                );
                // The springs copied, then written back over garbage in the near slots.
                let src = &v.contacts.springs;
                let np = v.contacts.pairs.len();
                let picked = |k: &mut dyn Iterator<Item = usize>| {
                    let k: Vec<usize> = k.collect();
                    ContactSprings {
                        history: k.iter().map(|&k| src.history[k]).collect(),
                        twist: k.iter().map(|&k| src.twist[k]).collect(),
                        forces: k.iter().map(|&k| src.forces[k]).collect(),
                        touching: k.iter().map(|&k| src.touching[k]).collect(),
                        ..ContactSprings::default()
                    }
                };
                let copied = picked(
                    &mut slots
                        .iter()
                        .map(|&s| s as usize)
                        .chain(np..src.history.len()),
                );
                assert!(
                    spring_bits(&l.springs) == spring_bits(&copied),
                    "springs copied, step {step}, pieces of {piece}"
                );
                for serial in [false, true] {
                    let mut dst = src.clone();
                    for &s in slots {
                        let s = s as usize;
                        dst.history[s] = glam::Vec3::NAN;
                        dst.twist[s] = f32::NAN;
                        dst.forces[s] = bytemuck::cast([u32::MAX; 12]);
                        dst.touching[s] = !dst.touching[s];
                    }
                    if serial {
                        near.write_back_serial(&mut dst);
                    } else {
                        near.write_back_in_pieces(&mut dst);
                    }
                    assert!(
                        spring_bits(&dst) == spring_bits(src),
                        "written back, step {step}, serially: {serial}"
                    );
                }
                checked += 1;
            }
        }
        // Covered: lists made at 15 moments, six ways each, pairs left out, bodies with a
        // finite reach.
        assert_eq!(checked, 90);
        assert!(
            left_out > 100 && finite > 100,
            "{left_out} left out, {finite} finite"
        );
    }
}
