//! The rebuild's migration (`Domain::migrate`): after every rebuild, each rank holds exactly
//! the bodies its box owns (by their rebuild positions) and every Verlet partner of them,
//! in ascending global id; its owned bodies' states and constants, and the springs of every
//! contact with an owned body, are bitwise those of one process at the same step, in one
//! process's order. Bodies that stay on their rank are copied in place rather than sent to
//! the rank itself, so this is checked on piles shaken so that bodies change rank at many
//! rebuilds.

use std::collections::HashMap;

use clatter::contact_list::ContactState;

use super::*;

/// One process's world at the end of a step that rebuilt: its contact state, states and
/// constants (by global id).
struct Reference {
    contacts: ContactState,
    state: Vec<u64>,
    consts: Vec<u64>,
}

/// The words of one body in [`snapshot`]: position (3), velocity (3), orientation and its
/// residual (4 each), angular momentum and velocity (3 each), removed flag.
const STATE_WORDS: usize = 21;

/// The words of one body in [`consts_of`].
const CONST_WORDS: usize = 13;

/// Every constant bit of body `i` (shape, material, sphere flag, mass, inertia and their
/// inverses, radii).
fn consts_of(w: &World, i: usize) -> Vec<u64> {
    let c = &w.consts;
    let f32s = [
        c.mass[i],
        c.inv_mass[i],
        c.radius[i],
        c.equivalent_radius[i],
    ]
    .into_iter()
    .chain(c.inertia[i].to_array())
    .chain(c.inv_inertia[i].to_array());
    let mut out = vec![
        c.shape[i] as u64,
        c.material[i] as u64,
        c.is_sphere[i] as u64,
    ];
    out.extend(f32s.map(|x| x.to_bits() as u64));
    out
}

/// One process's world after every step that rebuilt, by step.
fn references(mut w: World, steps: usize) -> HashMap<u64, Reference> {
    let mut out = HashMap::new();
    for _ in 0..steps {
        let before = w.rebuilds;
        w.step().expect("one process steps");
        if w.rebuilds > before {
            let consts = (0..w.len()).flat_map(|i| consts_of(&w, i)).collect();
            let reference = Reference {
                contacts: w.contact_state(),
                state: snapshot(&w),
                consts,
            };
            out.insert(w.step_count, reference);
        }
    }
    out
}

/// The springs' bits of pair `k` of `c`.
fn spring_bits(c: &ContactState, k: usize) -> [u32; 4] {
    let h = c.history[k].to_array().map(f32::to_bits);
    [h[0], h[1], h[2], c.twist[k].to_bits()]
}

