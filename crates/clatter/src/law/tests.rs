//! The contact laws' tests: the plain forms against the general ones, the law against a frozen copy of its `Vec3` form (bit for bit), and the stored energy and depth against the spring.

use super::*;
use crate::material::{ContactLaw, Material};
use glam::Vec4;

fn params(law: ContactLaw) -> PairParams {
    let m = Material::new("m", 1000.0, law, 0.5, 0.3);
    PairParams::combine(&m, &m)
}

#[test]
fn the_plain_forms_give_the_same_bits_on_plain_pairs() {
    let plain = params(ContactLaw::Linear { stiffness: 2.0e4 });
    assert!(is_plain(&plain));
    let hertz = params(ContactLaw::Hertz {
        youngs_modulus: 1.0e7,
        poisson_ratio: 0.3,
    });
    assert!(!is_plain(&hertz));
    for (field, value) in [(0, 0.1), (1, 0.1), (2, 1.0)] {
        let mut p = plain;
        match field {
            0 => p.rolling_friction = value,
            1 => p.spinning_friction = value,
            _ => p.cohesion_model = COHESION_DMT,
        }
        assert!(!is_plain(&p), "field {field}");
    }
    // Random one-point sphere contacts on the plain law: first steps, contacts inside,
    // separating ones, sticking and sliding springs.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let mut vec = |scale: f32| Vec3::new(unit(), unit(), unit()) * scale;
    for k in 0..20_000 {
        let n = vec(1.0).try_normalize().unwrap_or(Vec3::Z);
        let depth = (vec(1.0).x + 1.0) * 2e-4;
        let c = PairContext {
            params: plain,
            m_eff: 0.01 * (1.5 + vec(1.0).y),
            r_eff: 0.005,
            share: SPHERE_POINT_SHARE,
            dt: 3.3e-5,
        };
        let a = BodyMotion {
            position: Vec3::ZERO,
            velocity: vec(0.5),
            omega: vec(20.0),
        };
        let b = BodyMotion {
            position: n * 0.02,
            velocity: vec(0.5),
            omega: vec(20.0),
        };
        let cp = ContactPoint {
            point: n * (0.01 - 0.5 * depth),
            depth,
        };
        let history = vec(1e-4);
        let coverage = match k % 3 {
            0 => 0.0,
            1 => -1.0,
            _ => (vec(1.0).z + 1.0) * 1e-3,
        };
        let (mut h1, mut c1) = (history, coverage);
        let (mut h2, mut c2) = (history, coverage);
        let general = point_contact_force(&c, n, cp, &a, &b, &mut h1, &mut c1);
        let fast = point_contact_force_in::<true>(&c, n, cp, &a, &b, &mut h2, &mut c2);
        assert_eq!(
            bytemuck::bytes_of(&general),
            bytemuck::bytes_of(&fast),
            "contact {k}"
        );
        assert_eq!(
            h1.to_array().map(f32::to_bits),
            h2.to_array().map(f32::to_bits)
        );
        assert_eq!(c1.to_bits(), c2.to_bits(), "contact {k}");
    }
}

