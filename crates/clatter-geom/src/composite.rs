//! Composite shapes ("clumps"): one rigid body made of several convex pieces (spheres and
//! convex polyhedra), and the mass properties of their union.
//!
//! # Mass properties of the union
//!
//! Pieces may overlap (multi-sphere clumps usually do); the overlap is counted once. With
//! `c(x)` the number of pieces covering `x`, the union's integrals are
//!
//! `int_union f = sum_pieces int_piece f - int max(c - 1, 0) f`,
//!
//! and the excess `max(c - 1, 0)` is split into what closed forms give and a remainder:
//!
//! - each pair of overlapping **spheres** contributes its **lens** exactly (volume, first and
//!   second moments of two spherical caps, in closed form);
//! - the remainder `g(x) = max(c - 1, 0) - s(x)`, where `s(x)` counts the sphere pairs whose
//!   lens holds `x`, is zero wherever at most two pieces overlap and those are two spheres.
//!   It is integrated by a deterministic **adaptive octree quadrature** over the box that
//!   bounds every pairwise overlap: a cell in which no piece's boundary passes (decided
//!   conservatively from the cell's centre and half-diagonal) has a constant `g` and is
//!   integrated exactly (box moments); other cells are split, down to cells of
//!   `1/2^QUADRATURE_DEPTH` of the box, which take `g` at their centre.
//!
//! So the result is exact (up to f64 rounding) for pieces that do not overlap (parallel-axis
//! sums), for pieces that only touch (a box split in two boxes), and for multi-sphere clumps
//! whose spheres overlap only pairwise; otherwise (sphere-polyhedron or polyhedron-polyhedron
//! overlaps, triple sphere overlaps) its error is bounded by the volume of the cells that
//! straddle a boundary, returned as [`UnionMass::uncertainty`] (typically 1e-4 of the overlap
//! volume's surface cells: well below 1e-3 of the union's volume for ordinary clumps).

use std::sync::Arc;

use glam::{DMat3, DQuat, DVec3, Quat, Vec3};

use crate::{GeomError, MassProperties, PreparedShape, Shape};

/// Most pieces a composite may have (piece ids of a contact fit in 6 bits).
pub const MAX_PIECES: usize = 64;

/// Subdivision depth of the overlap quadrature (cells of 1/2^depth of the overlap box).
pub const QUADRATURE_DEPTH: u32 = 8;

/// One convex piece of a composite, placed in the composite's principal frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Piece {
    /// The piece's own shape (a sphere or a polyhedron, in its own principal frame).
    pub shape: Shape,
    /// The piece's centre of mass in the composite's principal frame.
    pub position: Vec3,
    /// The rotation from the piece's principal frame to the composite's principal frame.
    pub orientation: Quat,
    /// The piece's volume-equivalent sphere radius (the Hertz law's radius for its contacts).
    pub equivalent_radius: f32,
}

impl Piece {
    /// The piece's bounding-sphere radius about its own centre.
    pub fn radius(&self) -> f32 {
        self.shape.bounding_radius()
    }
}

/// A rigid body made of convex pieces, in its principal frame (centre of mass of the union at
/// the origin, principal axes along x, y, z).
#[derive(Debug, Clone, PartialEq)]
pub struct Composite {
    /// The pieces, in the order they were given.
    pub pieces: Vec<Piece>,
    /// Bounding-sphere radius about the composite's centre of mass (covers every piece).
    pub radius: f32,
    /// Largest distance of a piece's centre from the composite's centre of mass: how far a
    /// rotation can carry a piece (the broad phase's rebuild check uses it).
    pub reach: f32,
    /// The bound on the volume error of the union's quadrature (m^3; 0 when exact).
    pub uncertainty: f64,
}

/// A piece as authored: a prepared convex shape, where its centre of mass sits in the
/// composite's authored frame and how it is turned (as a body is placed: `offset` is the
/// piece's centre of mass, `orientation` turns the shape as authored).
#[derive(Debug, Clone, PartialEq)]
pub struct PieceSpec {
    /// The piece's prepared shape (not itself a composite).
    pub shape: PreparedShape,
    /// Where the piece's centre of mass is, in the composite's authored frame.
    pub offset: DVec3,
    /// The piece's rotation (from its authored frame to the composite's authored frame).
    pub orientation: DQuat,
}

