//! A step's stats on ranks: the touching contacts each rank reports for its share
//! (`StepStats::contacts`), summed over the ranks, are one process's count at every step
//! (the blocking step takes them from its contact stage's count, less the pairs whose first
//! body is a ghost; the overlapped step from the flags).

use super::*;

/// One process's touching contacts after each of `steps` steps.
fn per_step(mut w: World, steps: usize) -> Vec<usize> {
    (0..steps)
        .map(|_| w.step().expect("one process steps").contacts)
        .collect()
}

/// The same on `ranks` thread ranks: each step's contacts summed over the ranks.
fn per_step_on_ranks(world: &World, ranks: usize, steps: usize, overlap: bool) -> Vec<usize> {
    let counts: Vec<Vec<usize>> = std::thread::scope(|scope| {
        let handles: Vec<_> = ThreadComm::group(ranks)
            .into_iter()
            .map(|comm| {
                let w = world.clone();
                scope.spawn(move || {
                    let mut d = Domain::new(w, comm.rank(), comm.size());
                    d.set_overlap(overlap);
                    (0..steps)
                        .map(|_| d.step(&comm).expect("ranks step").contacts)
                        .collect::<Vec<usize>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    });
    (0..steps)
        .map(|k| counts.iter().map(|c| c[k]).sum())
        .collect()
}

/// Shaken spheres and a mixed polyhedron pile in their boxes (pairs and wall contacts
/// that come and go), on 2 and 3 ranks, blocking and overlapped.
#[test]
fn step_contacts_summed_over_ranks_are_one_process_count_at_every_step() {
    let mut spheres = pile(PileShape::Sphere, 400, &PileParams::default());
    for (i, b) in spheres.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 2.0;
    }
    let mixed = pile(PileShape::Mixed, 200, &PileParams::default());
    for (name, world, steps) in [
        ("sphere pile", World::new(spheres), 300),
        ("mixed pile", World::new(mixed), 200),
    ] {
        let want = per_step(world.clone(), steps);
        assert!(
            want.iter().any(|&n| n > 0),
            "{name}: some contacts touch ({want:?})"
        );
        for ranks in [2, 3] {
            for overlap in [false, true] {
                let got = per_step_on_ranks(&world, ranks, steps, overlap);
                let first = got.iter().zip(&want).position(|(a, b)| a != b);
                assert!(
                    first.is_none(),
                    "{name} on {ranks} ranks (overlap {overlap}): step {first:?} counts {:?}, \
                     one process {:?}",
                    first.map(|k| got[k]),
                    first.map(|k| want[k])
                );
            }
        }
    }
}