/// The plain patch law ([`contact_force_in`]`::<true>`) against the general one
/// ([`contact_force`], which tests for every model term) on random plain manifolds of one
/// to four points, polyhedron and sphere shares, sticking and sliding springs, twisting
/// springs capped and not: forces, springs and twists bitwise the same.
#[test]
fn the_plain_patch_law_gives_the_same_bits_on_plain_pairs() {
    let plain = params(ContactLaw::Linear { stiffness: 2.0e4 });
    assert!(is_plain(&plain));
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut unit = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let mut vec = |scale: f32| Vec3::new(unit(), unit(), unit()) * scale;
    let (mut patches, mut capped) = (0, 0);
    for k in 0..40_000 {
        let n = vec(1.0).try_normalize().unwrap_or(Vec3::Z);
        let count = 1 + k % 4;
        let share = if count == 1 && k % 8 == 0 {
            SPHERE_POINT_SHARE
        } else {
            POLYHEDRON_POINT_SHARE
        };
        let c = PairContext {
            params: plain,
            m_eff: 0.01 * (1.5 + vec(1.0).y),
            r_eff: 0.005,
            share,
            dt: 3.3e-5,
        };
        let mut m = Manifold {
            normal: n,
            count,
            ..Default::default()
        };
        for cp in &mut m.points[..count] {
            cp.depth = vec(1.0).x * 3e-4 + 1e-4;
            cp.point = n * 0.01 + vec(0.004);
        }
        let a = BodyMotion {
            position: Vec3::ZERO,
            velocity: vec(0.5),
            omega: vec(20.0),
        };
        let b = BodyMotion {
            position: n * 0.02,
            velocity: vec(0.5),
            omega: vec(20.0),
        };
        let history = vec(2e-4);
        let twist = match (count, k % 3) {
            (1, 0) => 0.0,
            (1, 1) => -1.0,
            (1, _) => (vec(1.0).z + 1.0) * 1e-3,
            _ => vec(0.05).x,
        };
        let (mut h1, mut t1) = (history, twist);
        let (mut h2, mut t2) = (history, twist);
        let general = contact_force(&c, &m, &a, &b, &mut h1, &mut t1);
        let fast = contact_force_in::<true>(&c, &m, &a, &b, &mut h2, &mut t2);
        assert_eq!(
            bytemuck::bytes_of(&general),
            bytemuck::bytes_of(&fast),
            "manifold {k}"
        );
        assert_eq!(
            h1.to_array().map(f32::to_bits),
            h2.to_array().map(f32::to_bits),
            "manifold {k}"
        );
        assert_eq!(t1.to_bits(), t2.to_bits(), "manifold {k}");
        if count > 1 {
            patches += 1;
            // The twisting spring capped: it was reset to the cap.
            capped += (t1 != twist + (b.omega - a.omega).dot(n) * c.dt) as usize;
        }
    }
    // Both branches of the twisting law were exercised.
    assert!(
        capped > 100 && capped < patches - 100,
        "{capped} of {patches}"
    );
}

/// The law as it was written with `Vec3` arithmetic (before `MotionA`): the reference the
/// `Vec3A` form must match bit for bit. The scalar parts it shares with the law
/// (`spring`, `damping`, the resolved normal force, adhesion and rolling) are called.
mod reference {
    use super::super::*;

    fn point_velocity(m: &BodyMotion, p: Vec3) -> Vec3 {
        m.velocity + m.omega.cross(p - m.position)
    }

    fn tangential_law(
        c: &PairContext,
        kt: f32,
        n: Vec3,
        vrel: Vec3,
        normal_force: f32,
        eta_t: f32,
        history: &mut Vec3,
    ) -> Vec3 {
        let vt = vrel - n * vrel.dot(n);
        let mut xi = *history;
        let along = xi.dot(n);
        if along != 0.0 {
            let old_len2 = xi.length_squared();
            xi -= n * along;
            let new_len2 = xi.length_squared();
            if new_len2 > 0.0 {
                xi *= (old_len2 / new_len2).sqrt();
            }
        }
        xi += vt * c.dt;
        let cap = c.params.friction * normal_force.max(0.0);
        let spring2 = kt * kt * xi.length_squared();
        if spring2 > cap * cap {
            xi *= cap / spring2.sqrt();
        }
        let mut ft = -kt * xi - eta_t * vt;
        let ft_len2 = ft.length_squared();
        if ft_len2 > cap * cap {
            ft *= cap / ft_len2.sqrt();
        }
        *history = xi;
        ft
    }

    fn point_force(
        c: &PairContext,
        n: Vec3,
        cp: ContactPoint,
        (a, b): (&BodyMotion, &BodyMotion),
        history: &mut Vec3,
        coverage: &mut f32,
    ) -> ContactForce {
        let (p, point, depth) = (&c.params, cp.point, cp.depth);
        let vrel = point_velocity(b, point) - point_velocity(a, point);
        let (fs, k) = spring(p, c.r_eff, depth, c.share);
        let eta = damping(p, c.m_eff, k);
        let fn_ = if c.share == SPHERE_POINT_SHARE {
            resolved_normal_force(c, depth, -vrel.dot(n), (fs, k, eta), coverage)
        } else {
            *coverage = 0.0;
            fs - eta * vrel.dot(n)
        };
        let kt = tangential_stiffness::<false>(c, depth, c.share);
        let eta_t = tangential_damping::<false>(c, kt, eta);
        let ft = tangential_law(c, kt, n, vrel, fn_, eta_t, history);
        let f = n * fn_ + ft;
        let mut out = ContactForce::new(
            f,
            f.cross(point - a.position),
            (point - b.position).cross(f),
            fn_,
        );
        adhesion_and_rolling::<false>(c, n, point, (a, b), fn_, &mut out);
        out
    }

