//! Stage 2 of the step, **contacts**: the narrow phase and the contact law for every
//! candidate body pair and body-wall pair, in parallel. Each contact writes only its own
//! slot (force, springs, touching flag), so the result does not depend on the thread count.

use glam::{Quat, Vec3};
use rayon::prelude::*;

use super::motion::BodyBound;
use super::plain_walls::{WallBodies, plain_wall, wall_pair};
#[cfg(test)]
use super::remembered::axis_motion_bound;
pub use super::remembered::pair_narrow;
use super::remembered::remembered_narrow;
use super::{CHUNK, FINE_CHUNK};

// The pair loop's list of the pairs left after `skip_apart` holds chunk positions as `u8`.
const _: () = assert!(FINE_CHUNK <= 256);
use crate::contact_list::{ContactSprings, piece_ids};
use crate::law::{self, BodyMotion, ContactForce, PairContext};
use crate::material::PairParams;
use crate::precise::Ds3A;
use crate::world::World;
use clatter_geom::narrow::{self, ContactPoint, EdgeMemory, SatHint};

/// Runs the stage; returns the number of contacts that touch.
pub(crate) fn run(world: &mut World) -> usize {
    prepare(world);
    let all = Part {
        pairs: 0..usize::MAX,
        groups: None,
        size: 8,
        walls: true,
    };
    run_part(world, &all)
}

/// The stage's start, before any contact is computed: each body's position split into its
/// pair once, for every contact it takes part in; for spheres, the near list kept or made
/// anew (the stage then runs on it). Reads every body's state (a rank's ghosts' too).
pub(crate) fn prepare(world: &mut World) {
    // The split and the near list's reach test in one pass.
    let held = super::near::split_and_test(world);
    super::near::update(world, held);
}

/// Which contacts of the active list a run of the stage computes ([`run_part`]): all of
/// them, or, for a decomposed step whose ghost states are still on their way
/// (`crate::domain`), those that need no ghost first and the others once the states are in.
/// Every contact is computed by the same code from the same inputs whatever the part (in
/// groups of eight the lanes take the same eights, parts starting at multiples of eight;
/// in groups of one a pair may fall to the scalar path instead, which gives the lanes'
/// bits, `sphere_lanes.rs`), and writes only its own slot, so computing the list in parts
/// gives the bits one run gives.
pub(crate) struct Part<'a> {
    /// The body pairs `lo..hi` of the active list (cut at its end), `lo` a multiple of 8.
    pub(crate) pairs: std::ops::Range<usize>,
    /// Of those, only the groups of `size` pairs (`k / size`: eight, the lanes' groups, or
    /// one) whose flag here equals the second: whether the group holds a pair with a ghost,
    /// and which kind the run computes (`None`: every pair).
    pub(crate) groups: Option<(&'a [bool], bool)>,
    /// The pairs in a group of `groups` (a divisor of [`CHUNK`]).
    pub(crate) size: usize,
    /// Whether the wall pairs are computed too (a ghost has none).
    pub(crate) walls: bool,
}

