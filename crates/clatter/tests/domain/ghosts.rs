//! The ghost states' records (`domain/ghosts.rs`): a world of spheres sends each ghost's
//! position, velocity, spin and removed flag only, and nothing reads the fields it leaves
//! out (orientation, its residual, angular momentum): with those scrambled to NaN on every
//! ghost after every step, the run still ends bitwise one process's. Polyhedra keep the
//! whole state.

use clatter::domain::GhostRecord;

use super::*;

/// `world` on 2 and 3 ranks (or 2 only), overlapped and blocking, every ghost's unsent
/// fields scrambled after every step: bitwise one process's end.
fn scrambled_is_one_process(name: &str, world: &World, steps: usize, rank_counts: &[usize]) {
    let reference = one_process(world.clone(), steps);
    for &ranks in rank_counts {
        for overlap in [false, true] {
            let (end, seen) = on_ranks_with(
                world,
                ranks,
                steps,
                with_overlap(overlap),
                |d| {
                    assert_eq!(d.ghost_record(), GhostRecord::Sphere, "{name}: spheres");
                    d.scramble_unsent_ghost_fields();
                },
                |d, _| d.ghosts(),
            );
            assert!(
                seen.iter().all(|&g| g > 0),
                "{name}: every rank holds ghosts ({seen:?})"
            );
            assert!(
                end == reference,
                "{name} on {ranks} ranks (overlap {overlap}), ghosts' orientation and angular \
                 momentum scrambled: not one process's end"
            );
        }
    }
}

/// Spinning, shaken spheres (contacts with friction and twist, so orientations and angular
/// momenta change every step), and spheres in a turning mesh drum (mesh contacts): nothing
/// reads a ghost sphere's orientation, residual or angular momentum.
#[test]
fn sphere_ghosts_need_only_position_velocity_and_spin() {
    let mut desc = pile(PileShape::Sphere, 400, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin()) * 2.0;
        b.angular_velocity = Vec3::new((f * 0.29).cos(), (f * 0.53).sin(), (f * 0.97).cos()) * 40.0;
    }
    scrambled_is_one_process("sphere pile", &World::new(desc), 500, &[2, 3]);
    let drum = scene_world("drum.toml");
    scrambled_is_one_process("drum", &drum, 1500, &[2]);
}

/// Polyhedra (and a world mixing them with spheres) read a ghost's orientation: the whole
/// state travels, and scrambling is a no-op there.
#[test]
fn polyhedron_ghosts_keep_the_whole_state() {
    for shape in [PileShape::Mixed, PileShape::Sphere] {
        let world = World::new(pile(shape, 120, &PileParams::default()));
        let d = Domain::new(world, 0, 2);
        let want = if shape == PileShape::Sphere {
            GhostRecord::Sphere
        } else {
            GhostRecord::Whole
        };
        assert_eq!(d.ghost_record(), want, "{shape:?}");
        assert!(GhostRecord::Sphere.bytes() < GhostRecord::Whole.bytes());
    }
}