    pub(super) fn contact_force(
        c: &PairContext,
        manifold: &Manifold,
        a: &BodyMotion,
        b: &BodyMotion,
        history: &mut Vec3,
        twist: &mut f32,
    ) -> ContactForce {
        let (p, m_eff, r_eff, share, dt) = (&c.params, c.m_eff, c.r_eff, c.share, c.dt);
        let n = manifold.normal;
        if manifold.count == 1 {
            return point_force(c, n, manifold.points[0], (a, b), history, twist);
        }
        let pts = manifold.points();
        let inv_count = 1.0 / pts.len() as f32;
        let mut springs = [(0.0f32, 0.0f32); 4];
        let mut k_total = 0.0;
        let mut centroid = Vec3::ZERO;
        let mut mean_depth = 0.0;
        for (s, cp) in springs.iter_mut().zip(pts) {
            *s = spring(p, r_eff, cp.depth, share);
            k_total += s.1;
            centroid += cp.point;
            mean_depth += cp.depth;
        }
        centroid *= inv_count;
        mean_depth *= inv_count;
        let eta_total = damping(p, m_eff, k_total);
        let mut out = ContactForce::default();
        for (&(fs, k), cp) in springs.iter().zip(pts) {
            let vrel = point_velocity(b, cp.point) - point_velocity(a, cp.point);
            let eta = if k_total > 0.0 {
                eta_total * k / k_total
            } else {
                0.0
            };
            let fn_i = fs - eta * vrel.dot(n);
            let f = n * fn_i;
            out.force_b += f;
            out.torque_b += (cp.point - b.position).cross(f);
            out.torque_a += f.cross(cp.point - a.position);
            out.normal_force += fn_i;
        }
        let share_total = share * pts.len() as f32;
        let kt = tangential_stiffness::<false>(c, mean_depth, share_total);
        let eta_t = tangential_damping::<false>(c, kt, eta_total);
        let vrel = point_velocity(b, centroid) - point_velocity(a, centroid);
        let ft = tangential_law(c, kt, n, vrel, out.normal_force, eta_t, history);
        out.force_b += ft;
        out.torque_b += (centroid - b.position).cross(ft);
        out.torque_a += ft.cross(centroid - a.position);
        let r_patch = pts
            .iter()
            .map(|cp| (cp.point - centroid).reject_from_normalized(n).length())
            .sum::<f32>()
            * inv_count;
        if r_patch > 0.0 {
            let w_n = (b.omega - a.omega).dot(n);
            let r2 = r_patch * r_patch;
            let k_tw = kt * r2;
            let eta_tw = eta_t * r2;
            *twist += w_n * dt;
            let mut tau = -k_tw * *twist - eta_tw * w_n;
            let cap = p.friction * out.normal_force.max(0.0) * r_patch;
            if tau.abs() > cap {
                tau = cap.copysign(tau);
                *twist = if k_tw > 0.0 { -tau / k_tw } else { 0.0 };
            }
            out.torque_b += n * tau;
            out.torque_a -= n * tau;
        } else {
            *twist = 0.0;
        }
        let normal_force = out.normal_force;
        adhesion_and_rolling::<false>(c, n, centroid, (a, b), normal_force, &mut out);
        out
    }
}

