//! The CPU pipeline is deterministic: the same scene gives bitwise identical states whatever the
//! number of rayon threads, and run after run (forces are gathered per body in a fixed order,
//! pair lists are sorted, no float atomics).

use clatter::World;
use clatter::pile::{PileParams, PileShape, pile};
use glam::Vec3;

/// Every state bit of every body, in order.
fn snapshot(w: &World) -> Vec<u32> {
    let mut out = Vec::with_capacity(w.len() * 16);
    for i in 0..w.len() {
        out.extend(w.state.position[i].to_array().into_iter().flat_map(|v| {
            let b = v.to_bits();
            [b as u32, (b >> 32) as u32]
        }));
        out.extend(w.state.velocity[i].to_array().map(f32::to_bits));
        out.extend(w.state.orientation[i].to_array().map(f32::to_bits));
        out.extend(w.state.angular_momentum[i].to_array().map(f32::to_bits));
        out.extend(w.state.omega[i].to_array().map(f32::to_bits));
    }
    out
}

struct Run {
    state: Vec<u32>,
    contacts: Vec<usize>,
    pairs: Vec<[u32; 2]>,
    rebuilds: u64,
}

/// A mixed pile (the five Platonic solids and spheres, random orientations) dropped into its
/// box and given a shake: every body starts with a different velocity and spin so contacts
/// form and break all the time.
fn run(threads: usize, n: usize, steps: usize) -> Run {
    run_pile(PileShape::Mixed, threads, n, steps)
}

/// [`run`] for a pile of any shape.
fn run_pile(shape: PileShape, threads: usize, n: usize, steps: usize) -> Run {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut desc = pile(shape, n, &PileParams::default());
        for (i, b) in desc.bodies.iter_mut().enumerate() {
            let f = i as f32;
            b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 1.5;
            b.angular_velocity =
                Vec3::new((f * 0.29).cos(), (f * 0.53).sin(), (f * 0.97).cos()) * 30.0;
        }
        let mut w = World::new(desc);
        let mut contacts = Vec::with_capacity(steps);
        for _ in 0..steps {
            contacts.push(w.step().unwrap().contacts);
        }
        Run {
            state: snapshot(&w),
            contacts,
            pairs: w.touching_pairs(),
            rebuilds: w.rebuilds,
        }
    })
}

fn first_difference(a: &[u32], b: &[u32]) -> Option<usize> {
    a.iter().zip(b).position(|(x, y)| x != y)
}

#[test]
fn same_bits_for_1_2_3_threads_and_repeated_runs() {
    // Enough bodies (and contacts) that every parallel stage is split into at least three
    // chunks (the sphere loops' tasks are 1024 items; the polyhedron pairs' at most 64; the
    // integrate stage's cut by the thread count, so each count here cuts it differently): a
    // few hundred bodies would run each stage in one chunk whatever the thread count, and
    // prove nothing.
    let (n, steps) = (3300, 300);
    let reference = run(1, n, steps);
    let total: usize = reference.contacts.iter().sum();
    eprintln!(
        "{n} bodies, {steps} steps: {total} contact-steps, {} at the end, {} rebuilds",
        reference.contacts[steps - 1],
        reference.rebuilds
    );
    assert!(
        reference.contacts[steps / 2..].iter().all(|&c| c > n / 10),
        "the pile should be in contact"
    );
    assert!(
        reference.rebuilds > 1,
        "the broad phase should have been rebuilt"
    );
    for threads in [1, 2, 3, 2] {
        let other = run(threads, n, steps);
        assert_eq!(
            other.contacts, reference.contacts,
            "{threads} threads: contact counts differ"
        );
        assert_eq!(
            other.pairs, reference.pairs,
            "{threads} threads: touching pairs differ"
        );
        assert_eq!(
            other.rebuilds, reference.rebuilds,
            "{threads} threads: rebuilds differ"
        );
        if let Some(k) = first_difference(&other.state, &reference.state) {
            panic!(
                "{threads} threads: state differs first at body {}, word {}",
                k / 16,
                k % 16
            );
        }
    }
}

#[test]
fn same_bits_with_and_without_the_avx2_builds() {
    // The hot stages run AVX2 builds of the same arithmetic where the CPU has it
    // (`step::vex`); turned off, they run the baseline x86-64 build. Both must give the
    // same bits (other tests in this binary may run meanwhile: they see the same bits too).
    if !clatter::step::avx2() {
        eprintln!("this CPU has no AVX2 (or it is off): both runs take the same build");
    }
    for shape in [PileShape::Sphere, PileShape::Mixed] {
        let (n, steps) = (600, 300);
        clatter::step::set_avx2(false);
        let baseline = run_pile(shape, 1, n, steps);
        clatter::step::set_avx2(true);
        let avx2 = run_pile(shape, 1, n, steps);
        let total: usize = baseline.contacts.iter().sum();
        assert!(
            total > n * steps / 10,
            "{shape:?}: the pile should be in contact"
        );
        assert_eq!(
            avx2.contacts, baseline.contacts,
            "{shape:?}: contact counts differ"
        );
        assert_eq!(
            avx2.pairs, baseline.pairs,
            "{shape:?}: touching pairs differ"
        );
        if let Some(k) = first_difference(&avx2.state, &baseline.state) {
            panic!(
                "{shape:?}: state differs first at body {}, word {}",
                k / 16,
                k % 16
            );
        }
    }
}
