//! The work balance: cuts that divide summed weights (`Bisection::weighted`) against the
//! weights summed per box by brute force, and a decomposition balanced by work that steps a
//! pile bitwise as one process does.

use super::*;

/// A pile whose work is uneven: a slab of bodies, those in the left quarter weighing 21
/// (deep in a pile: many pairs, many ghost copies), the others 1, with ties (a lattice row
/// sharing coordinates). The weighted cuts give every rank about the same summed weight,
/// summed by brute force over every body in each rank's box (the boxes tile space), where
/// cuts by count leave the ranks over the heavy quarter several times the mean; and the same
/// cuts come out when each rank holds a share of the bodies (histograms summed over ranks).
#[test]
fn weighted_cuts_balance_uneven_work_by_brute_force() {
    use clatter::domain::Bisection;
    let mut u = uniform(29);
    let mut pts: Vec<Vec3> = (0..12000)
        .map(|_| Vec3::new(4.0 * u(), 2.0 * u(), 0.3 * u()))
        .collect();
    pts.extend((0..200).map(|k| Vec3::new(0.5, k as f32 * 0.01, 0.1)));
    let weights: Vec<u64> = pts.iter().map(|p| if p.x < 1.0 { 21 } else { 1 }).collect();
    let total: u64 = weights.iter().sum();
    let heaviest = 21.0;
    // Every rank's summed weight, by brute force: each body in exactly one box.
    let loads = |b: &Bisection, ranks: usize| {
        let mut load = vec![0u64; ranks];
        for (p, &w) in pts.iter().zip(&weights) {
            let x = p.as_dvec3();
            let inside: Vec<usize> = (0..ranks)
                .filter(|&r| {
                    let reg = b.region(r);
                    (0..3).all(|a| reg[a][0] <= x[a] && x[a] < reg[a][1])
                })
                .collect();
            assert_eq!(inside.len(), 1, "{p} in boxes {inside:?}");
            load[inside[0]] += w;
        }
        load
    };
    for ranks in [2, 3, 4, 5, 7, 8, 16] {
        let weighted = Bisection::weighted(&pts, &weights, ranks, None, None);
        let load = loads(&weighted, ranks);
        assert_eq!(load.iter().sum::<u64>(), total);
        let imbalance = Bisection::imbalance(&load);
        // Each level's cut is within 0.1% of its node's weight and a body's weight of its
        // share; four levels at most (16 ranks).
        let mean = total as f64 / ranks as f64;
        let bound = 4.0 * (1e-3 + heaviest / mean);
        let by_count =
            Bisection::imbalance(&loads(&Bisection::balanced(&pts, ranks, None, None), ranks));
        eprintln!(
            "{ranks} ranks: weighted {load:?} (imbalance {imbalance:.4}, bound {bound:.4}); by count {by_count:.3}"
        );
        assert!(imbalance <= bound, "{ranks} ranks: {load:?} ({imbalance})");
        assert!(
            by_count > 0.5,
            "{ranks} ranks: the pile is not uneven ({by_count})"
        );
        // The same cuts from shares of the bodies, histograms summed over the ranks.
        let shared: Vec<Bisection> = std::thread::scope(|scope| {
            let handles: Vec<_> = ThreadComm::group(ranks)
                .into_iter()
                .map(|comm| {
                    let mine: Vec<usize> = (0..pts.len())
                        .filter(|i| (i * 5 + i / 7) % ranks == comm.rank())
                        .collect();
                    let (p, w): (Vec<Vec3>, Vec<u64>) =
                        mine.iter().map(|&i| (pts[i], weights[i])).unzip();
                    scope.spawn(move || Bisection::weighted(&p, &w, comm.size(), None, Some(&comm)))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("rank thread"))
                .collect()
        });
        assert!(
            shared.iter().all(|s| *s == weighted),
            "{ranks} ranks: shares give other cuts"
        );
        // Unit weights are the cuts by count.
        let ones = vec![1; pts.len()];
        assert_eq!(
            Bisection::weighted(&pts, &ones, ranks, None, None),
            Bisection::balanced(&pts, ranks, None, None)
        );
    }
}

/// A shaken sphere pile (bodies cross the boxes, and the boxes are cut again) stepped on 3
/// thread ranks with the boxes balanced by bodies and by work: both end bitwise as one
/// process does (a new world is first cut by bodies, then recut by work once it has pairs:
/// at least two cuts).
#[test]
fn both_balances_step_a_shaken_pile_bitwise_as_one_process() {
    use clatter::domain::{Balance, Bisection};
    let mut desc = pile(PileShape::Sphere, 400, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 2.0;
    }
    let world = World::new(desc);
    let steps = 400;
    let expected = one_process(world.clone(), steps);
    for balance in [Balance::Bodies, Balance::Work] {
        let (end, taken) = on_ranks_with(
            &world,
            3,
            steps,
            |w, rank, ranks| Domain::with_balance(w, rank, ranks, balance),
            |_| {},
            |d, _| (d.work(), d.recuts()),
        );
        let work: Vec<u64> = taken.iter().map(|t| t.0).collect();
        let recuts = taken[0].1;
        eprintln!(
            "{balance:?}: estimated work {work:?} (imbalance {:.4}), recuts {recuts}",
            Bisection::imbalance(&work),
        );
        assert!(end == expected, "{balance:?}: not one process's end");
        if balance == Balance::Work {
            assert!(recuts >= 2, "the pile should be cut again");
            assert!(work.iter().all(|&w| w > 0));
        }
    }
}
