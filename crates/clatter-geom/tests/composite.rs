//! Mass properties of composite shapes (unions of pieces) against analytic values: the lens
//! of two overlapping spheres, the parallel-axis theorem for disjoint pieces, a box split in
//! two boxes, a sphere overlapping a box by an exact octant; and the composite's errors.

use clatter_geom::composite::{MAX_PIECES, union_mass};
use clatter_geom::{GeomError, PieceSpec, PreparedShape, Shape, ShapeKind, prepare_composite};
use glam::{DMat3, DQuat, DVec3};
use std::f64::consts::PI;

fn sphere(r: f64) -> PreparedShape {
    ShapeKind::Sphere { radius: r }.prepare().unwrap()
}

fn cuboid(h: [f64; 3]) -> PreparedShape {
    ShapeKind::Box { half_extents: h }.prepare().unwrap()
}

fn at(shape: &PreparedShape, offset: [f64; 3]) -> PieceSpec {
    PieceSpec {
        shape: shape.clone(),
        offset: DVec3::from_array(offset),
        orientation: DQuat::IDENTITY,
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// Volume and inertia of a solid of revolution about x with slice radius `rho(x)` on
/// `[a, b]`, by composite Simpson (an independent 1-D integration).
fn revolution(rho: impl Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64, f64) {
    let n = 200_000;
    let h = (b - a) / n as f64;
    let (mut v, mut ix, mut iy) = (0.0, 0.0, 0.0);
    for k in 0..=n {
        let x = a + k as f64 * h;
        let w = if k == 0 || k == n {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let r2 = rho(x).powi(2);
        v += w * PI * r2;
        ix += w * PI * r2 * r2 / 2.0;
        iy += w * (PI * r2 * r2 / 4.0 + PI * r2 * x * x);
    }
    (v * h / 3.0, ix * h / 3.0, iy * h / 3.0)
}

#[test]
fn two_overlapping_equal_spheres_match_the_lens_formula() {
    let (r, d) = (1.0, 1.2);
    let s = sphere(r);
    let u = union_mass(&[at(&s, [-d / 2.0, 0.0, 0.0]), at(&s, [d / 2.0, 0.0, 0.0])]);
    // Lens of two equal spheres: pi (4r + d)(2r - d)^2 / 12.
    let lens = PI * (4.0 * r + d) * (2.0 * r - d).powi(2) / 12.0;
    let sphere_v = 4.0 / 3.0 * PI * r * r * r;
    // Sphere volumes are rounded to f32 by `prepare`: compare at that precision.
    assert!(rel(u.mass.volume, 2.0 * sphere_v - lens) < 1e-6, "{u:?}");
    assert_eq!(u.uncertainty, 0.0, "two spheres only: exact");
    assert!(u.mass.center.length() < 1e-9);
    // The union as a solid of revolution about x, integrated independently.
    let rho = |x: f64| {
        let a = r * r - (x + d / 2.0).powi(2);
        let b = r * r - (x - d / 2.0).powi(2);
        a.max(b).max(0.0).sqrt()
    };
    let (v, ix, iy) = revolution(rho, -d / 2.0 - r, d / 2.0 + r);
    assert!(rel(u.mass.volume, v) < 1e-6);
    let i = u.mass.inertia;
    assert!(rel(i.x_axis.x, ix) < 1e-5, "{} vs {ix}", i.x_axis.x);
    assert!(rel(i.y_axis.y, iy) < 1e-5, "{} vs {iy}", i.y_axis.y);
    assert!(rel(i.z_axis.z, iy) < 1e-5);
    assert!(i.x_axis.y.abs() < 1e-9 && i.x_axis.z.abs() < 1e-9 && i.y_axis.z.abs() < 1e-9);
}

#[test]
fn unequal_overlapping_spheres_match_a_revolution_integral() {
    let (ra, rb, d) = (1.0, 0.6, 1.1);
    let u = union_mass(&[at(&sphere(ra), [0.0; 3]), at(&sphere(rb), [d, 0.0, 0.0])]);
    let rho = |x: f64| {
        let a = ra * ra - x * x;
        let b = rb * rb - (x - d).powi(2);
        a.max(b).max(0.0).sqrt()
    };
    let (v, _, _) = revolution(rho, -ra, d + rb);
    assert!(rel(u.mass.volume, v) < 1e-6);
    // Centre of mass by the same slices.
    let n = 100_000;
    let (a, b) = (-ra, d + rb);
    let h = (b - a) / n as f64;
    let mut mx = 0.0;
    for k in 0..n {
        let x = a + (k as f64 + 0.5) * h;
        mx += PI * rho(x).powi(2) * x * h;
    }
    assert!(
        (u.mass.center.x - mx / v).abs() < 1e-6,
        "{}",
        u.mass.center.x
    );
}

#[test]
fn disjoint_pieces_follow_the_parallel_axis_theorem() {
    let s = sphere(0.5);
    let b = cuboid([0.3, 0.2, 0.1]);
    let u = union_mass(&[at(&s, [2.0, 0.0, 0.0]), at(&b, [-1.0, 1.0, 0.0])]);
    assert_eq!(u.uncertainty, 0.0);
    let vs = s.volume as f64;
    let vb = b.volume as f64;
    assert!(rel(u.mass.volume, vs + vb) < 1e-12);
    let c = (DVec3::new(2.0, 0.0, 0.0) * vs + DVec3::new(-1.0, 1.0, 0.0) * vb) / (vs + vb);
    assert!((u.mass.center - c).length() < 1e-9);
    // Each piece's own inertia plus m (|d|^2 Id - d d^T) about the common centre.
    let shift = |m: f64, d: DVec3| {
        (DMat3::from_diagonal(DVec3::splat(d.length_squared()))
            - DMat3::from_cols(d * d.x, d * d.y, d * d.z))
            * m
    };
    let is = DMat3::from_diagonal(s.unit_inertia.as_dvec3());
    let ib = DMat3::from_diagonal(b.unit_inertia.as_dvec3());
    let want = is
        + shift(vs, DVec3::new(2.0, 0.0, 0.0) - c)
        + ib
        + shift(vb, DVec3::new(-1.0, 1.0, 0.0) - c);
    for (x, y) in u
        .mass
        .inertia
        .to_cols_array()
        .iter()
        .zip(want.to_cols_array())
    {
        assert!((x - y).abs() < 1e-9 * want.x_axis.x, "{x} vs {y}");
    }
}

#[test]
fn a_box_split_in_two_boxes_has_the_whole_box_inertia() {
    let whole = cuboid([1.0, 0.5, 0.25]);
    let half = cuboid([0.5, 0.5, 0.25]);
    let u = union_mass(&[at(&half, [-0.5, 0.0, 0.0]), at(&half, [0.5, 0.0, 0.0])]);
    assert_eq!(u.uncertainty, 0.0, "touching pieces do not overlap");
    assert_eq!(u.mass.volume, whole.volume as f64);
    assert!(u.mass.center.length() < 1e-15);
    let i = u.mass.inertia;
    let w = whole.unit_inertia.as_dvec3();
    for (got, want) in [(i.x_axis.x, w.x), (i.y_axis.y, w.y), (i.z_axis.z, w.z)] {
        assert!(rel(got, want) < 1e-7, "{got} vs {want}");
    }
}

#[test]
fn a_sphere_on_a_box_corner_overlaps_by_one_octant() {
    // The sphere's centre on the corner of a box larger than it: an exact eighth overlaps.
    let (r, h) = (0.4, 1.0);
    let s = sphere(r);
    let b = cuboid([h, h, h]);
    let u = union_mass(&[at(&b, [0.0; 3]), at(&s, [h, h, h])]);
    let want = b.volume as f64 + 7.0 / 8.0 * s.volume as f64;
    let err = (u.mass.volume - want).abs();
    assert!(u.uncertainty > 0.0);
    assert!(err <= u.uncertainty, "{err} > bound {}", u.uncertainty);
    assert!(err / want < 1e-4, "relative error {}", err / want);
}

#[test]
fn a_composite_is_placed_in_its_principal_frame() {
    // A dumbbell along the diagonal: principal axes turn it onto x, y or z.
    let s = sphere(0.5);
    let d = DVec3::new(1.0, 1.0, 0.0).normalize();
    let p = prepare_composite(&[
        at(&s, (d * 1.0).to_array()),
        at(&s, (-d * 1.0 + 0.3).to_array()),
    ])
    .unwrap();
    let Shape::Composite(c) = &p.shape else {
        panic!("not a composite")
    };
    assert_eq!(c.pieces.len(), 2);
    // Pieces sit symmetric about the centre of mass, the authored pose reproduces the offsets.
    let sum = c.pieces[0].position + c.pieces[1].position;
    assert!(sum.length() < 1e-5, "{sum}");
    let authored = p.frame * c.pieces[0].position + p.com;
    assert!((authored.as_dvec3() - d).length() < 1e-5);
    assert!(c.radius >= c.pieces[0].position.length() + 0.5);
    // Two disjoint spheres: exact.
    assert_eq!(c.uncertainty, 0.0);
    assert!(rel(p.volume as f64, 2.0 * s.volume as f64) < 1e-7);
}

#[test]
fn composite_errors() {
    assert_eq!(prepare_composite(&[]), Err(GeomError::EmptyComposite));
    let s = sphere(0.1);
    let nested = prepare_composite(&[at(&s, [0.0; 3])]).unwrap();
    assert_eq!(
        prepare_composite(&[at(&s, [0.0; 3]), at(&nested, [1.0, 0.0, 0.0])]),
        Err(GeomError::NestedComposite { index: 1 })
    );
    let many: Vec<PieceSpec> = (0..=MAX_PIECES)
        .map(|k| at(&s, [k as f64, 0.0, 0.0]))
        .collect();
    assert!(matches!(
        prepare_composite(&many),
        Err(GeomError::TooManyPieces { .. })
    ));
    assert_eq!(
        prepare_composite(&[at(&s, [f64::NAN, 0.0, 0.0])]),
        Err(GeomError::NonFinitePiece { index: 0 })
    );
}
