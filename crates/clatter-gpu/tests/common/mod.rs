//! What the narrow-phase tests share: random poses, the comparison of a GPU manifold with
//! the CPU's (to rounding, near-ties excused under pose perturbations), and a bound of how
//! far the separating-axis test's separations move between two poses of a pair.
#![allow(dead_code)] // each test binary uses its own part

use clatter_geom::Pose;
use clatter_geom::narrow::{self, Manifold};
use glam::{Quat, Vec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

pub fn random_unit(rng: &mut ChaCha8Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return v / l.sqrt();
        }
    }
}

pub fn random_quat(rng: &mut ChaCha8Rng) -> Quat {
    loop {
        let q = Quat::from_xyzw(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = q.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return q.normalize();
        }
    }
}

/// Tolerances, relative to the pair's size for lengths.
pub const NORMAL_TOL: f32 = 1e-4;

pub const POINT_TOL: f32 = 1e-4;

/// How a GPU manifold compares to the CPU's.
#[derive(Debug, PartialEq)]
pub enum Agreement {
    /// Same contact, count, normal, points in order.
    Same,
    /// Same points, in another order.
    Order,
    /// Anything else.
    Differ(String),
}

/// Largest errors over agreeing manifolds (lengths relative to the size).
#[derive(Default, Debug)]
pub struct Errors {
    pub normal: f32,
    pub point: f32,
    pub depth: f32,
}

pub fn agree(
    cpu: Option<&Manifold>,
    gpu: &Manifold,
    size: f32,
    tol: f32,
    err: &mut Errors,
) -> Agreement {
    let Some(cpu) = cpu else {
        return if gpu.count == 0 {
            Agreement::Same
        } else {
            Agreement::Differ(format!("CPU: no contact, GPU: {} points", gpu.count))
        };
    };
    if gpu.count == 0 {
        return Agreement::Differ(format!("CPU: {} points, GPU: no contact", cpu.count));
    }
    if cpu.count != gpu.count {
        return Agreement::Differ(format!("count CPU {} GPU {}", cpu.count, gpu.count));
    }
    let dn = (cpu.normal - gpu.normal).length();
    if dn > NORMAL_TOL * tol {
        return Agreement::Differ(format!("normal CPU {} GPU {}", cpu.normal, gpu.normal));
    }
    let close = |a: &narrow::ContactPoint, b: &narrow::ContactPoint| {
        (a.point - b.point).length() <= POINT_TOL * tol * size
            && (a.depth - b.depth).abs() <= POINT_TOL * tol * size
    };
    let mut e = Errors {
        normal: dn,
        ..Default::default()
    };
    let in_order = cpu.points().iter().zip(gpu.points()).all(|(a, b)| {
        e.point = e.point.max((a.point - b.point).length() / size);
        e.depth = e.depth.max((a.depth - b.depth).abs() / size);
        close(a, b)
    });
    let result = if in_order {
        Agreement::Same
    } else {
        // The same points in another order?
        let mut used = [false; 4];
        let all = cpu.points().iter().all(|a| {
            let hit = (0..gpu.count).find(|&j| !used[j] && close(a, &gpu.points[j]));
            if let Some(j) = hit {
                used[j] = true;
            }
            hit.is_some()
        });
        if all {
            Agreement::Order
        } else {
            return Agreement::Differ(format!(
                "points CPU {:?} GPU {:?}",
                cpu.points(),
                gpu.points()
            ));
        }
    };
    err.normal = err.normal.max(e.normal);
    if result == Agreement::Same {
        err.point = err.point.max(e.point);
        err.depth = err.depth.max(e.depth);
    }
    result
}

/// A pose moved by `eps` (a length) and turned by `eps / size` radians at random.
pub fn perturb(p: &Pose, eps: f32, size: f32, rng: &mut ChaCha8Rng) -> Pose {
    let turn = Quat::from_axis_angle(random_unit(rng), eps / size);
    Pose::new(
        p.position + random_unit(rng) * eps,
        (turn * p.rotation).normalize(),
    )
}

/// Whether a mismatch is a near-tie of the CPU: under small perturbations of the poses the
/// CPU's own answer changes, or becomes the GPU's answer.
pub fn is_near_tie(
    cpu: Option<&Manifold>,
    gpu: &Manifold,
    size: f32,
    eval: &dyn Fn(&Pose, &Pose) -> Option<Manifold>,
    pa: &Pose,
    pb: &Pose,
    rng: &mut ChaCha8Rng,
) -> bool {
    let eps = 1e-5 * size;
    let mut scratch = Errors::default();
    for _ in 0..32 {
        let qa = perturb(pa, eps, size, rng);
        let qb = perturb(pb, eps, size, rng);
        let c = eval(&qa, &qb);
        // Perturbed CPU answers move by ~eps: compare with a 20x looser tolerance.
        let c_as_gpu = c.unwrap_or_default();
        if agree(cpu, &c_as_gpu, size, 20.0, &mut scratch) != Agreement::Same {
            return true;
        }
        if agree(c.as_ref(), gpu, size, 20.0, &mut scratch) == Agreement::Same {
            return true;
        }
    }
    false
}