/// The law ([`contact_force`], and [`contact_force_in`]`::<true>` on plain pairs)
/// against [`reference::contact_force`], the same law in `Vec3` arithmetic, on random
/// manifolds of one to four points: linear and Hertz laws, with and without cohesion,
/// rolling and spinning resistance; polyhedron and sphere shares, first steps and
/// contacts inside (coverage), sticking and sliding springs, twisting springs capped
/// and not. Forces, springs, twists and coverages bitwise the same.
#[test]
fn the_law_matches_its_vec3_reference_bitwise() {
    let linear = params(ContactLaw::Linear { stiffness: 2.0e4 });
    let hertz = params(ContactLaw::Hertz {
        youngs_modulus: 1.0e7,
        poisson_ratio: 0.3,
    });
    let mut laws = vec![linear, hertz];
    for base in [linear, hertz] {
        let mut p = base;
        p.cohesion_model = COHESION_DMT;
        p.surface_energy = 0.5;
        p.rolling_friction = 0.1;
        p.spinning_friction = 0.05;
        laws.push(p);
    }
    let mut seed = 0x51_7cc1_b727_220au64;
    let mut unit = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let mut vec = |scale: f32| Vec3::new(unit(), unit(), unit()) * scale;
    let mut capped = [0usize; 2];
    for k in 0..60_000 {
        let params = laws[k % laws.len()];
        let n = vec(1.0).try_normalize().unwrap_or(Vec3::Z);
        let count = 1 + (k / laws.len()) % 4;
        let share = if count == 1 && k % 3 == 0 {
            SPHERE_POINT_SHARE
        } else {
            POLYHEDRON_POINT_SHARE
        };
        let c = PairContext {
            params,
            m_eff: 0.01 * (1.5 + vec(1.0).y),
            r_eff: 0.005,
            share,
            dt: 3.3e-5,
        };
        let mut m = Manifold {
            normal: n,
            count,
            ..Default::default()
        };
        for cp in &mut m.points[..count] {
            cp.depth = vec(1.0).x * 3e-4 + 1e-4;
            cp.point = n * 0.01 + vec(0.004);
        }
        let a = BodyMotion {
            position: vec(0.001),
            velocity: vec(0.5),
            omega: vec(20.0),
        };
        let b = BodyMotion {
            position: n * 0.02,
            velocity: vec(0.5),
            omega: vec(20.0),
        };
        let history = vec(2e-4);
        let twist = match (count, k % 5) {
            (1, 0) => 0.0,
            (1, 1) => -1.0,
            (1, _) => (vec(1.0).z + 1.0) * 1e-3,
            _ => vec(0.05).x,
        };
        let t0 =
            assert_law_is_reference(&c, &m, (&a, &b), (history, twist), &format!("manifold {k}"));
        if count > 1 {
            let free = twist + (b.omega - a.omega).dot(n) * c.dt;
            capped[(t0 != free) as usize] += 1;
        }
    }
    // Both branches of the twisting law were exercised.
    assert!(capped[0] > 1000 && capped[1] > 1000, "{capped:?}");
}

#[test]
fn energy_and_depth_follow_the_spring() {
    for law in [
        ContactLaw::Linear { stiffness: 2.0e4 },
        ContactLaw::Hertz {
            youngs_modulus: 1.0e7,
            poisson_ratio: 0.3,
        },
    ] {
        let p = params(law);
        let (r, share, depth) = (0.01f32, POLYHEDRON_POINT_SHARE, 1.0e-4f32);
        // The energy is the integral of the force (midpoint rule, 10,000 slices).
        let slices = 10_000;
        let h = depth as f64 / slices as f64;
        let integral: f64 = (0..slices)
            .map(|k| spring(&p, r, ((k as f64 + 0.5) * h) as f32, share).0 as f64 * h)
            .sum();
        let e = elastic_energy(&p, r, depth, share);
        assert!(
            (e - integral).abs() < 1e-5 * integral,
            "{law:?}: {e} vs {integral}"
        );
        // The depth at the spring's force is the depth.
        let (f, _) = spring(&p, r, depth, share);
        let d = depth_at_force(&p, r, f, share);
        assert!((d - depth).abs() < 1e-5 * depth, "{law:?}: {d} vs {depth}");
    }
}

/// Awkward values for the patch tests: signed zeros, tiny and ordinary magnitudes.
fn awkward(rng: &mut rand_chacha::ChaCha8Rng, scale: f32) -> f32 {
    use rand::Rng;
    match rng.random_range(0..10) {
        0 => 0.0,
        1 => -0.0,
        2 => rng.random_range(-1.0f32..1.0) * 1e-30,
        _ => rng.random_range(-1.0f32..1.0) * scale,
    }
}