/// Runs part of the stage on a prepared world ([`prepare`]); returns the number of its
/// contacts that touch.
pub(crate) fn run_part(world: &mut World, part: &Part) -> usize {
    let active = match &mut world.contacts.near {
        Some(near) => &mut near.list.springs,
        None => &mut world.contacts.springs,
    };
    let mut springs = std::mem::take(active);
    // The plain body-pair path's edge memories, one per body pair (see `World::edge_memory`).
    let mut memory = std::mem::take(&mut world.edge_memory);
    if !world.has_composites() && !world.spheres_only() {
        memory.resize(world.contacts.pairs.len(), EdgeMemory::default());
    }
    // The plain wall path's gap bounds, one per wall pair (see `plain_walls`).
    let mut wall_gap = std::mem::take(&mut world.contacts.wall_gap);
    wall_gap.fit(&world.walls, world.contacts.active().wall_pairs.len());
    let w = &*world;
    let x = w.position_pairs.as_slice();
    let list = w.contacts.active();
    let np = list.pairs.len();
    let ContactSprings {
        history,
        twist,
        forces,
        touching,
        hints,
        separation_bound,
    } = &mut springs;
    let (hist_pairs, hist_walls) = history.split_at_mut(np);
    let (twist_pairs, twist_walls) = twist.split_at_mut(np);
    let (force_pairs, force_walls) = forces.split_at_mut(np);
    let (touch_pairs, touch_walls) = touching.split_at_mut(np);
    let (piece_pairs, piece_walls) = list.pieces.split_at(list.pieces.len().min(np));
    // The part's body pairs (and per-pair memories, where the list keeps them).
    let lo = part.pairs.start.min(np);
    let hi = part.pairs.end.clamp(lo, np);
    let size = part.size;
    debug_assert!(
        size > 0 && CHUNK.is_multiple_of(size) && lo.is_multiple_of(size),
        "whole groups"
    );
    let r = lo..hi;
    let cut = |len: usize| lo.min(len)..hi.min(len);
    let pairs = &list.pairs[r.clone()];
    let (hist_pairs, twist_pairs) = (&mut hist_pairs[r.clone()], &mut twist_pairs[r.clone()]);
    let (force_pairs, touch_pairs) = (&mut force_pairs[r.clone()], &mut touch_pairs[r]);
    let piece_pairs = &piece_pairs[cut(piece_pairs.len())];
    let (nh, nb, nm) = (hints.len(), separation_bound.len(), memory.len());
    let hints = &mut hints[cut(nh)];
    let separation_bound = &mut separation_bound[cut(nb)];
    let memory_part = &mut memory[cut(nm)];
    let groups = part.groups;
    // Whether pair `k` of the part is computed.
    let keep = |k: usize| groups.is_none_or(|(g, want)| g[(lo + k) / size] == want);
    // Every pair on the plain law: the law compiled without the tests for the others.
    let plain = w.materials.all_plain();
    // Bodies all alike on the plain law: one body-pair context and its constants.
    let same = if plain && !w.has_composites() && !w.spheres_only() {
        SamePair::of(w)
    } else {
        None
    };
    let same = same.as_ref();
    // Spheres of one radius, mass and material: the lanes' law constants once a chunk.
    #[cfg(target_arch = "x86_64")]
    let uniform = if w.spheres_only() && plain {
        super::sphere_lanes::Uniform::of(w)
    } else {
        None
    };
    // Body pairs and wall pairs in one fork-join (one synchronisation, not two).
    let (pairs_touching, walls_touching) = rayon::join(
        || {
            if w.has_composites() {
                // Contacts per piece pair (the same per-contact work, on the pieces).
                return pairs
                    .par_iter()
                    .zip(piece_pairs.par_iter())
                    .zip(hist_pairs.par_iter_mut())
                    .zip(force_pairs.par_iter_mut())
                    .zip(touch_pairs.par_iter_mut())
                    .zip(hints.par_iter_mut())
                    .zip(twist_pairs.par_iter_mut())
                    .zip(separation_bound.par_iter_mut())
                    .enumerate()
                    .with_max_len(FINE_CHUNK)
                    .map(|(k, (((((((p, pc), h), f), t), hn), tw), b))| {
                        if !keep(k) {
                            return 0;
                        }
                        let memo = None;
                        body_pair::<true>(w, x, *p, *pc, h, f, t, hn, tw, b, memo, plain) as usize
                    })
                    .sum::<usize>();
            }
            if w.spheres_only() {
                // Chunks of plain slices: the sphere law is cheap, so the per-item cost of
                // a deep parallel zip would show.
                let chunk = |p: &[[u32; 2]],
                             h: &mut [Vec3],
                             f: &mut [ContactForce],
                             t: &mut [bool],
                             c: &mut [f32]| {
                    if plain {
                        #[cfg(target_arch = "x86_64")]
                        if super::avx2() {
                            // SAFETY: the CPU has AVX2.
                            return unsafe {
                                super::sphere_lanes::sphere_chunk(w, x, uniform, p, h, c, f, t)
                            };
                        }
                        super::vex(|| sphere_chunk::<true>(w, x, p, h, c, f, t))
                    } else {
                        super::vex(|| sphere_chunk::<false>(w, x, p, h, c, f, t))
                    }
                };
                return pairs
                    .par_chunks(CHUNK)
                    .zip(hist_pairs.par_chunks_mut(CHUNK))
                    .zip(force_pairs.par_chunks_mut(CHUNK))
                    .zip(touch_pairs.par_chunks_mut(CHUNK))
                    .zip(twist_pairs.par_chunks_mut(CHUNK))
                    .enumerate()
                    .map(|(n, ((((p, h), f), t), c))| match groups {
                        None => chunk(p, h, f, t, c),
                        // The chunk's runs of wanted groups, each as a chunk of its own.
                        Some((g, want)) => {
                            let first = (lo + n * CHUNK) / size;
                            let runs = runs(&g[first..first + p.len().div_ceil(size)], want);
                            runs.map(|(a, b)| {
                                let r = size * a..(size * b).min(p.len());
                                let (h, f) = (&mut h[r.clone()], &mut f[r.clone()]);
                                let (t, c) = (&mut t[r.clone()], &mut c[r.clone()]);
                                chunk(&p[r], h, f, t, c)
                            })
                            .sum()
                        }
                    })
                    .sum::<usize>();
            }
            // A task of `FINE_CHUNK` pairs each, the pairs in a plain loop: an item per
            // pair of a deep parallel zip cost a call and the zip's bookkeeping per pair.
            pairs
                .par_chunks(FINE_CHUNK)
                .zip(hist_pairs.par_chunks_mut(FINE_CHUNK))
                .zip(force_pairs.par_chunks_mut(FINE_CHUNK))
                .zip(touch_pairs.par_chunks_mut(FINE_CHUNK))
                .zip(hints.par_chunks_mut(FINE_CHUNK))
                .zip(twist_pairs.par_chunks_mut(FINE_CHUNK))
                .zip(separation_bound.par_chunks_mut(FINE_CHUNK))
                .zip(memory_part.par_chunks_mut(FINE_CHUNK))
                .enumerate()
                .with_max_len(1)
                .map(|(c, (((((((p, h), f), t), hn), tw), b), m))| {
                    let lens = [
                        h.len(),
                        f.len(),
                        t.len(),
                        hn.len(),
                        tw.len(),
                        b.len(),
                        m.len(),
                    ];
                    let n = lens.into_iter().fold(p.len(), usize::min);
                    let (p, h, f, t) = (&p[..n], &mut h[..n], &mut f[..n], &mut t[..n]);
                    let (hn, tw, b, m) = (&mut hn[..n], &mut tw[..n], &mut b[..n], &mut m[..n]);
                    let mut touching = 0;
                    // Every pair kept without groups: the test once, not once per pair.
                    let all = groups.is_none();
                    // First the pairs still apart by more than both bodies can have moved
                    // (most of a pile's list), in a short loop of their own; the others
                    // after, in the list's order (see `skip_apart`).
                    let mut rest = [0u8; FINE_CHUNK];
                    let mut kept = 0;
                    #[cfg(target_arch = "x86_64")]
                    let lanes = all && super::avx2();
                    #[cfg(not(target_arch = "x86_64"))]
                    let lanes = false;
                    if lanes {
                        #[cfg(target_arch = "x86_64")]
                        {
                            let bounds = w.body_bounds.as_slice();
                            // SAFETY: the CPU has AVX2 (`avx2` is never true otherwise).
                            let (k, tc) = unsafe {
                                super::apart_lanes::skip_pass(bounds, p, hn, b, t, &mut rest)
                            };
                            kept = k;
                            touching += tc;
                        }
                    } else {
                        for k in 0..n {
                            if !all && !keep(c * FINE_CHUNK + k) {
                                continue;
                            }
                            if skip_apart(w, p[k], hn[k], &mut b[k]) {
                                touching += t[k] as usize;
                            } else {
                                rest[kept] = k as u8;
                                kept += 1;
                            }
                        }
                    }
                    let v = PlainBodies::of(w, x);
                    let rest = &rest[..kept];
                    let slots = (h, f, t, hn, tw, b, m);
                    // The loop compiled twice: with one context for all pairs, or without
                    // (each form with its own registers).
                    touching
                        + match same {
                            Some(s) => plain_pairs(w, &v, p, rest, slots, PairLaw::Same(s)),
                            None => plain_pairs(w, &v, p, rest, slots, PairLaw::Each(plain)),
                        }
                })
                .sum::<usize>()
        },
        || {
            if !part.walls {
                return 0;
            }
            if w.has_composites() {
                return list
                    .wall_pairs
                    .par_iter()
                    .zip(piece_walls.par_iter())
                    .zip(hist_walls.par_iter_mut())
                    .zip(force_walls.par_iter_mut())
                    .zip(touch_walls.par_iter_mut())
                    .zip(twist_walls.par_iter_mut())
                    .with_max_len(FINE_CHUNK)
                    .map(|(((((p, pc), h), f), t), tw)| {
                        wall_pair::<true>(w, x, *p, *pc, h, f, t, tw, plain) as usize
                    })
                    .sum::<usize>();
            }
            // Sphere-wall pairs are cheap (and go eight at a time); pairs with polyhedra are
            // not: a task each of `FINE_CHUNK` of those.
            let (chunk, most) = if w.spheres_only() {
                (CHUNK, usize::MAX)
            } else {
                (FINE_CHUNK, 1)
            };
            list.wall_pairs
                .par_chunks(chunk)
                .zip(hist_walls.par_chunks_mut(chunk))
                .zip(force_walls.par_chunks_mut(chunk))
                .zip(touch_walls.par_chunks_mut(chunk))
                .zip(twist_walls.par_chunks_mut(chunk))
                .zip(wall_gap.gaps.par_chunks_mut(chunk))
                .with_max_len(most)
                .map(|(((((p, h), f), t), tw), g)| {
                    #[cfg(target_arch = "x86_64")]
                    if plain && w.spheres_only() && super::avx2() {
                        // SAFETY: the CPU has AVX2.
                        return unsafe {
                            super::wall_lanes::wall_chunk(w, x, uniform, p, h, tw, f, t)
                        };
                    }
                    super::vex(|| {
                        let n = p.len();
                        let (h, f, t, tw) = (&mut h[..n], &mut f[..n], &mut t[..n], &mut tw[..n]);
                        let mut touching = 0;
                        if w.spheres_only() {
                            // (No motion bounds in a world of spheres only: no gaps kept.)
                            for k in 0..n {
                                touching += wall_pair::<false>(
                                    w, x, p[k], 0, &mut h[k], &mut f[k], &mut t[k], &mut tw[k],
                                    plain,
                                ) as usize;
                            }
                            return touching;
                        }
                        let g = &mut g[..n];
                        let v = WallBodies::of(w, x);
                        for k in 0..n {
                            let (h, f, t, tw, g) =
                                (&mut h[k], &mut f[k], &mut t[k], &mut tw[k], &mut g[k]);
                            touching += plain_wall(w, &v, p[k], h, f, t, tw, g, plain) as usize;
                        }
                        touching
                    })
                })
                .sum::<usize>()
        },
    );
    match &mut world.contacts.near {
        Some(near) => near.list.springs = springs,
        None => world.contacts.springs = springs,
    }
    world.edge_memory = memory;
    world.contacts.wall_gap = wall_gap;
    pairs_touching + walls_touching
}

