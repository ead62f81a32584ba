//! Materials: the combination rules (identical materials keep their own values, different
//! ones combine as documented), the linear contact duration for unequal masses, two different
//! materials measured through a scene file, and the Hertz static overlap of a loaded sphere.

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::scene::Scene;
use clatter::{BodyInit, ContactLaw, Material, PairParams, Wall, World, WorldDesc};
use glam::{Quat, Vec3};

fn linear(k: f32, e: f32, mu: f32) -> Material {
    Material::new("lin", 2500.0, ContactLaw::Linear { stiffness: k }, e, mu)
}

fn hertz(youngs: f32, poisson: f32, e: f32, mu: f32) -> Material {
    Material::new(
        "hertz",
        2500.0,
        ContactLaw::Hertz {
            youngs_modulus: youngs,
            poisson_ratio: poisson,
        },
        e,
        mu,
    )
}

/// `beta = 2 (-ln e) / sqrt(pi^2 + ln^2 e)`: the damping ratio of the linear law times 2.
fn beta(e: f64) -> f64 {
    let l = e.ln();
    2.0 * -l / (std::f64::consts::PI.powi(2) + l * l).sqrt()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-30)
}

#[test]
fn identical_materials_keep_their_own_values() {
    for k in [1.0e3f32, 2.0e4, 7.3e5, 3.1e8] {
        for e in [0.1f32, 0.3, 0.5, 0.7, 0.9, 1.0] {
            for mu in [0.0f32, 0.3, 1.2] {
                let m = linear(k, e, mu);
                let p = PairParams::combine(&m, &m);
                assert!(!p.is_hertz());
                assert!(
                    close(p.stiffness as f64, k as f64, 1e-6),
                    "k {k}: {}",
                    p.stiffness
                );
                assert!(
                    close(p.restitution as f64, e as f64, 1e-6),
                    "e {e}: {}",
                    p.restitution
                );
                assert!(
                    close(p.friction as f64, mu as f64, 1e-6) || (mu == 0.0 && p.friction == 0.0),
                    "mu {mu}: {}",
                    p.friction
                );
                assert!(
                    close(p.damping_factor as f64, beta(e as f64), 1e-6)
                        || (e == 1.0 && p.damping_factor == 0.0),
                    "e {e}: damping {}",
                    p.damping_factor
                );
            }
        }
    }
    // Hertz: one material against itself gets the physical effective moduli of two such
    // bodies, E* = E / (2 (1 - v^2)) and G* = G / (2 (2 - v)) with G = E / (2 (1 + v)).
    for (youngs, poisson) in [
        (1.0e7f32, 0.0f32),
        (7.0e10, 0.22),
        (5.0e6, 0.49),
        (2.0e11, 0.3),
    ] {
        for e in [0.1f32, 0.5, 1.0] {
            let m = hertz(youngs, poisson, e, 0.4);
            let p = PairParams::combine(&m, &m);
            let (y, v) = (youngs as f64, poisson as f64);
            assert!(p.is_hertz());
            assert!(
                close(p.stiffness as f64, y / (2.0 * (1.0 - v * v)), 1e-6),
                "E* {}",
                p.stiffness
            );
            let g = y / (2.0 * (1.0 + v));
            assert!(
                close(p.shear as f64, g / (2.0 * (2.0 - v)), 1e-6),
                "G* {}",
                p.shear
            );
            assert!(close(p.restitution as f64, e as f64, 1e-6));
            assert!(close(p.friction as f64, 0.4, 1e-6));
            assert!(
                close(
                    p.damping_factor as f64,
                    (5.0f64 / 6.0).sqrt() * beta(e as f64),
                    1e-6
                ) || (e == 1.0 && p.damping_factor == 0.0)
            );
        }
    }
}

/// A restitution far below f32's square root of its smallest normal (1e-30: the scene
/// format allows any e in (0, 1]) keeps its own value and a finite damping, close to the
/// critical 2: the product of two such values is 0 in f32, and ln(0) made the pair's
/// damping NaN, blowing the run up at its first contact.
#[test]
fn tiny_restitutions_combine_without_underflow() {
    for e in [1e-30f32, 1e-25, 1e-20, 1e-19] {
        let m = linear(1e4, e, 0.3);
        let p = PairParams::combine(&m, &m);
        assert!(
            close(p.restitution as f64, e as f64, 1e-6),
            "e {e}: {}",
            p.restitution
        );
        assert!(
            close(p.damping_factor as f64, beta(e as f64), 1e-6),
            "e {e}: damping {} against {}",
            p.damping_factor,
            beta(e as f64)
        );
        assert!(p.damping_factor < 2.0);
        let t = p.contact_duration(0.01, 0.01, 1.0);
        assert!(t.is_finite() && t < 1.0, "e {e}: t_c {t}");
    }
}