fn awkward_vec(rng: &mut rand_chacha::ChaCha8Rng, scale: f32) -> Vec3 {
    Vec3::new(
        awkward(rng, scale),
        awkward(rng, scale),
        awkward(rng, scale),
    )
}

/// A random manifold of two to four points for the patch tests: depths zero (both signs),
/// negative or positive; points sometimes coincident (a zero patch radius) or with zero
/// coordinates; the unused slots filled with garbage (NaN, infinities) that must not count.
fn awkward_patch(rng: &mut rand_chacha::ChaCha8Rng, count: usize) -> Manifold {
    use rand::Rng;
    let n = awkward_vec(rng, 1.0).try_normalize().unwrap_or(Vec3::Z);
    let mut m = Manifold {
        normal: n,
        count,
        ..Default::default()
    };
    let shared = n * 0.01 + awkward_vec(rng, 0.004);
    let coincident = rng.random_range(0..8) == 0;
    for cp in &mut m.points[..count] {
        cp.depth = match rng.random_range(0..6) {
            0 => 0.0,
            1 => -0.0,
            2 => -rng.random_range(0.0f32..3e-4),
            _ => rng.random_range(0.0f32..4e-4),
        };
        cp.point = if coincident {
            shared
        } else {
            n * awkward(rng, 0.01) + awkward_vec(rng, 0.004)
        };
    }
    let junk = [f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30, -0.0];
    for cp in &mut m.points[count..] {
        cp.point = Vec3::new(
            junk[rng.random_range(0..junk.len())],
            junk[rng.random_range(0..junk.len())],
            junk[rng.random_range(0..junk.len())],
        );
        cp.depth = junk[rng.random_range(0..junk.len())];
    }
    m
}

/// A body's motion for the patch tests: at rest (a wall) one time in five.
fn awkward_motion(rng: &mut rand_chacha::ChaCha8Rng, position: Vec3) -> BodyMotion {
    use rand::Rng;
    if rng.random_range(0..5) == 0 {
        return BodyMotion::default();
    }
    BodyMotion {
        position,
        velocity: awkward_vec(rng, 0.5),
        omega: awkward_vec(rng, 20.0),
    }
}

fn bits3(v: Vec3A) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// The four lanes of `v`.
#[cfg(target_arch = "x86_64")]
fn lanes_array(v: std::arch::x86_64::__m128) -> [f32; 4] {
    Vec4::from(v).to_array()
}

/// The patch's lanes (four points at a time, `patch::lanes`) against its scalar loops
/// (`patch::scalar`, the law's loops as written before the lanes) on random manifolds of
/// two to four points with signed zeros, zero and negative depths, coincident points,
/// bodies at rest and garbage in the unused slots: every sum bitwise the same.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_patch_lanes_match_the_scalar_loops_bitwise() {
    use super::patch::{lanes, scalar};
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(34);
    let mut zero_radius = 0;
    for k in 0..50_000 {
        let count = 2 + k % 3;
        let m = awkward_patch(&mut rng, count);
        let n = Vec3A::from(m.normal);
        let at = awkward_vec(&mut rng, 0.001);
        let a = awkward_motion(&mut rng, at);
        let b = awkward_motion(&mut rng, m.normal * 0.02);
        let (ma, mb) = (MotionA::of(&a), MotionA::of(&b));
        let mut fs = [0.0f32; 4];
        let mut eta = [awkward(&mut rng, 3.0); 4];
        for i in 0..count {
            fs[i] = awkward(&mut rng, 2.0);
            if k % 2 == 0 {
                eta[i] = awkward(&mut rng, 3.0);
            }
        }
        let (lane, one) = (lanes::Patch::of(&m), scalar::Patch::of(&m));
        let what = format!("manifold {k}: {m:?}");
        let (ls, os) = (lane.sums(), one.sums());
        assert_eq!(bits3(ls.0), bits3(os.0), "{what}");
        assert_eq!(ls.1.to_bits(), os.1.to_bits(), "{what}");
        let k = awkward(&mut rng, 2.0);
        let (lf, of) = (lane.linear_springs(k), one.linear_springs(k));
        let lf = lanes_array(lf);
        for i in 0..count {
            assert_eq!(lf[i].to_bits(), of[i].to_bits(), "{what}");
        }
        let (ln, on) = (
            lane.normal_sums(n, &ma, &mb, lanes::f4(fs), lanes::f4(eta)),
            one.normal_sums(n, &ma, &mb, scalar::f4(fs), scalar::f4(eta)),
        );
        assert_eq!(bits3(ln.force_b), bits3(on.force_b), "{what}");
        assert_eq!(bits3(ln.torque_a), bits3(on.torque_a), "{what}");
        assert_eq!(bits3(ln.torque_b), bits3(on.torque_b), "{what}");
        assert_eq!(
            ln.normal_force.to_bits(),
            on.normal_force.to_bits(),
            "{what}"
        );
        let centroid = os.0 * (1.0 / count as f32);
        let (lr, or) = (lane.radius_sum(centroid, n), one.radius_sum(centroid, n));
        assert_eq!(lr.to_bits(), or.to_bits(), "{what}");
        zero_radius += (or == 0.0) as usize;
    }
    assert!(zero_radius > 1000, "{zero_radius}");
}