/// The runs `(a, b)` of consecutive flags equal to `want` in `flags`.
fn runs(flags: &[bool], want: bool) -> impl Iterator<Item = (usize, usize)> + '_ {
    let mut a = 0;
    std::iter::from_fn(move || {
        while a < flags.len() && flags[a] != want {
            a += 1;
        }
        if a == flags.len() {
            return None;
        }
        let b = a + flags[a..].iter().take_while(|&&f| f == want).count();
        let run = (a, b);
        a = b;
        Some(run)
    })
}

/// A chunk of sphere pairs with their springs, coverages, forces and touching flags (all
/// slices of one length): the number that touch. `PLAIN`: every pair's law is plain
/// ([`law::is_plain`]).
#[inline]
pub(super) fn sphere_chunk<const PLAIN: bool>(
    w: &World,
    x: &[Ds3A],
    pairs: &[[u32; 2]],
    hist: &mut [Vec3],
    coverage: &mut [f32],
    force: &mut [ContactForce],
    touching: &mut [bool],
) -> usize {
    let n = pairs.len();
    let (h, c, f, t) = (
        &mut hist[..n],
        &mut coverage[..n],
        &mut force[..n],
        &mut touching[..n],
    );
    (0..n)
        .map(|k| {
            sphere_pair::<PLAIN>(w, x, pairs[k], &mut h[k], &mut c[k], &mut f[k], &mut t[k])
                as usize
        })
        .sum()
}