/// Mass properties of a union of pieces and the bound on their quadrature error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnionMass {
    /// Volume, centre of mass and inertia (about the centre of mass) at unit density.
    pub mass: MassProperties,
    /// Upper bound of the volume error (m^3) of the quadrature part (0 when exact).
    pub uncertainty: f64,
}

/// A piece in the composite's authored frame, for the point tests and the integrals.
enum Region {
    Sphere {
        centre: DVec3,
        radius: f64,
    },
    /// Outward planes `n . x <= d`, the centre and bounding radius, the vertices' box.
    Convex {
        planes: Vec<(DVec3, f64)>,
        centre: DVec3,
        radius: f64,
        aabb: (DVec3, DVec3),
    },
}

/// Where a cell stands relative to a region.
#[derive(Clone, Copy, PartialEq)]
enum Side {
    Inside,
    Outside,
    Straddles,
}

impl Region {
    fn centre(&self) -> DVec3 {
        match self {
            Region::Sphere { centre, .. } | Region::Convex { centre, .. } => *centre,
        }
    }

    fn radius(&self) -> f64 {
        match self {
            Region::Sphere { radius, .. } | Region::Convex { radius, .. } => *radius,
        }
    }

    fn aabb(&self) -> (DVec3, DVec3) {
        match self {
            Region::Sphere { centre, radius } => (
                *centre - DVec3::splat(*radius),
                *centre + DVec3::splat(*radius),
            ),
            Region::Convex { aabb, .. } => *aabb,
        }
    }

    /// The cell with centre `c` and half-diagonal length `h` against the region.
    fn side(&self, c: DVec3, h: f64) -> Side {
        match self {
            Region::Sphere { centre, radius } => {
                let d = (c - *centre).length();
                if d + h <= *radius {
                    Side::Inside
                } else if d - h >= *radius {
                    Side::Outside
                } else {
                    Side::Straddles
                }
            }
            Region::Convex { planes, .. } => {
                let mut inside = true;
                for &(n, d) in planes {
                    let s = n.dot(c) - d;
                    if s >= h {
                        return Side::Outside;
                    }
                    if s > -h {
                        inside = false;
                    }
                }
                if inside {
                    Side::Inside
                } else {
                    Side::Straddles
                }
            }
        }
    }

    fn contains(&self, p: DVec3) -> bool {
        match self {
            Region::Sphere { centre, radius } => (p - *centre).length_squared() < radius * radius,
            Region::Convex { planes, .. } => planes.iter().all(|&(n, d)| n.dot(p) < d),
        }
    }
}

/// Volume, first moment `int x` and second moment `int x x^T` (about the origin).
#[derive(Clone, Copy)]
struct Moments {
    volume: f64,
    first: DVec3,
    second: DMat3,
}

impl Default for Moments {
    /// Zero (glam's matrices default to the identity, not zero).
    fn default() -> Self {
        Moments {
            volume: 0.0,
            first: DVec3::ZERO,
            second: DMat3::ZERO,
        }
    }
}

impl Moments {
    fn add(&mut self, o: &Moments, weight: f64) {
        self.volume += weight * o.volume;
        self.first += o.first * weight;
        self.second += o.second * weight;
    }

    /// Moments of a body with mass properties `m` (centre and inertia about it).
    fn of(m: &MassProperties) -> Moments {
        let c = m.center;
        // Covariance from the inertia: I = tr(S) Id - S  =>  S = tr(I)/2 Id - I.
        let tr = m.inertia.x_axis.x + m.inertia.y_axis.y + m.inertia.z_axis.z;
        let cov = DMat3::from_diagonal(DVec3::splat(0.5 * tr)) - m.inertia;
        Moments {
            volume: m.volume,
            first: c * m.volume,
            second: cov + outer(c, c) * m.volume,
        }
    }

    /// An axis-aligned box with centre `c` and half extents `h`.
    fn of_box(c: DVec3, h: DVec3) -> Moments {
        let v = 8.0 * h.x * h.y * h.z;
        Moments {
            volume: v,
            first: c * v,
            second: outer(c, c) * v + DMat3::from_diagonal(h * h * (v / 3.0)),
        }
    }