/// The law on manifold `m` (bodies `a`, `b`; springs `history`, `twist` before the step)
/// against [`reference::contact_force`], bitwise: force, springs and twist, in the general
/// form and, on plain parameters, the plain form. Returns the reference's twist after.
fn assert_law_is_reference(
    c: &PairContext,
    m: &Manifold,
    (a, b): (&BodyMotion, &BodyMotion),
    (history, twist): (Vec3, f32),
    what: &str,
) -> f32 {
    let (mut h0, mut t0) = (history, twist);
    let want = reference::contact_force(c, m, a, b, &mut h0, &mut t0);
    // The linear law's constants made once (`LinearLaw`), where the law is linear.
    let known = LinearLaw::of(c);
    for (plain, constants) in [(false, false), (true, false), (false, true), (true, true)] {
        if (plain && !is_plain(&c.params)) || (constants && known.is_none()) {
            continue;
        }
        let known = known.as_ref().filter(|_| constants);
        let (mut h, mut t) = (history, twist);
        let got = if plain {
            contact_force_known::<true>(c, known, m, a, b, &mut h, &mut t)
        } else {
            contact_force_known::<false>(c, known, m, a, b, &mut h, &mut t)
        };
        let what = format!("{what}, plain form {plain}, constants made once {constants}");
        assert_eq!(
            bytemuck::bytes_of(&got),
            bytemuck::bytes_of(&want),
            "{what}"
        );
        assert_eq!(
            h.to_array().map(f32::to_bits),
            h0.to_array().map(f32::to_bits),
            "{what}"
        );
        assert_eq!(t.to_bits(), t0.to_bits(), "{what}");
    }
    t0
}