/// Two spheres (the common DEM case), without building a manifold.
#[inline(always)]
pub(super) fn sphere_pair<const PLAIN: bool>(
    w: &World,
    x: &[Ds3A],
    [i, j]: [u32; 2],
    hist: &mut Vec3,
    coverage: &mut f32,
    force: &mut ContactForce,
    touching: &mut bool,
) -> bool {
    let (i, j) = (i as usize, j as usize);
    // Relative to body i: the offset is subtracted in double-single, then rounded.
    let d = w.offset_in(x, i, j);
    let (ri, rj) = (w.consts.radius[i], w.consts.radius[j]);
    let dist2 = d.length_squared();
    if dist2 < (ri + rj) * (ri + rj) {
        let dist = dist2.sqrt();
        let n = if dist > 0.0 { d / dist } else { Vec3::Z };
        let depth = ri + rj - dist;
        let params = w.pair_params(w.consts.material[i], w.consts.material[j]);
        let (mi, mj) = (w.consts.mass[i], w.consts.mass[j]);
        let context = pair_context(w, params, mi * mj / (mi + mj), ri * rj / (ri + rj), 1.0);
        let point = ContactPoint {
            point: n * (ri - 0.5 * depth),
            depth,
        };
        *force = law::point_contact_force_in::<PLAIN>(
            &context,
            n,
            point,
            &w.local_motion(i),
            &w.motion_at(j, d),
            hist,
            coverage,
        );
        *touching = true;
    } else if *touching {
        release(force, hist, Some(coverage), touching);
    }
    *touching
}

