//! The domain decomposition (`clatter::domain`) on ranks that are threads of this process
//! (`ThreadComm`): a world stepped on 1, 2, 3 and 4 ranks ends bitwise equal to the same
//! world stepped by `World::step`, with the same contact count and rebuilds. The MPI
//! transport itself is tested by `clatter-cli/tests/mpi/` (feature `mpi`).

use std::path::Path;

use clatter::World;
use clatter::domain::{Comm, Domain, ThreadComm};
use clatter::pile::{PileParams, PileShape, pile};
use clatter::scene::Scene;
use glam::Vec3;

mod balance;
mod bitwise;
mod checks;
mod cuts;
mod ghosts;
mod migration;
mod overlap;
mod stats;
mod traffic;

/// Every state bit of every body, in order.
fn snapshot(w: &World) -> Vec<u64> {
    let mut out = Vec::with_capacity(w.len() * 20);
    for i in 0..w.len() {
        let s = &w.state;
        out.extend(s.position[i].to_array().map(f64::to_bits));
        let f32s = s.velocity[i]
            .to_array()
            .into_iter()
            .chain(s.orientation[i].to_array())
            .chain(s.orientation_residual[i].to_array())
            .chain(s.angular_momentum[i].to_array())
            .chain(s.omega[i].to_array());
        out.extend(f32s.map(|x| x.to_bits() as u64));
        out.push(s.removed[i] as u64);
    }
    out
}

/// What a run ends with: every state bit, the touching contacts, the rebuilds.
#[derive(Debug, PartialEq)]
struct End {
    state: Vec<u64>,
    /// The world's checkpoint: every state bit, the contact list with its springs, forces,
    /// hints and bounds, the rebuild positions, the clock.
    checkpoint: Vec<u8>,
    contacts: usize,
    rebuilds: u64,
    step: u64,
}

fn one_process(mut w: World, steps: usize) -> End {
    for _ in 0..steps {
        w.step().expect("one process steps");
    }
    End {
        state: snapshot(&w),
        checkpoint: w.checkpoint_bytes("test", "", &[]),
        contacts: w.contact_count(),
        rebuilds: w.rebuilds,
        step: w.step_count,
    }
}

/// `world` stepped on `ranks` threads; every rank's gathered end must agree.
fn on_ranks(world: &World, ranks: usize, steps: usize) -> End {
    on_ranks_counted(world, ranks, steps).0
}

/// [`on_ranks`], with the number of bodies handed from one rank to another at rebuilds.
fn on_ranks_counted(world: &World, ranks: usize, steps: usize) -> (End, u64) {
    let (end, handovers) = on_ranks_with(
        world,
        ranks,
        steps,
        Domain::new,
        |_| {},
        |d, comm| comm.sum_u64(d.handed_over()),
    );
    (end, handovers[0])
}

/// How [`on_ranks_with`] makes each rank's domain: [`Domain::new`] with the exchange
/// overlap on or off.
fn with_overlap(overlap: bool) -> impl Fn(World, usize, usize) -> Domain + Sync {
    move |w, rank, ranks| {
        let mut d = Domain::new(w, rank, ranks);
        d.set_overlap(overlap);
        d
    }
}

/// `world` stepped on `ranks` threads, each rank's domain made by `make` (from the world,
/// the rank and the rank count) and given to `after_step` after every step (to look at, or to
/// scramble what no step may read); every rank's gathered end must agree (and rank 0's
/// `gather_root` with it). Also what `take` takes from each rank's domain after the steps
/// (every rank calls it, in the same place: it may be collective), by rank.
fn on_ranks_with<T: Send>(
    world: &World,
    ranks: usize,
    steps: usize,
    make: impl Fn(World, usize, usize) -> Domain + Sync,
    after_step: impl Fn(&mut Domain) + Sync,
    take: impl Fn(&Domain, &ThreadComm) -> T + Sync,
) -> (End, Vec<T>) {
    let ends: Vec<(End, T)> = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(ranks)
            .into_iter()
            .map(|comm| {
                let w = world.clone();
                let (make, after_step, take) = (&make, &after_step, &take);
                scope.spawn(move || {
                    let mut d = make(w, comm.rank(), comm.size());
                    for _ in 0..steps {
                        d.step(&comm).expect("ranks step");
                        after_step(&mut d);
                    }
                    let contacts = d.contact_count(&comm);
                    let taken = take(&d, &comm);
                    let g = d.gather(&comm);
                    let end = End {
                        state: snapshot(&g),
                        checkpoint: g.checkpoint_bytes("test", "", &[]),
                        contacts,
                        rebuilds: g.rebuilds,
                        step: g.step_count,
                    };
                    // Rank 0 alone gathers the same world (the outputs' gather).
                    let root = d.gather_root(&comm);
                    assert_eq!(
                        root.is_some(),
                        comm.rank() == 0,
                        "gather_root on rank 0 only"
                    );
                    if let Some(root) = root {
                        assert!(
                            root.checkpoint_bytes("test", "", &[]) == end.checkpoint,
                            "gather_root's world differs from gather's"
                        );
                    }
                    (end, taken)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    });
    let (ends, taken): (Vec<End>, Vec<T>) = ends.into_iter().unzip();
    for e in &ends[1..] {
        assert_eq!(e, &ends[0], "ranks disagree");
    }
    (ends.into_iter().next().expect("one rank at least"), taken)
}

fn check(name: &str, world: World, steps: usize) -> u64 {
    let reference = one_process(world.clone(), steps);
    assert!(
        reference.rebuilds > 3,
        "{name}: the run should rebuild ({} rebuilds)",
        reference.rebuilds
    );
    eprintln!(
        "{name}: {} steps, {} rebuilds, {} contacts at the end",
        steps, reference.rebuilds, reference.contacts
    );
    let mut handovers = 0;
    for ranks in 1..=4 {
        let (got, handed) = on_ranks_counted(&world, ranks, steps);
        eprintln!("{name} on {ranks} ranks: {handed} bodies handed over");
        handovers = handovers.max(handed);
        assert_eq!(got.step, reference.step, "{name} on {ranks} ranks: step");
        assert_eq!(
            got.rebuilds, reference.rebuilds,
            "{name} on {ranks} ranks: rebuilds"
        );
        assert_eq!(
            got.contacts, reference.contacts,
            "{name} on {ranks} ranks: contacts"
        );
        let first = got
            .state
            .iter()
            .zip(&reference.state)
            .position(|(a, b)| a != b);
        assert!(
            first.is_none(),
            "{name} on {ranks} ranks: state differs from one process at word {first:?} (body {:?})",
            first.map(|k| k / 20)
        );
        let first = got
            .checkpoint
            .iter()
            .zip(&reference.checkpoint)
            .position(|(a, b)| a != b);
        assert!(
            first.is_none() && got.checkpoint.len() == reference.checkpoint.len(),
            "{name} on {ranks} ranks: the gathered world's checkpoint differs from one process's at byte {first:?} (lengths {} and {})",
            got.checkpoint.len(),
            reference.checkpoint.len()
        );
    }
    handovers
}

fn scene_world(name: &str) -> World {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    Scene::load(&path)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .world()
}

/// A small deterministic generator for the tests below (xorshift64*), uniform in [0, 1).
fn uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed.max(1);
    move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }
}