/// The law with the linear law's constants made once ([`LinearLaw::of`], taken by
/// [`contact_force_known`]) against the law computing them per contact
/// ([`contact_force`]) and against [`reference::contact_force`], bitwise: forces, springs,
/// twists and coverages, on random contexts (stiffness, restitution, mass, step, both
/// point shares) and manifolds of one to four points; Hertz has none.
#[test]
fn the_linear_law_constants_made_once_give_the_same_bits() {
    use rand::{Rng, SeedableRng};
    let hertz = params(ContactLaw::Hertz {
        youngs_modulus: 1.0e7,
        poisson_ratio: 0.3,
    });
    assert!(
        LinearLaw::of(&PairContext {
            params: hertz,
            m_eff: 0.01,
            r_eff: 0.005,
            share: POLYHEDRON_POINT_SHARE,
            dt: 3.3e-5,
        })
        .is_none()
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3838);
    let (mut sliding, mut sticking) = (0, 0);
    for k in 0..40_000 {
        // (Not 0: the combined stiffness is then NaN, whose sign bit the compiler's
        // operand order decides.)
        let stiffness = 10f32.powf(rng.random_range(-3.0..6.0));
        let restitution = rng.random_range(0.05..0.95);
        let m = Material::new(
            "m",
            1000.0,
            ContactLaw::Linear { stiffness },
            restitution,
            0.4,
        );
        let count = 1 + k % 4;
        let share = if count == 1 && k % 8 == 0 {
            SPHERE_POINT_SHARE
        } else {
            POLYHEDRON_POINT_SHARE
        };
        let c = PairContext {
            params: PairParams::combine(&m, &m),
            m_eff: 10f32.powf(rng.random_range(-4.0..0.0)),
            r_eff: 0.005,
            share,
            dt: 10f32.powf(rng.random_range(-6.0..-4.0)),
        };
        let known = LinearLaw::of(&c).expect("a linear law");
        let manifold = if count == 1 {
            let n = awkward_vec(&mut rng, 1.0)
                .try_normalize()
                .unwrap_or(Vec3::Z);
            let mut m = Manifold {
                normal: n,
                count: 1,
                ..Default::default()
            };
            m.points[0].depth = awkward(&mut rng, 3e-4) + 1e-4;
            m.points[0].point = n * 0.01;
            m
        } else {
            awkward_patch(&mut rng, count)
        };
        let at = awkward_vec(&mut rng, 0.001);
        let a = awkward_motion(&mut rng, at);
        let b = awkward_motion(&mut rng, manifold.normal * 0.02);
        let history = awkward_vec(&mut rng, 2e-4);
        let twist = match (count, k % 3) {
            (1, 0) => 0.0,
            (1, 1) => -1.0,
            (1, _) => (awkward(&mut rng, 1.0) + 1.0) * 1e-3,
            _ => awkward(&mut rng, 0.05),
        };
        let (mut h1, mut t1) = (history, twist);
        let (mut h2, mut t2) = (history, twist);
        let each = contact_force(&c, &manifold, &a, &b, &mut h1, &mut t1);
        let once =
            contact_force_known::<true>(&c, Some(&known), &manifold, &a, &b, &mut h2, &mut t2);
        let what = format!("contact {k}: {c:?} {manifold:?}");
        assert_eq!(
            bytemuck::bytes_of(&each),
            bytemuck::bytes_of(&once),
            "{what}"
        );
        assert_eq!(
            h1.to_array().map(f32::to_bits),
            h2.to_array().map(f32::to_bits),
            "{what}"
        );
        assert_eq!(t1.to_bits(), t2.to_bits(), "{what}");
        assert_law_is_reference(&c, &manifold, (&a, &b), (history, twist), &what);
        // Not vacuous: forces (and a spring) came out, and the Coulomb cap bound.
        let cap = c.params.friction * each.normal_force.max(0.0);
        if each.force_b.reject_from(manifold.normal).length() >= cap * 0.999 {
            sliding += 1;
        } else {
            sticking += 1;
        }
    }
    assert!(sliding > 1000 && sticking > 1000, "{sliding} {sticking}");
}

/// The law on the patch tests' awkward manifolds (two to four points) against
/// [`reference::contact_force`]: linear and Hertz, plain forms on plain pairs, walls.
#[test]
fn the_patch_law_matches_its_reference_on_awkward_manifolds() {
    use rand::SeedableRng;
    let linear = params(ContactLaw::Linear { stiffness: 2.0e4 });
    let hertz = params(ContactLaw::Hertz {
        youngs_modulus: 1.0e7,
        poisson_ratio: 0.3,
    });
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3434);
    for k in 0..40_000 {
        let params = [linear, hertz][k % 2];
        let count = 2 + (k / 2) % 3;
        let m = awkward_patch(&mut rng, count);
        let c = PairContext {
            params,
            m_eff: 0.01 * (1.5 + awkward(&mut rng, 1.0)),
            r_eff: 0.005,
            share: POLYHEDRON_POINT_SHARE,
            dt: 3.3e-5,
        };
        let at = awkward_vec(&mut rng, 0.001);
        let a = awkward_motion(&mut rng, at);
        let b = awkward_motion(&mut rng, m.normal * 0.02);
        let history = awkward_vec(&mut rng, 2e-4);
        let twist = awkward(&mut rng, 0.05);
        assert_law_is_reference(
            &c,
            &m,
            (&a, &b),
            (history, twist),
            &format!("manifold {k}: {m:?}"),
        );
    }
}