/// Two bodies of any shapes (pieces `piece_ids(pieces)` of them when composites are
/// present, else 0): the separation bound first, then the narrow phase and the law. The
/// law sees the bodies' masses and motions (so torques are about each body's centre of
/// mass) and the pieces' radii and point shares. `PIECES` is false in worlds without
/// composites: the code is then the plain body-pair path, compiled without the piece lookups.
/// `plain`: every pair's law is plain ([`law::is_plain`]), so the law's plain form serves.
/// Inlined into the loops over pairs (one call site each form).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn body_pair<const PIECES: bool>(
    w: &World,
    x: &[Ds3A],
    [i, j]: [u32; 2],
    pieces: u32,
    hist: &mut Vec3,
    force: &mut ContactForce,
    touching: &mut bool,
    hint: &mut SatHint,
    twist: &mut f32,
    bound: &mut f32,
    memory: Option<&mut EdgeMemory>,
    plain: bool,
) -> bool {
    let pair = [i, j];
    let b = w.body_bounds.as_slice();
    debug_assert_eq!(b.len(), w.len(), "bounds made with the positions' split");
    let of = |i: usize| b[i];
    let body = |i: usize| w.body_shape(i);
    // The manifold is written in place and the law reads it there (returned in a tuple it
    // was copied three times between the narrow phase and the law).
    let mut found = None;
    let narrow = remembered_narrow::<PIECES>(
        w, x, of, body, pair, pieces, hint, bound, memory, &mut found,
    );
    let Some(d) = narrow else {
        return *touching;
    };
    let (i, j) = (i as usize, j as usize);
    let (pa, pb) = piece_ids(pieces);
    match &found {
        Some(m) => {
            let params = w.pair_params(w.consts.material[i], w.consts.material[j]);
            let (mi, mj) = (w.consts.mass[i], w.consts.mass[j]);
            let ((ri, si), (rj, sj)) = (law_side::<PIECES>(w, i, pa), law_side::<PIECES>(w, j, pb));
            let share = law::point_share(si, sj);
            let context = pair_context(w, params, mi * mj / (mi + mj), ri * rj / (ri + rj), share);
            let (a, b) = (w.local_motion(i), w.motion_at(j, d));
            *force = if plain {
                law::contact_force_in::<true>(&context, m, &a, &b, hist, twist)
            } else {
                law::contact_force_in::<false>(&context, m, &a, &b, hist, twist)
            };
            *touching = true;
        }
        None if *touching => release(force, hist, Some(twist), touching),
        None => {}
    }
    *touching
}

