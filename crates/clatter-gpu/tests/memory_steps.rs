//! The GPU step's remembered contacts against the full test, step by step (issue 23): two
//! GPU worlds from the same poured pile, one as it runs (touching polyhedron pairs reuse
//! their remembered face or edge contact while its margin lasts), one with
//! `GpuWorld::set_full_test` (every contact from the full separating-axis test). Both must
//! stay bitwise equal at every step, body by body and pair by pair; the first pair whose
//! force differs is named.
//!
//! A pair slot's memory word outlives its contact: the pair parts (the word stays), or a
//! rebuild gives the slot to another pair. A word left so must never be read as the new
//! contact's: before this test, a pair that started touching with nothing to remember kept
//! the old word, and the next step clipped a stale reference face or searched a stale edge
//! contact (seen first on the default scene resumed at step 14,000: forces of 3.7 N
//! against the full test's 0.011 N). Here the slots of pairs that do not touch are filled
//! before every step with such leftovers, remembered face or edge contacts with margins to
//! spare, and the Verlet skin is small, so that rebuilds (every few steps) hand the slots
//! of touching pairs to other pairs.

use clatter::World;
use clatter::geom::narrow;
use clatter::pile::{PileParams, PileShape, poured};
use clatter_gpu::GpuWorld;

/// The GPU's `axis_motion_bound` (contacts.wgsl, no composites) on `w`'s state, for pair
/// `(i, j)`: how much the margin shrinks this step is twice it.
fn axis_motion(w: &World, i: usize, j: usize) -> f32 {
    let s = &w.state;
    let (ri, rj) = (w.consts.radius[i], w.consts.radius[j]);
    let d = w.pose_from(i, j).position;
    let (vi, vj) = (s.velocity[i], s.velocity[j]);
    let moved = ((vj - vi).length() + (vi.length() + vj.length()) * (1.0 / 4_194_304.0)) * w.dt;
    let rho = clatter::contract::TURN_ROUNDING;
    let (ti, tj) = (
        s.omega[i].length() * w.dt + rho,
        s.omega[j].length() * w.dt + rho,
    );
    let far = d.length() + moved;
    let turn = (tj * rj + ti * (far + rj)).max(ti * ri + tj * (far + ri));
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    (moved + turn) * 1.000_01 + (l1 * (1.0 / 8_388_608.0) + (ri + rj) * (1.0 / 16_777_216.0))
}

/// A stage buffer as words.
fn words(gpu: &GpuWorld, name: &str) -> Vec<u32> {
    bytemuck::pod_collect_to_vec(&gpu.debug_buffer(name).expect("stage buffer"))
}

/// What the slots of pairs that do not touch are filled with: one of the words an earlier
/// contact could have left (a remembered face of A or of B, or an edge contact), with a
/// margin no step uses up.
fn leftover(k: usize) -> [u32; 2] {
    let hint = match k % 3 {
        0 => narrow::HINT_EDGE_CONTACT,
        1 => narrow::HINT_FACE_A | narrow::HINT_CONTACT | (k % 4) as u32,
        _ => narrow::HINT_FACE_B | narrow::HINT_CONTACT | (k % 4) as u32,
    };
    [hint, 1.0f32.to_bits()]
}

#[test]
fn remembered_contacts_give_the_full_tests_bits_step_by_step() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let params = PileParams {
        restitution: 0.1,
        ..PileParams::default()
    };
    let mut cpu = World::new(poured(PileShape::Mixed, 128, &params, 11));
    for _ in 0..3000 {
        cpu.step().expect("CPU step");
    }
    // A rebuild every few steps: touching pairs' slots go to other pairs often.
    cpu.skin = 1e-4;
    let mut gpu = GpuWorld::new(ctx.clone(), &cpu).expect("scene fits");
    let mut full = GpuWorld::new(ctx, &cpu).expect("scene fits");
    full.set_full_test(true);
    let mut host = cpu.clone();
    let is_poly = |w: &World, i: usize| matches!(w.shape(i), clatter::geom::Shape::Polyhedron(_));
    // Pair-steps offered a remembered contact (touching, a contact hint, margin left after
    // the step's bound), and pairs that started touching on a step without a rebuild.
    let (mut offered, mut started) = (0usize, 0usize);
    let steps = 300;
    for step in 0..steps {
        gpu.read_into(&mut host).expect("read-back");
        let (t0, mut m0) = (words(&gpu, "touching"), words(&gpu, "pair_memory"));
        let pairs0 = words(&gpu, "pairs");
        let np = (pairs0.len() / 2).min(t0.len()).min(gpu.pairs());
        for k in 0..np {
            if t0[k] != 1 {
                // The slot's own word (an earlier contact's) made to last, or a leftover.
                let own = m0[2 * k];
                let word = if narrow::is_contact_hint(own) {
                    [own, 1.0f32.to_bits()]
                } else {
                    leftover(k)
                };
                m0[2 * k..2 * k + 2].copy_from_slice(&word);
            }
        }
        gpu.debug_write_pair_memory(&m0).expect("pair memory");
        let rebuilds = gpu.rebuilds();
        gpu.step(1).expect("GPU step");
        full.step(1).expect("GPU step, full test");
        if gpu.rebuilds() == rebuilds {
            let t1 = words(&gpu, "touching");
            for k in 0..np {
                let (i, j) = (pairs0[2 * k] as usize, pairs0[2 * k + 1] as usize);
                if !is_poly(&host, i) || !is_poly(&host, j) {
                    continue;
                }
                let margin = f32::from_bits(m0[2 * k + 1]) - 2.0 * axis_motion(&host, i, j);
                if t0[k] == 1 && narrow::is_contact_hint(m0[2 * k]) && margin > 0.0 {
                    offered += 1;
                }
                started += (t0[k] != 1 && t1[k] == 1) as usize;
            }
        }
        let (a, b) = (gpu.read_states().unwrap(), full.read_states().unwrap());
        if bytemuck::cast_slice::<_, u8>(&a) == bytemuck::cast_slice::<_, u8>(&b) {
            continue;
        }
        // The first pair (in the remembering world's list) whose contact differs.
        let (ca, cb) = (gpu.contact_state().unwrap(), full.contact_state().unwrap());
        let slot_b = |p: &[u32; 2]| cb.pairs.binary_search(p).ok();
        for (k, p) in ca.pairs.iter().enumerate() {
            let same = slot_b(p).is_some_and(|kb| {
                ca.touching[k] == cb.touching[kb]
                    && bytemuck::bytes_of(&ca.forces[k]) == bytemuck::bytes_of(&cb.forces[kb])
            });
            let was = (0..np)
                .find(|&c| pairs0[2 * c] == p[0] && pairs0[2 * c + 1] == p[1])
                .map(|c| (t0[c], m0[2 * c], f32::from_bits(m0[2 * c + 1])));
            assert!(
                same,
                "step {step}: pair {p:?} differs: remembering {:?}, full test {:?}; before the step (touching, hint, margin) {was:x?}",
                ca.forces[k],
                slot_b(p).map(|kb| cb.forces[kb]),
            );
        }
        panic!("step {step}: the bodies differ, their contacts do not");
    }
    eprintln!(
        "{steps} steps bitwise equal ({} rebuilds); {offered} pair-steps offered a remembered contact, {started} pairs started touching between rebuilds",
        gpu.rebuilds()
    );
    assert!(gpu.rebuilds() > 30, "too few rebuilds: {}", gpu.rebuilds());
    assert!(offered > 300, "too few remembered pair-steps: {offered}");
}