#[derive(Default, Debug)]
pub struct Stats {
    /// Queries that involve only generic shapes (spheres, random hulls), and their near-ties.
    pub generic: usize,
    pub generic_ties: usize,
    pub tested: usize,
    pub contacts: usize,
    pub max_points: usize,
    pub near_ties: usize,
    pub order_ties: usize,
    pub hard: Vec<String>,
    pub err: Errors,
}

impl Stats {
    #[allow(clippy::too_many_arguments)]
    pub fn check(
        &mut self,
        generic: bool,
        label: &str,
        cpu: Option<Manifold>,
        gpu: &Manifold,
        size: f32,
        eval: &dyn Fn(&Pose, &Pose) -> Option<Manifold>,
        pa: &Pose,
        pb: &Pose,
        rng: &mut ChaCha8Rng,
    ) {
        self.tested += 1;
        self.generic += generic as usize;
        if let Some(m) = &cpu {
            self.contacts += 1;
            self.max_points = self.max_points.max(m.count);
        }
        match agree(cpu.as_ref(), gpu, size, 1.0, &mut self.err) {
            Agreement::Same => {}
            Agreement::Order | Agreement::Differ(_)
                if is_near_tie(cpu.as_ref(), gpu, size, eval, pa, pb, rng) =>
            {
                if self.near_ties < 5 {
                    eprintln!(
                        "  near-tie {label}: {:?}",
                        agree(cpu.as_ref(), gpu, size, 1.0, &mut Errors::default())
                    );
                }
                self.near_ties += 1;
                self.generic_ties += generic as usize;
            }
            Agreement::Order => {
                self.order_ties += 1;
                self.hard
                    .push(format!("{label}: point order differs and is not ambiguous"));
            }
            Agreement::Differ(why) => self.hard.push(format!("{label}: {why}")),
        }
    }

    pub fn report(&self, what: &str) {
        eprintln!(
            "{what}: {} tested, {} contacts (up to {} points), {} near-tie mismatches ({:.3}%; {} of {} generic-shape queries = {:.3}%), {} hard mismatches; max |normal error| {:.2e}, max point error {:.2e} x size, max depth error {:.2e} x size",
            self.tested,
            self.contacts,
            self.max_points,
            self.near_ties,
            100.0 * self.near_ties as f64 / self.tested.max(1) as f64,
            self.generic_ties,
            self.generic,
            100.0 * self.generic_ties as f64 / self.generic.max(1) as f64,
            self.hard.len(),
            self.err.normal,
            self.err.point,
            self.err.depth
        );
        for h in self.hard.iter().take(20) {
            eprintln!("  {h}");
        }
        assert!(
            self.hard.is_empty(),
            "{what}: {} hard mismatches",
            self.hard.len()
        );
        assert!(self.generic >= 500, "{what}: too few generic-shape queries");
        assert!(
            self.generic_ties * 200 <= self.generic,
            "{what}: too many near-tie mismatches on generic shapes ({} of {})",
            self.generic_ties,
            self.generic
        );
        // Symmetric shapes tie exactly far more often (see is_symmetric); still bounded.
        assert!(
            self.near_ties * 25 <= self.tested,
            "{what}: too many near-tie mismatches ({} of {})",
            self.near_ties,
            self.tested
        );
    }
}

/// The rotation angle from `p` to `q` (rad), in f64 from the vector part of `q p^-1` (an
/// `acos` of their dot product loses small angles entirely in f32).
pub fn turn_angle(p: Quat, q: Quat) -> f32 {
    let d = q.as_dquat() * p.as_dquat().conjugate();
    (2.0 * d.xyz().length().atan2(d.w.abs())) as f32
}

/// A bound of how much any separation of the separating-axis test moved from `(pa0, pb0)` to
/// `(pa1, pb1)` (the CPU's `axis_motion_bound` with the actual motion, and its rounding
/// terms doubled for the positions off the origin).
pub fn axis_motion(pa0: &Pose, pb0: &Pose, pa1: &Pose, pb1: &Pose, r: f32) -> f32 {
    let l1 = |v: Vec3| v.x.abs() + v.y.abs() + v.z.abs();
    let moved = l1(pa1.position - pa0.position) + l1(pb1.position - pb0.position);
    let turned = (turn_angle(pa0.rotation, pa1.rotation) + turn_angle(pb0.rotation, pb1.rotation))
        * 1.001
        + 1e-6;
    let x = l1(pa1.position) + l1(pb1.position);
    (moved + turned * 2.0 * r) * 1.000_01 + x * (2.0 / 8_388_608.0) + 4e-6 * r
}