    fn mass_properties(&self) -> MassProperties {
        let c = self.first / self.volume;
        let cov = self.second - outer(c, c) * self.volume;
        let tr = cov.x_axis.x + cov.y_axis.y + cov.z_axis.z;
        MassProperties {
            volume: self.volume,
            center: c,
            inertia: DMat3::from_diagonal(DVec3::splat(tr)) - cov,
        }
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The lens shared by spheres `(ca, ra)` and `(cb, rb)` (zero when they do not overlap):
/// two spherical caps cut by the radical plane, each integrated in closed form.
fn lens(ca: DVec3, ra: f64, cb: DVec3, rb: f64) -> Moments {
    let d = (cb - ca).length();
    if d >= ra + rb {
        return Moments::default();
    }
    if d <= (ra - rb).abs() {
        // One sphere inside the other: the lens is the smaller sphere.
        let (c, r) = if ra <= rb { (ca, ra) } else { (cb, rb) };
        let mut m = MassProperties::of_sphere(r);
        m.center = c;
        return Moments::of(&m);
    }
    let axis = (cb - ca) / d;
    // Distance of the radical plane from ca along the axis.
    let a = (d * d + ra * ra - rb * rb) / (2.0 * d);
    // Cap of sphere a beyond the plane (z in [a, ra]) and of sphere b on the near side
    // (z' in [d - a, rb], measured from cb towards ca).
    let mut total = Moments::default();
    for (centre, r, lo, dir) in [(ca, ra, a, axis), (cb, rb, d - a, -axis)] {
        total.add(&cap(centre, r, lo, dir), 1.0);
    }
    total
}

/// The part `z >= lo` (z along unit `dir` from `centre`) of the sphere `(centre, r)`,
/// `lo` in `(-r, r)`: slices `pi (r^2 - z^2) dz` integrated in closed form.
fn cap(centre: DVec3, r: f64, lo: f64, dir: DVec3) -> Moments {
    let pi = std::f64::consts::PI;
    let r2 = r * r;
    // Antiderivatives of the slice integrals.
    let v = |z: f64| pi * (r2 * z - z * z * z / 3.0);
    let z1 = |z: f64| pi * (r2 * z * z / 2.0 - z.powi(4) / 4.0);
    let z2 = |z: f64| pi * (r2 * z.powi(3) / 3.0 - z.powi(5) / 5.0);
    // int (r^2 - z^2)^2 / 4 * pi dz: the in-plane second moment per axis.
    let t = |z: f64| pi / 4.0 * (r2 * r2 * z - 2.0 * r2 * z.powi(3) / 3.0 + z.powi(5) / 5.0);
    let volume = v(r) - v(lo);
    let mz = z1(r) - z1(lo);
    let szz = z2(r) - z2(lo);
    let sxx = t(r) - t(lo);
    // Second moment about `centre` in a frame with `dir` as z: diag(sxx, sxx, szz).
    let local = DMat3::from_diagonal(DVec3::splat(sxx)) + outer(dir, dir) * (szz - sxx);
    let first_local = dir * mz;
    Moments {
        volume,
        first: first_local + centre * volume,
        second: local
            + outer(centre, first_local)
            + outer(first_local, centre)
            + outer(centre, centre) * volume,
    }
}

/// The union's mass properties (see the module docs) of pieces with known mass properties
/// `pieces[k].1`, whose solid regions are given by `pieces[k].0`.
fn union_moments(regions: &[Region], props: &[MassProperties]) -> (Moments, f64) {
    let mut total = Moments::default();
    for p in props {
        total.add(&Moments::of(p), 1.0);
    }
    // Pairwise overlaps: lenses exactly, the rest by quadrature over their bounding box.
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut sphere_pairs = Vec::new();
    let mut any_overlap = false;
    for a in 0..regions.len() {
        for b in a + 1..regions.len() {
            let (ra, rb) = (&regions[a], &regions[b]);
            if (rb.centre() - ra.centre()).length() >= ra.radius() + rb.radius() {
                continue;
            }
            let (la, ha) = ra.aabb();
            let (lb, hb) = rb.aabb();
            let (l, h) = (la.max(lb), ha.min(hb));
            if let (
                Region::Sphere {
                    centre: ca,
                    radius: rad_a,
                },
                Region::Sphere {
                    centre: cb,
                    radius: rad_b,
                },
            ) = (ra, rb)
            {
                total.add(&lens(*ca, *rad_a, *cb, *rad_b), -1.0);
                sphere_pairs.push((a, b));
            }
            if (h - l).min_element() > 0.0 {
                lo = lo.min(l);
                hi = hi.max(h);
                any_overlap = true;
            }
        }
    }
    if !any_overlap {
        return (total, 0.0);
    }
    let mut quad = Moments::default();
    let mut uncertainty = 0.0;
    let centre = (lo + hi) * 0.5;
    let half = (hi - lo) * 0.5;
    integrate_cell(
        regions,
        &sphere_pairs,
        centre,
        half,
        QUADRATURE_DEPTH,
        &mut quad,
        &mut uncertainty,
    );
    total.add(&quad, -1.0);
    (total, uncertainty)
}

/// The remainder `g = max(c - 1, 0) - s` at the point `p`.
fn remainder_at(regions: &[Region], sphere_pairs: &[(usize, usize)], p: DVec3) -> f64 {
    let inside: Vec<bool> = regions.iter().map(|r| r.contains(p)).collect();
    remainder(&inside, sphere_pairs)
}

fn remainder(inside: &[bool], sphere_pairs: &[(usize, usize)]) -> f64 {
    let c = inside.iter().filter(|&&b| b).count();
    let s = sphere_pairs
        .iter()
        .filter(|&&(a, b)| inside[a] && inside[b])
        .count();
    (c.saturating_sub(1) as f64) - s as f64
}

/// Adds `int g` over the cell (centre `c`, half extents `h`) to `out`, splitting cells where
/// some piece's boundary may pass, down to `depth` more levels.
fn integrate_cell(
    regions: &[Region],
    sphere_pairs: &[(usize, usize)],
    c: DVec3,
    h: DVec3,
    depth: u32,
    out: &mut Moments,
    uncertainty: &mut f64,
) {
    let diag = h.length();
    let mut inside = Vec::with_capacity(regions.len());
    let mut straddling = Vec::new();
    for (k, r) in regions.iter().enumerate() {
        let side = r.side(c, diag);
        inside.push(side == Side::Inside);
        if side == Side::Straddles {
            straddling.push(k);
        }
    }
    // The range of g over the cell: every subset of the straddling pieces may hold a point.
    let (lo, hi) = if straddling.len() <= 8 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for mask in 0u32..(1 << straddling.len()) {
            for (bit, &k) in straddling.iter().enumerate() {
                inside[k] = mask & (1 << bit) != 0;
            }
            let g = remainder(&inside, sphere_pairs);
            lo = lo.min(g);
            hi = hi.max(g);
        }
        (lo, hi)
    } else {
        (0.0, regions.len() as f64)
    };
    if lo == hi {
        // g is constant on the cell: its integral is exact.
        if lo != 0.0 {
            out.add(&Moments::of_box(c, h), lo);
        }
        return;
    }
    if depth == 0 {
        let g = remainder_at(regions, sphere_pairs, c);
        let cell = Moments::of_box(c, h);
        if g != 0.0 {
            out.add(&cell, g);
        }
        *uncertainty += cell.volume * (hi - lo);
        return;
    }
    let q = h * 0.5;
    for k in 0..8 {
        let s = DVec3::new(
            if k & 1 == 0 { -1.0 } else { 1.0 },
            if k & 2 == 0 { -1.0 } else { 1.0 },
            if k & 4 == 0 { -1.0 } else { 1.0 },
        );
        integrate_cell(
            regions,
            sphere_pairs,
            c + s * q,
            q,
            depth - 1,
            out,
            uncertainty,
        );
    }
}

/// The region and exact mass properties of a prepared piece placed at `offset`, turned by
/// `orientation`, in the composite's authored frame.
fn placed(p: &PieceSpec) -> (Region, MassProperties) {
    let q = p.orientation * p.shape.frame.as_dquat();
    let centre = p.offset;
    let r = glam::DMat3::from_quat(q);
    let m = MassProperties {
        volume: p.shape.volume as f64,
        center: centre,
        inertia: r * DMat3::from_diagonal(p.shape.unit_inertia.as_dvec3()) * r.transpose(),
    };
    let region = match &p.shape.shape {
        Shape::Sphere { radius } => Region::Sphere {
            centre,
            radius: *radius as f64,
        },
        Shape::Polyhedron(h) => Region::Convex {
            planes: h
                .faces
                .iter()
                .map(|f| {
                    let n = q * f.normal.as_dvec3();
                    (n, f.offset as f64 + n.dot(centre))
                })
                .collect(),
            centre,
            radius: h.radius as f64,
            aabb: h.vertices.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), v| {
                    let w = centre + q * v.as_dvec3();
                    (lo.min(w), hi.max(w))
                },
            ),
        },
        Shape::Composite(c) => Region::Sphere {
            centre,
            radius: c.radius as f64,
        },
    };
    (region, m)
}