/// The per-body arrays the plain body-pair path ([`plain_pair`]) reads, each cut to the
/// world's body count `n`: one test that a pair's indices are below `n` then stands for
/// every read's bounds check (a slice's length known to be `n`, the compiler drops them;
/// read from the world's vectors, each read tested its index against that vector's length).
/// Made once per chunk of pairs.
struct PlainBodies<'a> {
    /// The body count.
    n: usize,
    /// The step's motion bounds ([`World::body_bounds`]).
    bounds: &'a [BodyBound],
    /// The step's split positions ([`World::position_pairs`]).
    x: &'a [Ds3A],
    velocity: &'a [Vec3],
    omega: &'a [Vec3],
    orientation: &'a [Quat],
    shape: &'a [u32],
    material: &'a [u32],
    mass: &'a [f32],
    equivalent_radius: &'a [f32],
    is_sphere: &'a [bool],
}

impl<'a> PlainBodies<'a> {
    /// The arrays of `w` (with the step's positions `x`), cut to its body count (a panic
    /// if one is shorter, as its first read out of range would have been).
    #[inline(always)]
    fn of(w: &'a World, x: &'a [Ds3A]) -> Self {
        let n = w.len();
        let (s, c) = (&w.state, &w.consts);
        Self {
            n,
            bounds: &w.body_bounds[..n],
            x: &x[..n],
            velocity: &s.velocity[..n],
            omega: &s.omega[..n],
            orientation: &s.orientation[..n],
            shape: &c.shape[..n],
            material: &c.material[..n],
            mass: &c.mass[..n],
            equivalent_radius: &c.equivalent_radius[..n],
            is_sphere: &c.is_sphere[..n],
        }
    }
}

/// The body-pair law's context when every body is alike (one material, mass, equivalent
/// radius and shape kind, as in a pile of equal cubes) and the law plain: the context
/// [`plain_pair`] would build for any pair, built once from body 0 by the same operations
/// on the same values (so the same bits), and its linear law's constants
/// ([`law::LinearLaw`]), which the law then takes instead of computing them per contact.
struct SamePair {
    context: PairContext,
    law: law::LinearLaw,
}

impl SamePair {
    /// `w`'s, if its bodies are all alike (compared by their bits), else `None`. Only for
    /// a world whose every pair's law is plain ([`law::is_plain`]).
    fn of(w: &World) -> Option<SamePair> {
        let n = w.len();
        let c = &w.consts;
        // Whether every entry has the first's bits (no early exit: the loop vectorises).
        fn alike<T: Copy>(v: &[T], bits: impl Fn(T) -> u32) -> bool {
            v.first()
                .is_some_and(|&f| v.iter().fold(0, |d, &x| d | (bits(x) ^ bits(f))) == 0)
        }
        let all = alike(&c.material[..n], |m| m)
            && alike(&c.mass[..n], f32::to_bits)
            && alike(&c.equivalent_radius[..n], f32::to_bits)
            && alike(&c.is_sphere[..n], u32::from);
        if !all {
            return None;
        }
        // `plain_pair`'s context with body 0 on both sides.
        let (m, r, s) = (c.mass[0], c.equivalent_radius[0], c.is_sphere[0]);
        let params = w.pair_params(c.material[0], c.material[0]);
        let share = law::point_share(s, s);
        let context = pair_context(w, params, m * m / (m + m), r * r / (r + r), share);
        let law = law::LinearLaw::of(&context)?;
        Some(SamePair { context, law })
    }
}