/// Checks rank `d`'s local world against one process's after the same rebuild step; says
/// whether some spring it compared was not zero.
fn matches_one_process(name: &str, d: &Domain, r: &Reference) -> bool {
    let (local, ids) = (d.local(), d.ids());
    let step = local.step_count;
    assert!(
        ids.windows(2).all(|p| p[0] < p[1]),
        "{name} step {step}: local bodies not in ascending global id"
    );
    let owned: Vec<usize> = (0..local.len()).filter(|&i| !local.is_ghost(i)).collect();
    // Ownership: exactly the bodies whose rebuild position lies in this rank's box.
    let boxes = d.boxes().expect("boxes after a rebuild");
    let at = |g: u32| r.contacts.rebuild_position[g as usize];
    if let Some(&first) = owned.first() {
        let rank = boxes.owner(at(ids[first]));
        let mine = (0..r.contacts.rebuild_position.len() as u32)
            .filter(|&g| boxes.owner(at(g)) == rank)
            .count();
        assert!(
            owned.iter().all(|&i| boxes.owner(at(ids[i])) == rank),
            "{name} step {step}: a body owned here lies in another rank's box"
        );
        assert_eq!(owned.len(), mine, "{name} step {step}: owned bodies");
    }
    // Owned states and constants: one process's, bit for bit.
    let here = snapshot(local);
    assert_eq!(here.len(), STATE_WORDS * local.len());
    let (sw, cw) = (STATE_WORDS, CONST_WORDS);
    for &i in &owned {
        let g = ids[i] as usize;
        assert!(
            here[sw * i..sw * (i + 1)] == r.state[sw * g..sw * (g + 1)],
            "{name} step {step}: body {g}'s state differs from one process's"
        );
        assert!(
            consts_of(local, i) == r.consts[cw * g..cw * (g + 1)],
            "{name} step {step}: body {g}'s constants differ from one process's"
        );
    }
    // Contacts with an owned body: one process's pairs, in its order, with its springs.
    let is_owned = |g: u32| ids.binary_search(&g).is_ok_and(|i| !local.is_ghost(i));
    let c = local.contact_state();
    let got: Vec<([u32; 2], [u32; 4])> = (0..c.pairs.len())
        .filter(|&k| c.pairs[k].iter().any(|&l| !local.is_ghost(l as usize)))
        .map(|k| (c.pairs[k].map(|l| ids[l as usize]), spring_bits(&c, k)))
        .collect();
    let want: Vec<([u32; 2], [u32; 4])> = (0..r.contacts.pairs.len())
        .filter(|&k| r.contacts.pairs[k].iter().any(|&g| is_owned(g)))
        .map(|k| (r.contacts.pairs[k], spring_bits(&r.contacts, k)))
        .collect();
    if let Some(k) = (0..got.len().max(want.len())).find(|&k| got.get(k) != want.get(k)) {
        panic!(
            "{name} step {step}: contact {k} with an owned body: {:?} here, {:?} in one process",
            got.get(k),
            want.get(k)
        );
    }
    // Wall springs of owned bodies: one process's (a slot per body, wall and piece).
    let per = |c: &ContactState, n: usize| c.wall_history.len() / n.max(1);
    let (n, m) = (per(&c, local.len()), per(&r.contacts, r.state.len() / sw));
    assert_eq!(n, m, "{name}: wall slots per body");
    for &i in &owned {
        let g = ids[i] as usize;
        let bits = |c: &ContactState, b: usize| -> Vec<u32> {
            (b * n..(b + 1) * n)
                .flat_map(|s| {
                    let h = c.wall_history[s].to_array();
                    [h[0], h[1], h[2], c.wall_twist[s]].map(f32::to_bits)
                })
                .collect()
        };
        assert!(
            bits(&c, i) == bits(&r.contacts, g),
            "{name} step {step}: body {g}'s wall springs differ from one process's"
        );
    }
    got.iter().any(|p| p.1 != [0; 4])
}

/// `world` on 2 and 3 ranks (blocking steps): after every rebuild each rank matches one
/// process (`matches_one_process`), bodies change rank at rebuilds, and the run ends as
/// one process's.
fn migrates_as_one_process(name: &str, world: &World, steps: usize) {
    let refs = references(world.clone(), steps);
    assert!(refs.len() > 5, "{name}: {} rebuilds", refs.len());
    let reference = one_process(world.clone(), steps);
    for ranks in [2, 3] {
        let checked = std::sync::atomic::AtomicUsize::new(0);
        let springy = std::sync::atomic::AtomicUsize::new(0);
        let (end, handed) = on_ranks_with(
            world,
            ranks,
            steps,
            with_overlap(false),
            |d| {
                if let Some(r) = refs.get(&d.local().step_count) {
                    if matches_one_process(name, d, r) {
                        springy.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    }
                    checked.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
            },
            |d, comm| comm.sum_u64(d.handed_over()),
        );
        let checked = checked.into_inner();
        eprintln!(
            "{name} on {ranks} ranks: {} bodies handed over, {checked} rank-rebuilds checked",
            handed[0]
        );
        assert_eq!(checked, refs.len() * ranks, "{name}: every rebuild checked");
        let springy = springy.into_inner();
        assert!(springy > checked / 2, "{name}: springs carried ({springy})");
        assert!(handed[0] > 30, "{name}: bodies change rank ({})", handed[0]);
        assert!(
            end == reference,
            "{name} on {ranks} ranks: not one process's end"
        );
    }
}

/// Shaken, spinning spheres and a shaken mixed pile (polyhedra carry the whole record and
/// their orientations; the constants differ between shapes): the bodies cross the boxes'
/// faces many times over the run.
#[test]
fn migration_keeps_one_process_order_states_and_springs() {
    for (name, shape, n) in [
        ("spheres", PileShape::Sphere, 400),
        ("mixed", PileShape::Mixed, 160),
    ] {
        let mut desc = pile(shape, n, &PileParams::default());
        for (i, b) in desc.bodies.iter_mut().enumerate() {
            let f = i as f32;
            b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 3.0;
            b.angular_velocity =
                Vec3::new((f * 0.29).cos(), (f * 0.53).sin(), (f * 0.97).cos()) * 40.0;
        }
        migrates_as_one_process(name, &World::new(desc), 600);
    }
}