/// The mass properties (unit density) of the union of `pieces`, in their authored frame.
pub fn union_mass(pieces: &[PieceSpec]) -> UnionMass {
    let (regions, props): (Vec<Region>, Vec<MassProperties>) = pieces.iter().map(placed).unzip();
    let (m, uncertainty) = union_moments(&regions, &props);
    UnionMass {
        mass: m.mass_properties(),
        uncertainty,
    }
}

/// Builds a composite body from its pieces: the union's mass properties (module docs), its
/// principal frame, and every piece placed in that frame. Fails on no pieces, more than
/// [`MAX_PIECES`], or a piece that is itself a composite.
pub fn prepare_composite(pieces: &[PieceSpec]) -> Result<PreparedShape, GeomError> {
    if pieces.is_empty() {
        return Err(GeomError::EmptyComposite);
    }
    if pieces.len() > MAX_PIECES {
        return Err(GeomError::TooManyPieces {
            count: pieces.len(),
        });
    }
    for (index, p) in pieces.iter().enumerate() {
        if matches!(p.shape.shape, Shape::Composite(_)) {
            return Err(GeomError::NestedComposite { index });
        }
        if !(p.offset.is_finite() && p.orientation.is_finite()) {
            return Err(GeomError::NonFinitePiece { index });
        }
    }
    let u = union_mass(pieces);
    if !(u.mass.volume > 0.0 && u.mass.volume.is_finite()) {
        return Err(GeomError::NonFinitePiece { index: 0 });
    }
    let (moments, rot) = u.mass.principal_axes();
    let com = u.mass.center;
    let inv = rot.conjugate();
    let mut placed_pieces = Vec::with_capacity(pieces.len());
    let (mut radius, mut reach) = (0.0f32, 0.0f32);
    for p in pieces {
        let q = p.orientation * p.shape.frame.as_dquat();
        let centre = p.offset;
        let position = (inv * (centre - com)).as_vec3();
        let orientation = (inv * q).normalize().as_quat();
        let shape = p.shape.shape.clone();
        radius = radius.max(position.length() + shape.bounding_radius());
        reach = reach.max(position.length());
        placed_pieces.push(Piece {
            equivalent_radius: (3.0 * p.shape.volume / (4.0 * std::f32::consts::PI)).cbrt(),
            shape,
            position,
            orientation,
        });
    }
    Ok(PreparedShape {
        shape: Shape::Composite(Arc::new(Composite {
            pieces: placed_pieces,
            radius,
            reach,
            uncertainty: u.uncertainty,
        })),
        volume: u.mass.volume as f32,
        unit_inertia: moments.as_vec3(),
        frame: rot.as_quat(),
        com: com.as_vec3(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cap_of_half_sphere() {
        let m = cap(DVec3::ZERO, 1.0, 0.0, DVec3::Z);
        let pi = std::f64::consts::PI;
        assert!((m.volume - 2.0 / 3.0 * pi).abs() < 1e-12);
        // Centroid of a hemisphere at 3/8 r.
        assert!((m.first.z / m.volume - 0.375).abs() < 1e-12);
        // Second moments: half the sphere's, 4 pi / 15 per axis for the full unit sphere.
        assert!((m.second.z_axis.z - 2.0 * pi / 15.0).abs() < 1e-12);
        assert!((m.second.x_axis.x - 2.0 * pi / 15.0).abs() < 1e-12);
    }
}