/// A chunk's per-pair slots: springs, forces, touching flags, hints, twists, separation
/// bounds and edge memories.
type Slots<'s> = (
    &'s mut [Vec3],
    &'s mut [ContactForce],
    &'s mut [bool],
    &'s mut [SatHint],
    &'s mut [f32],
    &'s mut [f32],
    &'s mut [EdgeMemory],
);

/// [`plain_pair`] for the chunk's pairs `pairs[k]`, `k` in `rest` (in that order), with
/// their slots; returns how many touch. Inlined into each of its call sites, each with
/// its `law` (so each loop is compiled for its kind of context).
#[inline(always)]
fn plain_pairs(
    w: &World,
    v: &PlainBodies,
    pairs: &[[u32; 2]],
    rest: &[u8],
    (h, f, t, hn, tw, b, m): Slots,
    law: PairLaw,
) -> usize {
    let mut touching = 0;
    // Each pair's edge memory fetched one pair ahead (a hint: see `EdgeMemory::prefetch`).
    if let Some(&first) = rest.first() {
        m[first as usize].prefetch();
    }
    for (n, &k) in rest.iter().enumerate() {
        if let Some(&next) = rest.get(n + 1) {
            m[next as usize].prefetch();
        }
        let k = k as usize;
        let (h, f, t, hn) = (&mut h[k], &mut f[k], &mut t[k], &mut hn[k]);
        let (tw, b, m) = (&mut tw[k], &mut b[k], &mut m[k]);
        touching += plain_pair(w, v, pairs[k], h, f, t, hn, tw, b, m, law) as usize;
    }
    touching
}

/// Which law context [`plain_pair`] takes.
#[derive(Clone, Copy)]
enum PairLaw<'a> {
    /// The one every pair has ([`SamePair`]).
    Same(&'a SamePair),
    /// Each pair's own, made from its bodies; whether every pair's law is plain.
    Each(bool),
}

/// [`body_pair`] of the plain path (no composites: `PIECES` false), for a pair with its
/// edge memory, with body data read through `v` (the same values, so the same floats in
/// the same order: the same bits), its law's context as `law` says.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn plain_pair(
    w: &World,
    v: &PlainBodies,
    [i, j]: [u32; 2],
    hist: &mut Vec3,
    force: &mut ContactForce,
    touching: &mut bool,
    hint: &mut SatHint,
    twist: &mut f32,
    bound: &mut f32,
    memory: &mut EdgeMemory,
    law: PairLaw,
) -> bool {
    let (iu, ju) = (i as usize, j as usize);
    // The one bounds check for every read of `v` below (and in `remembered_narrow`).
    assert!(iu < v.n && ju < v.n, "a body pair's index out of range");
    let of = |k: usize| v.bounds[k];
    // The manifold is written in place and the law reads it there (see `body_pair`).
    let mut found = None;
    let memory = Some(memory);
    let body = |k: usize| (&w.shapes[v.shape[k] as usize].shape, v.orientation[k]);
    let pair = [i, j];
    let narrow =
        remembered_narrow::<false>(w, v.x, of, body, pair, 0, hint, bound, memory, &mut found);
    let Some(d) = narrow else {
        return *touching;
    };
    match &found {
        Some(m) => {
            // `w.local_motion(i)` and `w.motion_at(j, d)`.
            let a = BodyMotion {
                position: Vec3::ZERO,
                velocity: v.velocity[iu],
                omega: v.omega[iu],
            };
            let b = BodyMotion {
                position: d,
                velocity: v.velocity[ju],
                omega: v.omega[ju],
            };
            *force = match law {
                PairLaw::Same(s) => {
                    let known = Some(&s.law);
                    law::contact_force_known::<true>(&s.context, known, m, &a, &b, hist, twist)
                }
                PairLaw::Each(plain) => {
                    let params = w.pair_params(v.material[iu], v.material[ju]);
                    let (mi, mj) = (v.mass[iu], v.mass[ju]);
                    let (ri, si) = (v.equivalent_radius[iu], v.is_sphere[iu]);
                    let (rj, sj) = (v.equivalent_radius[ju], v.is_sphere[ju]);
                    let share = law::point_share(si, sj);
                    let (m_eff, r_eff) = (mi * mj / (mi + mj), ri * rj / (ri + rj));
                    let context = pair_context(w, params, m_eff, r_eff, share);
                    if plain {
                        law::contact_force_in::<true>(&context, m, &a, &b, hist, twist)
                    } else {
                        law::contact_force_in::<false>(&context, m, &a, &b, hist, twist)
                    }
                }
            };
            *touching = true;
        }
        None if *touching => release(force, hist, Some(twist), touching),
        None => {}
    }
    *touching
}