#[test]
fn different_materials_combine_as_documented_and_symmetrically() {
    let (a, b) = (linear(1.0e4, 0.9, 0.2), linear(4.0e4, 0.4, 0.8));
    let p = PairParams::combine(&a, &b);
    assert_eq!(p, PairParams::combine(&b, &a));
    assert!(
        close(p.stiffness as f64, 2.0 * 1e4 * 4e4 / 5e4, 1e-6),
        "k {}",
        p.stiffness
    );
    assert!(
        close(p.restitution as f64, 0.6, 1e-6),
        "e {}",
        p.restitution
    );
    assert!(close(p.friction as f64, 0.4, 1e-6), "mu {}", p.friction);
    assert!(close(p.damping_factor as f64, beta(0.6), 1e-6));

    let (a, b) = (hertz(1.0e7, 0.3, 0.8, 0.5), hertz(2.0e11, 0.25, 0.5, 0.2));
    let p = PairParams::combine(&a, &b);
    assert_eq!(p, PairParams::combine(&b, &a));
    let e_star = 1.0 / ((1.0 - 0.09) / 1e7 + (1.0 - 0.0625) / 2e11);
    let g_star = 1.0 / (2.0 * 1.7 * 1.3 / 1e7 + 2.0 * 1.75 * 1.25 / 2e11);
    assert!(
        close(p.stiffness as f64, e_star, 1e-6),
        "E* {}",
        p.stiffness
    );
    assert!(close(p.shear as f64, g_star, 1e-6), "G* {}", p.shear);
    assert!(close(p.restitution as f64, 0.4f64.sqrt(), 1e-6));
    assert!(close(p.friction as f64, 0.1f64.sqrt(), 1e-6));
}

/// Steps until the single contact has come and gone; returns the time spent in contact.
fn run_impact(w: &mut World) -> f64 {
    let mut contact_steps = 0u64;
    let mut was_in_contact = false;
    for _ in 0..10_000_000 {
        let s = w.step().unwrap();
        if s.contacts > 0 {
            contact_steps += 1;
            was_in_contact = true;
        } else if was_in_contact {
            assert_eq!(w.step().unwrap().contacts, 0, "touched again");
            return contact_steps as f64 * w.dt as f64;
        }
    }
    panic!("the impact never ended");
}

/// Two spheres of unequal size (mass ratio 2, and 8) collide head-on: the contact lasts
/// `t_c(m_eff)` with `m_eff = m1 m2 / (m1 + m2)`, not `t_c(m1)` or `t_c(m2)`, and the relative
/// velocity is reversed with the requested `e`.
#[test]
fn linear_contact_duration_uses_the_effective_mass() {
    for (rb, e) in [
        (0.01 * 2f64.cbrt(), 0.5f32),
        (0.02, 0.5),
        (0.02, 0.9),
        (0.015, 0.2),
    ] {
        let ra = 0.01;
        let m = linear(2.0e4, e, 0.0);
        let sa = ShapeKind::Sphere { radius: ra }.prepare().unwrap();
        let sb = ShapeKind::Sphere { radius: rb }.prepare().unwrap();
        let (ma, mb) = (2500.0 * sa.volume as f64, 2500.0 * sb.volume as f64);
        let m_eff = ma * mb / (ma + mb);
        let p = PairParams::combine(&m, &m);
        let t_c = p.contact_duration(m_eff, 0.0, 0.0);
        let mut w = World::new(WorldDesc {
            shapes: vec![sa, sb],
            materials: vec![m],
            walls: vec![],
            bodies: vec![
                BodyInit {
                    shape: 0,
                    material: 0,
                    position: Vec3::new(-(ra as f32) - 1e-4, 0.0, 0.0).as_dvec3(),
                    orientation: Quat::IDENTITY,
                    velocity: Vec3::new(0.4, 0.0, 0.0),
                    angular_velocity: Vec3::ZERO,
                },
                BodyInit {
                    shape: 1,
                    material: 0,
                    position: Vec3::new(rb as f32 + 1e-4, 0.0, 0.0).as_dvec3(),
                    orientation: Quat::IDENTITY,
                    velocity: Vec3::new(-0.2, 0.0, 0.0),
                    angular_velocity: Vec3::ZERO,
                },
            ],
            gravity: Vec3::ZERO,
            dt: Some((t_c / 1000.0) as f32),
            skin: None,
            periodic: None,
        });
        let p0 = w.momentum()[0];
        let measured = run_impact(&mut w);
        let e_meas = -(w.state.velocity[1].x - w.state.velocity[0].x) as f64 / -0.6;
        let t_a = p.contact_duration(ma, 0.0, 0.0);
        eprintln!(
            "m_b/m_a = {:.2}, e = {e}: t_c(m_eff) = {t_c:.4e}, measured {measured:.4e} (t_c(m_a) = {t_a:.4e}); e measured {e_meas:.5}",
            mb / ma
        );
        assert!(
            (measured / t_c - 1.0).abs() < 0.02,
            "duration {measured}, expected {t_c}"
        );
        assert!(
            (t_a / t_c - 1.0).abs() > 0.05,
            "the test cannot tell m_eff from m_a"
        );
        assert!(
            (e_meas / e as f64 - 1.0).abs() < 0.01,
            "e {e_meas}, expected {e}"
        );
        let scale = ma * 0.4 + mb * 0.2;
        let dp = (w.momentum()[0] - p0).abs() / scale;
        assert!(dp < 1e-6, "momentum changed by {dp} of sum m|v|");
    }
}

