//! The overlapped step (`domain/overlap.rs`): the ghost states sent while the contacts
//! with no ghost are computed, the others after. Its two halves both compute pairs, its
//! near-list fallback runs, and the results are bitwise one process's and the blocking
//! step's.

use clatter::domain::Overlapped;

use super::*;

/// `world` stepped on `ranks` thread ranks with the overlap on or off: the gathered end
/// (every rank's must agree) and what each rank's overlapped steps computed.
fn stepped(world: &World, ranks: usize, steps: usize, overlap: bool) -> (End, Vec<Overlapped>) {
    on_ranks_with(
        world,
        ranks,
        steps,
        with_overlap(overlap),
        // Between steps the ghost states are owed exactly when overlapped.
        |d| assert_eq!(d.ghosts_owed(), overlap && ranks > 1),
        |d, _| d.overlapped(),
    )
}

/// Sums over the ranks.
fn total(counts: &[Overlapped]) -> Overlapped {
    counts
        .iter()
        .fold(Overlapped::default(), |a, c| Overlapped {
            steps: a.steps + c.steps,
            interior_pairs: a.interior_pairs + c.interior_pairs,
            ghost_pairs: a.ghost_pairs + c.ghost_pairs,
            waited: a.waited + c.waited,
            fallbacks: a.fallbacks + c.fallbacks,
        })
}

/// A world on 2 and 3 ranks, overlapped: bitwise one process and the blocking step, most
/// steps overlapped, both halves computing pairs; returns the counts summed over the
/// ranks and the runs.
fn both_halves(name: &str, world: &World, steps: usize) -> Overlapped {
    let reference = one_process(world.clone(), steps);
    let mut sum = Overlapped::default();
    for ranks in [2, 3] {
        let (on, counts) = stepped(world, ranks, steps, true);
        let (off, none) = stepped(world, ranks, steps, false);
        assert!(
            on == reference,
            "{name} on {ranks} ranks, overlapped: not one process's"
        );
        assert!(
            off == reference,
            "{name} on {ranks} ranks, blocking: not one process's"
        );
        assert!(
            none.iter().all(|c| *c == Overlapped::default()),
            "{name}: the blocking step overlaps nothing"
        );
        let t = total(&counts);
        eprintln!("{name} on {ranks} ranks: {t:?}");
        for (r, c) in counts.iter().enumerate() {
            // Every step but the rebuilds' (and those after a fallback) overlapped.
            assert!(
                c.steps > steps as u64 / 2,
                "{name}, rank {r} of {ranks}: {c:?}"
            );
            assert!(
                c.interior_pairs > 0 && c.ghost_pairs > 0,
                "{name}, rank {r} of {ranks}: pairs in both halves ({c:?})"
            );
        }
        sum = total(&[sum, t]);
    }
    sum
}

/// Shaken spheres (a near list, which the overlapped step keeps, or falls back from when a
/// ghost has left it): both halves compute pairs, the fallback runs, and the ends are
/// bitwise one process's and the blocking step's.
#[test]
fn overlapped_spheres_compute_both_halves_bitwise() {
    let mut desc = pile(PileShape::Sphere, 400, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 2.0;
    }
    let t = both_halves("sphere pile", &World::new(desc), 600);
    assert!(t.fallbacks > 0, "the near list's fallback ran ({t:?})");
}

/// Polyhedra (no near list: the broad phase's list, its groups found at each rebuild).
#[test]
fn overlapped_polyhedra_compute_both_halves_bitwise() {
    let mut desc = pile(PileShape::Mixed, 300, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 1.5;
        b.angular_velocity = Vec3::new((f * 0.29).cos(), (f * 0.53).sin(), (f * 0.97).cos()) * 30.0;
    }
    let t = both_halves("mixed pile", &World::new(desc), 400);
    assert_eq!(t.fallbacks, 0, "no near list, no fallback");
}