/// What the law takes of body `i` (of its piece `piece` with composites): its equivalent
/// radius and whether it is a sphere.
#[inline(always)]
pub(super) fn law_side<const PIECES: bool>(w: &World, i: usize, piece: u32) -> (f32, bool) {
    if PIECES {
        w.piece_law(i, piece)
    } else {
        (w.consts.equivalent_radius[i], w.consts.is_sphere[i])
    }
}

/// The law's context of a contact with these parameters, effective mass and radius and
/// point share, at the world's step.
#[inline(always)]
pub(super) fn pair_context(
    w: &World,
    params: &PairParams,
    m_eff: f32,
    r_eff: f32,
    share: f32,
) -> PairContext {
    PairContext {
        params: *params,
        m_eff,
        r_eff,
        share,
        dt: w.dt,
    }
}

/// [`narrow::is_contact_hint`], the same answer for every `hint`, in fewer instructions
/// for the pair loop's first test: a face hint (kind bits `0x` or `01`, so bit 31 clear)
/// with [`narrow::HINT_CONTACT`] (bit 29) set is one; kind `10` (edges: bit 31 set, bit 30
/// clear) never is; kind `11` is one when bit 29 is set, except [`narrow::NO_HINT`] (no
/// hint of that kind but `NO_HINT` is made, but one read from a checkpoint may be).
#[inline(always)]
fn is_contact_hint(hint: SatHint) -> bool {
    const BIT31: u32 = 1 << 31;
    let face_contact = hint & (BIT31 | narrow::HINT_CONTACT) == narrow::HINT_CONTACT;
    face_contact || (hint >= 0xe000_0000 && hint != narrow::NO_HINT)
}

/// Whether body pair `[i, j]` (with contact `hint`) is still apart by more than both bodies
/// can have moved in the step: then its separation `bound` is lowered by both bodies' motion,
/// as [`remembered_narrow`] would (the same subtraction, the same float), and the pair is
/// skipped; else nothing is written, and the pair goes through [`body_pair`] (whose
/// [`remembered_narrow`] makes the same test again and the same subtraction). A short path
/// of its own: most pairs of a pile's list stop here, and inside the pair loop's body they
/// paid for its register spills and reloads.
#[inline(always)]
fn skip_apart(w: &World, pair: [u32; 2], hint: SatHint, bound: &mut f32) -> bool {
    skip_apart_in(w.body_bounds.as_slice(), pair, hint, bound)
}

/// [`skip_apart`] with the step's motion bounds `b` ([`World::body_bounds`]); also the
/// scalar part of the lanes' pass (`apart_lanes::skip_pass`).
#[inline(always)]
pub(super) fn skip_apart_in(
    b: &[BodyBound],
    [i, j]: [u32; 2],
    hint: SatHint,
    bound: &mut f32,
) -> bool {
    // Not `*bound <= 0.0`: a NaN bound is not skipped, as in `remembered_narrow`.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if is_contact_hint(hint) || !(*bound > 0.0) {
        return false;
    }
    let left = *bound - (b[i as usize].moved + b[j as usize].moved);
    if left > 0.0 {
        *bound = left;
        return true;
    }
    false
}

/// A contact that stopped touching: zero force and springs (written only on the change).
#[inline]
pub(super) fn release(
    force: &mut ContactForce,
    hist: &mut Vec3,
    twist: Option<&mut f32>,
    touching: &mut bool,
) {
    *force = ContactForce::default();
    *hist = Vec3::ZERO;
    if let Some(t) = twist {
        *t = 0.0;
    }
    *touching = false;
}

#[cfg(test)]
#[path = "contacts_tests.rs"]
pub(super) mod tests;