/// Two different linear materials, through a scene file: a ball (k 2e4, e 0.9) hits a floor
/// (k 6e4, e 0.4) head-on without gravity. Measured: `e = sqrt(0.9 * 0.4) = 0.6` and the
/// duration of the combined `k = 2 k1 k2 / (k1 + k2) = 3e4`.
#[test]
fn two_materials_through_a_scene_file() {
    let text = r#"
[simulation]
steps = 1
dt = 1.0e-6
gravity = [0.0, 0.0, 0.0]

[[material]]
name = "ball"
density = 1100.0
stiffness = 2.0e4
restitution = 0.9
friction = 0.0

[[material]]
name = "floor"
density = 7800.0
stiffness = 6.0e4
restitution = 0.4
friction = 0.0

[[shape]]
name = "ball"
sphere = { radius = 0.05 }

[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "floor"

[[body]]
shape = "ball"
material = "ball"
position = [0.0, 0.0, 0.0501]
velocity = [0.0, 0.0, -1.0]
"#;
    let scene = Scene::parse(text, "two-materials.toml").unwrap();
    let mut w = scene.world();
    let m = w.consts.mass[0] as f64;
    let (k, e) = (3.0e4f64, 0.6f64);
    let eta = beta(e) * (m * k).sqrt();
    let t_c = std::f64::consts::PI / (k / m - (eta / (2.0 * m)).powi(2)).sqrt();
    // dt = 1e-6 s is about t_c / 14000.
    let measured = run_impact(&mut w);
    let e_meas = w.state.velocity[0].z as f64;
    eprintln!(
        "scene: e measured {e_meas:.5} (expected {e}), t_c measured {measured:.5e} (expected {t_c:.5e})"
    );
    assert!((e_meas / e - 1.0).abs() < 0.01, "e {e_meas}");
    assert!(
        (measured / t_c - 1.0).abs() < 0.02,
        "t_c {measured}, expected {t_c}"
    );
}

/// A Hertz sphere resting on a wall under gravity settles where `4/3 E* sqrt(R d) d = m g`,
/// with `E*` from the sphere's and the wall's materials and `R` the sphere's radius.
#[test]
fn hertz_static_overlap_under_load() {
    let r = 0.01f64;
    let shape = ShapeKind::Sphere { radius: r }.prepare().unwrap();
    // Same material for the wall, then a wall 10 times stiffer with another Poisson ratio.
    for (wall_e, wall_v) in [(5.0e7f32, 0.3f32), (5.0e8, 0.2)] {
        for g in [9.81f32, 98.1] {
            let ball = hertz(5.0e7, 0.3, 0.5, 0.5);
            let wall = hertz(wall_e, wall_v, 0.5, 0.5);
            let e_star =
                1.0 / ((1.0 - 0.09) / 5.0e7 + (1.0 - (wall_v as f64).powi(2)) / wall_e as f64);
            let mass = 2500.0 * shape.volume as f64;
            let d = (3.0 * mass * g as f64 / (4.0 * e_star * r.sqrt())).powf(2.0 / 3.0);
            let mut w = World::new(WorldDesc {
                shapes: vec![shape.clone()],
                materials: vec![ball, wall],
                walls: vec![Wall {
                    plane: Plane {
                        normal: Vec3::Z,
                        offset: 0.0,
                    },
                    material: 1,
                }],
                bodies: vec![BodyInit {
                    shape: 0,
                    material: 0,
                    position: Vec3::new(0.0, 0.0, r as f32 + 1e-4).as_dvec3(),
                    orientation: Quat::IDENTITY,
                    velocity: Vec3::ZERO,
                    angular_velocity: Vec3::ZERO,
                }],
                gravity: Vec3::new(0.0, 0.0, -g),
                dt: None,
                skin: None,
                periodic: None,
            });
            assert!(close(w.pair_params(1, 0).stiffness as f64, e_star, 1e-6));
            let steps = (1.0 / w.dt as f64) as usize;
            for _ in 0..steps {
                w.step().unwrap();
            }
            let overlap = r - w.state.position[0].z as f64;
            eprintln!(
                "wall E {wall_e:e}, g {g}: overlap {overlap:.5e}, Hertz {d:.5e} (rel {:.2e}); |v| {:.2e}",
                overlap / d - 1.0,
                w.state.velocity[0].length()
            );
            // f32 positions near 0.01 m resolve 1e-9 m: 1e-4 of these overlaps.
            assert!(
                (overlap / d - 1.0).abs() < 0.01,
                "overlap {overlap}, Hertz {d}"
            );
        }
    }
}

/// A scene with one material whose last line is `extra` (and one ball on a floor).
fn one_material_scene(extra: &str) -> String {
    format!(
        "[simulation]\nsteps = 1\n\n[[material]]\nname = \"m\"\ndensity = 1000.0\nstiffness = 1.0e4\n{extra}\n\n\
         [[shape]]\nname = \"ball\"\nsphere = {{ radius = 0.01 }}\n\n\
         [[body]]\nshape = \"ball\"\nmaterial = \"m\"\nposition = [0.0, 0.0, 0.0]\n"
    )
}

/// Every coefficient of the table is a scene key: left out it takes its default, given it is
/// checked against its range (the error naming the line and the field), and a pair of one
/// material keeps the material's value. Holds for a coefficient added to the table with no
/// edit here.
#[test]
fn every_coefficient_is_a_scene_key_with_its_default_and_range() {
    use clatter::material::{COEFFICIENTS, Range};
    assert_eq!(
        COEFFICIENTS.iter().map(|c| c.name).collect::<Vec<_>>()[..4],
        [
            "restitution",
            "friction",
            "rolling_friction",
            "spinning_friction"
        ]
    );
    let plain = Scene::parse(&one_material_scene(""), "plain.toml").unwrap();
    for c in COEFFICIENTS {
        let m = &plain.desc.materials[0];
        assert_eq!(m.coefficient(c.name), Some(c.default), "{}", c.name);

        let given = Scene::parse(
            &one_material_scene(&format!("{} = 0.25", c.name)),
            "given.toml",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let m = &given.desc.materials[0];
        assert_eq!(m.coefficient(c.name), Some(0.25), "{}", c.name);
        let pair = PairParams::combine(m, m);
        assert_eq!(pair.coefficient(c.name), Some(0.25), "{}", c.name);

        let bad = match c.range {
            Range::NonNegative => "-1.0",
            Range::UnitInterval => "1.5",
        };
        let e = Scene::parse(
            &one_material_scene(&format!("{} = {bad}", c.name)),
            "bad.toml",
        )
        .err()
        .unwrap_or_else(|| panic!("{} = {bad} accepted", c.name));
        assert_eq!(
            e.field.as_deref(),
            Some(&*format!("material[0].{}", c.name))
        );
        assert_eq!(e.line.map(|(l, _)| l), Some(8), "{e}");
        assert_eq!(Some(e.message.clone()), c.range.check(bad.parse().unwrap()));
    }
}

/// A misspelt coefficient is refused by name, the message listing the keys a material has.
#[test]
fn an_unknown_material_key_is_refused_with_the_known_ones() {
    let Err(e) = Scene::parse(&one_material_scene("rolling_fricton = 0.1"), "typo.toml") else {
        panic!("an unknown key is accepted");
    };
    let text = e.to_string();
    assert!(text.contains("rolling_fricton"), "{text}");
    for c in clatter::material::COEFFICIENTS {
        assert!(text.contains(&format!("`{}`", c.name)), "{text}");
    }
    assert_eq!(e.line.map(|(l, _)| l), Some(8), "{e}");
}

/// docs/scene-format.md's `[[material]]` table has a row for every coefficient, with its
/// default.
#[test]
fn every_coefficient_is_documented_in_the_scene_format() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene-format.md");
    let doc = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let section = doc
        .split("## `[[material]]`")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("a `[[material]]` section");
    for c in clatter::material::COEFFICIENTS {
        let row = section
            .lines()
            .find(|l| l.starts_with(&format!("| `{}` ", c.name)))
            .unwrap_or_else(|| panic!("no row for `{}` in {}", c.name, path.display()));
        assert!(
            row.contains(&format!("`{}`", c.default)),
            "the row of `{}` should give its default `{}`: {row}",
            c.name,
            c.default
        );
    }
}
