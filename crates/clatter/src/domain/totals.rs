//! The whole world's totals of `energy.csv` and `discharge.csv` on a decomposed world
//! ([`Domain::totals`]): each rank sums its own bodies exactly ([`ExactSum`]) and the
//! partial sums are added as integers, so the totals are bitwise those one process finds
//! ([`World::kinetic_energy`], [`World::potential_energy`], [`World::momentum`],
//! [`World::discharged`], which sum exactly too), with no body's state sent anywhere.

use super::Domain;
use super::comm::Comm;
use crate::exact_sum::ExactSum;
use crate::world::World;

/// The whole world's energies, momentum and discharged bodies at one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Totals {
    /// The step.
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// [`World::kinetic_energy`], J.
    pub kinetic: f64,
    /// [`World::potential_energy`], J.
    pub potential: f64,
    /// [`World::momentum`], kg m/s.
    pub momentum: [f64; 3],
    /// [`World::discharged`]'s count.
    pub removed: u64,
    /// [`World::discharged`]'s mass, kg.
    pub removed_mass: f64,
}

impl Domain {
    /// The whole world's totals (collective; the same on every rank): one element-wise
    /// integer sum of `6 x 71 + 1` words (3,416 bytes), whatever the number of bodies.
    pub fn totals(&self, comm: &dyn Comm) -> Totals {
        let w: &World = &self.local;
        let own = || (0..w.len()).filter(|&i| !w.is_ghost(i));
        let kinetic = ExactSum::of(own().map(|i| w.body_kinetic_energy(i)));
        let potential = ExactSum::of(own().map(|i| w.body_potential_energy(i)));
        let momentum = w.momentum_sums(own());
        let removed = own().filter(|&i| w.is_removed(i));
        let mass = ExactSum::of(removed.clone().map(|i| w.consts.mass[i] as f64));
        let sums = [
            &kinetic,
            &potential,
            &momentum[0],
            &momentum[1],
            &momentum[2],
            &mass,
        ];
        let mut words: Vec<u64> = sums.iter().flat_map(|s| s.to_words()).collect();
        words.push(removed.count() as u64);
        comm.sum_u64s(&mut words);
        let total = |k: usize| {
            ExactSum::from_words(&words[k * ExactSum::WORDS..(k + 1) * ExactSum::WORDS])
                .map_or(f64::NAN, |s| s.value())
        };
        Totals {
            step: w.step_count,
            time: w.time,
            kinetic: total(0),
            potential: total(1),
            momentum: [total(2), total(3), total(4)],
            removed: words[6 * ExactSum::WORDS],
            removed_mass: total(5),
        }
    }
}
