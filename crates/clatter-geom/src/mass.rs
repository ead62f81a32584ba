//! Exact mass properties of spheres and convex polyhedra, and the principal frame.
use glam::{DMat3, DQuat, DVec3};

use crate::ConvexPolyhedron;

/// Volume, centre of mass and inertia tensor (about the centre of mass) at unit density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Volume (the mass at unit density).
    pub volume: f64,
    /// Centre of mass, in the frame the shape was given in.
    pub center: DVec3,
    /// Inertia tensor about the centre of mass at unit density (symmetric).
    pub inertia: DMat3,
}

/// `a b^T`.
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

impl MassProperties {
    /// Solid sphere of radius `r`.
    pub fn of_sphere(r: f64) -> Self {
        let volume = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        Self {
            volume,
            center: DVec3::ZERO,
            inertia: DMat3::from_diagonal(DVec3::splat(0.4 * volume * r * r)),
        }
    }

    /// Solid convex polyhedron, exactly (up to f64 rounding).
    ///
    /// Each face is fanned into triangles, each triangle with the vertex centroid forms a
    /// tetrahedron, and the closed-form tetrahedron integrals are summed:
    /// `V = det[a, b, c] / 6`, `int x dV = V (a + b + c) / 4` and
    /// `int x x^T dV = V / 20 (a a^T + b b^T + c c^T + s s^T)` with `s = a + b + c`
    /// (vertices relative to the apex). Working relative to the vertex centroid keeps the
    /// sums well conditioned for shapes far from the origin. A polyhedron without volume gives
    /// zero volume and inertia (never NaN).
    pub fn of_polyhedron(p: &ConvexPolyhedron) -> Self {
        let verts: Vec<DVec3> = p.vertices.iter().map(|v| v.as_dvec3()).collect();
        let apex = verts.iter().copied().sum::<DVec3>() / verts.len().max(1) as f64;
        let mut volume = 0.0;
        let mut first = DVec3::ZERO;
        let mut second = DMat3::ZERO;
        for f in 0..p.faces.len() {
            let lp = p.face_loop(f);
            let Some(&l0) = lp.first() else { continue };
            let a = verts[l0 as usize] - apex;
            for k in 1..lp.len().saturating_sub(1) {
                let b = verts[lp[k] as usize] - apex;
                let c = verts[lp[k + 1] as usize] - apex;
                let v = a.dot(b.cross(c)) / 6.0;
                let s = a + b + c;
                volume += v;
                first += s * (v / 4.0);
                second += (outer(a, a) + outer(b, b) + outer(c, c) + outer(s, s)) * (v / 20.0);
            }
        }
        if !(volume > 0.0 && volume.is_finite()) {
            return Self {
                volume: 0.0,
                center: apex,
                inertia: DMat3::ZERO,
            };
        }
        let d = first / volume;
        let cov = second - outer(d, d) * volume;
        let trace = cov.x_axis.x + cov.y_axis.y + cov.z_axis.z;
        Self {
            volume,
            center: apex + d,
            inertia: DMat3::from_diagonal(DVec3::splat(trace)) - cov,
        }
    }

    /// Principal moments and the proper rotation `R` (det +1) whose columns are the principal
    /// axes, so that `R^T I R` is diagonal with the moments in order.
    ///
    /// Symmetric eigen-decomposition by cyclic Jacobi rotations. When the tensor is already
    /// diagonal up to rounding (off-diagonal below 1e-9 of the trace) or isotropic (eigenvalue
    /// spread below 1e-6 of the trace, e.g. f32-rounded Platonic solids), the identity and the
    /// diagonal are returned, so that boxes and Platonic solids keep their authored orientation.
    /// Nothing is sorted.
    pub fn principal_axes(&self) -> (DVec3, DQuat) {
        let m = self.inertia;
        let mut a = [[0.0f64; 3]; 3];
        for (i, row) in a.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = 0.5 * (m.col(j)[i] + m.col(i)[j]);
            }
        }
        let diagonal = DVec3::new(a[0][0], a[1][1], a[2][2]);
        let scale = (a[0][0] + a[1][1] + a[2][2]).abs();
        let off = a[0][1].abs().max(a[0][2].abs()).max(a[1][2].abs());
        if off <= 1e-9 * scale || !a.iter().flatten().all(|x| x.is_finite()) {
            return (diagonal, DQuat::IDENTITY);
        }
        let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0f64]];
        for _sweep in 0..64 {
            let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
            if off <= 1e-17 * scale {
                break;
            }
            for (p, q) in [(0, 1), (0, 2), (1, 2)] {
                let apq = a[p][q];
                if apq.abs() <= 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
                };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                a[p][p] -= t * apq;
                a[q][q] += t * apq;
                a[p][q] = 0.0;
                a[q][p] = 0.0;
                let r = 3 - p - q;
                let (arp, arq) = (a[r][p], a[r][q]);
                a[r][p] = c * arp - s * arq;
                a[p][r] = a[r][p];
                a[r][q] = s * arp + c * arq;
                a[q][r] = a[r][q];
                for row in &mut v {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
        let moments = DVec3::new(a[0][0], a[1][1], a[2][2]);
        if moments.max_element() - moments.min_element() <= 1e-6 * scale {
            return (diagonal, DQuat::IDENTITY);
        }
        let col = |j: usize| DVec3::new(v[0][j], v[1][j], v[2][j]);
        let mut r = DMat3::from_cols(col(0), col(1), col(2));
        if r.determinant() < 0.0 {
            r.z_axis = -r.z_axis;
        }
        (moments, DQuat::from_mat3(&r).normalize())
    }
}
