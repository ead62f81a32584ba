//! Sinks: axis-aligned boxes that take bodies out of the simulation (a silo's outlet, a
//! conveyor's end). A body whose centre is inside a sink's closed box `[min, max]` after the
//! position update of a step is **removed**: it stays in the body arrays (indices never
//! change, so pair lists, determinism and checkpoints stay simple) but is no longer
//! integrated, takes part in no contact, and counts in no kinetic energy, momentum or
//! blow-up check; outputs leave it out. The test is the same in f32 on both backends
//! (`integrate.wgsl` `in_sink`).

use glam::Vec3;

/// One sink box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sink {
    /// Lower corner, m.
    pub min: Vec3,
    /// Upper corner, m (at least `min` along every axis).
    pub max: Vec3,
}

impl Sink {
    /// Whether `p` is inside the closed box (false for a NaN coordinate).
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// Whether `p` is inside any of `sinks`.
#[inline]
pub fn in_any(sinks: &[Sink], p: Vec3) -> bool {
    sinks.iter().any(|s| s.contains(p))
}

/// The bodies removed so far and their total mass.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Discharged {
    /// Number of removed bodies.
    pub count: u64,
    /// Their total mass, kg (summed in f64 in body order: exact and the same on every
    /// backend and thread count).
    pub mass: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_box() {
        let s = Sink {
            min: Vec3::new(0.0, 0.0, 0.0),
            max: Vec3::new(1.0, 2.0, 3.0),
        };
        assert!(s.contains(Vec3::new(0.0, 0.0, 0.0)));
        assert!(s.contains(Vec3::new(1.0, 2.0, 3.0)));
        assert!(s.contains(Vec3::new(0.5, 1.0, 1.5)));
        assert!(!s.contains(Vec3::new(-1e-7, 1.0, 1.0)));
        assert!(!s.contains(Vec3::new(0.5, 2.0001, 1.0)));
        assert!(!s.contains(Vec3::new(f32::NAN, 1.0, 1.0)));
        assert!(!in_any(&[], Vec3::ZERO));
        assert!(in_any(&[s], Vec3::ONE));
    }
}
