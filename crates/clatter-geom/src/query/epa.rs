//! EPA (expanding polytope algorithm): penetration depth and normal of two overlapping convex
//! cores, in `f64`, started from the final GJK simplex.
//!
//! The polytope is a triangulated subset of the CSO `A - B` that contains the origin. Each
//! iteration takes the face closest to the origin, asks for the CSO support point along its
//! normal and, when that point lies further out than the face by more than the tolerance,
//! removes every face that sees it and fans the horizon to it.
//!
//! Termination:
//! * `w·n - d <= EPA_ABS_TOL * scale + EPA_REL_TOL * d`: converged, `d` is the depth;
//! * the support point is already a polytope vertex: converged (no further progress possible);
//! * [`EPA_MAX_ITERATIONS`] iterations or [`EPA_MAX_VERTICES`] vertices: the closest face so far
//!   is returned with `converged = false`; its distance is a lower bound on the depth and its
//!   normal a valid (if not minimal) separating direction.

use glam::DVec3;

use super::gjk::Simplex;
use super::support::Support;

/// Iteration cap of the EPA loop.
pub const EPA_MAX_ITERATIONS: usize = 128;
/// Vertex cap of the EPA polytope.
pub const EPA_MAX_VERTICES: usize = 256;
/// Relative tolerance on the depth.
pub const EPA_REL_TOL: f64 = 1e-7;
/// Absolute tolerance on the depth, as a fraction of the CSO scale.
pub const EPA_ABS_TOL: f64 = 1e-9;

#[derive(Clone, Copy, Debug)]
struct Vert {
    w: DVec3,
    a: DVec3,
    b: DVec3,
}

#[derive(Clone, Copy, Debug)]
struct Face {
    v: [u32; 3],
    n: DVec3,
    d: f64,
    alive: bool,
}

/// Result of EPA in the query frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Epa {
    /// Penetration depth (>= 0).
    pub depth: f64,
    /// Unit normal from `a` to `b`: translating `b` by `depth * normal` separates the cores.
    pub normal: DVec3,
    /// Deepest point of `a` (inside `b`).
    pub pa: DVec3,
    /// Deepest point of `b` (inside `a`).
    pub pb: DVec3,
}

#[inline]
fn sup<A: Support, B: Support>(a: &A, b: &B, d: DVec3) -> Vert {
    let pa = a.support(d);
    let pb = b.support(-d);
    Vert {
        w: pa - pb,
        a: pa,
        b: pb,
    }
}

/// Barycentric coordinates of the origin's projection on face `f`'s plane (a third each
/// for a face without area).
fn barycentric(verts: &[Vert], f: &Face) -> (f64, f64, f64) {
    let (x0, x1, x2) = (
        verts[f.v[0] as usize].w,
        verts[f.v[1] as usize].w,
        verts[f.v[2] as usize].w,
    );
    let p = f.n * f.d;
    let nn = (x1 - x0).cross(x2 - x0);
    let den = nn.length_squared();
    if den > 0.0 {
        let l0 = (x1 - p).cross(x2 - p).dot(nn) / den;
        let l1 = (x2 - p).cross(x0 - p).dot(nn) / den;
        (l0, l1, 1.0 - l0 - l1)
    } else {
        (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)
    }
}

fn make_face(verts: &[Vert], i: u32, j: u32, k: u32) -> Face {
    let (x0, x1, x2) = (
        verts[i as usize].w,
        verts[j as usize].w,
        verts[k as usize].w,
    );
    let n = (x1 - x0).cross(x2 - x0);
    let len = n.length();
    if !(len.is_finite() && len > 0.0) {
        // Zero-area face: keep it for the topology but never select it.
        return Face {
            v: [i, j, k],
            n: DVec3::ZERO,
            d: f64::INFINITY,
            alive: true,
        };
    }
    let n = n / len;
    let d = (n.dot(x0) + n.dot(x1) + n.dot(x2)) / 3.0;
    Face {
        v: [i, j, k],
        n,
        d,
        alive: true,
    }
}

/// Builds a tetrahedron of CSO points from the GJK simplex (which contains or touches the
/// origin), completing it with support points when GJK stopped with fewer than 4 points.
fn initial<A: Support, B: Support>(a: &A, b: &B, s: &Simplex, scale: f64) -> Vec<Vert> {
    let mut v: Vec<Vert> = (0..s.n)
        .map(|i| Vert {
            w: s.w[i],
            a: s.a[i],
            b: s.b[i],
        })
        .collect();
    let eps = 1e-9 * scale.max(f64::MIN_POSITIVE);
    if v.len() == 4 {
        let vol = (v[1].w - v[0].w)
            .cross(v[2].w - v[0].w)
            .dot(v[3].w - v[0].w)
            .abs();
        let edge = v
            .iter()
            .map(|x| (x.w - v[0].w).length())
            .fold(0.0, f64::max);
        if vol > 1e-12 * edge * edge * edge {
            return v;
        }
        // Flat tetrahedron: keep the face whose triangle contains the origin's projection
        // (best effort: the largest face otherwise) and rebuild the apex below.
        let faces = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        let mut best = faces[0];
        let mut best_area = -1.0;
        for f in faces {
            let n = (v[f[1]].w - v[f[0]].w).cross(v[f[2]].w - v[f[0]].w);
            let area = n.length();
            let side = |e: usize| {
                let p = v[f[e]].w;
                let q = v[f[(e + 1) % 3]].w;
                (q - p).cross(-p).dot(n)
            };
            let (s0, s1, s2) = (side(0), side(1), side(2));
            let inside =
                (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0);
            let score = if inside { area + 1e300 } else { area };
            if score > best_area {
                best_area = score;
                best = f;
            }
        }
        v = best.iter().map(|&i| v[i]).collect();
    }
    // Drop near-duplicates so the steps below see an affinely independent set.
    if v.len() >= 2 && (v[1].w - v[0].w).length() <= eps {
        v.truncate(1);
    }
    if v.len() == 3 {
        let n = (v[1].w - v[0].w).cross(v[2].w - v[0].w);
        if n.length() <= eps * (v[1].w - v[0].w).length().max(eps) {
            v.truncate(2);
        }
    }
    if v.len() == 1 {
        let mut best = None;
        let mut bd = eps;
        for d in [
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z,
        ] {
            let p = sup(a, b, d);
            let dd = (p.w - v[0].w).length();
            if dd > bd {
                bd = dd;
                best = Some(p);
            }
        }
        v.push(best.unwrap_or(sup(a, b, DVec3::X)));
    }
    if v.len() == 2 {
        let axis = (v[1].w - v[0].w).normalize_or_zero();
        let e1 = axis.any_orthonormal_vector();
        let e2 = axis.cross(e1);
        let mut best = None;
        let mut bd = -1.0;
        for d in [e1, -e1, e2, -e2, e1 + e2, -e1 - e2, e1 - e2, e2 - e1] {
            let p = sup(a, b, d);
            let r = p.w - v[0].w;
            let dd = (r - axis * r.dot(axis)).length();
            if dd > bd {
                bd = dd;
                best = Some(p);
            }
        }
        v.push(best.expect("eight candidates"));
    }
    let n = (v[1].w - v[0].w).cross(v[2].w - v[0].w).normalize_or_zero();
    let p = sup(a, b, n);
    let q = sup(a, b, -n);
    if (p.w - v[0].w).dot(n).abs() >= (q.w - v[0].w).dot(n).abs() {
        v.push(p);
    } else {
        v.push(q);
    }
    v
}

/// Runs EPA on `a - b` from the GJK simplex `s` (which must contain or touch the origin).
pub(crate) fn epa<A: Support, B: Support>(a: &A, b: &B, s: &Simplex) -> Epa {
    let scale = (0..s.n).map(|i| s.w[i].length()).fold(0.0, f64::max) + a.radius() + b.radius();
    let mut verts = initial(a, b, s, scale);
    verts.reserve(48);
    let mut faces: Vec<Face> = Vec::with_capacity(96);
    let centroid = verts.iter().map(|x| x.w).sum::<DVec3>() / 4.0;
    for f in [[0u32, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]] {
        let mut face = make_face(&verts, f[0], f[1], f[2]);
        if face.n.dot(centroid - verts[f[0] as usize].w) > 0.0 {
            face = make_face(&verts, f[0], f[2], f[1]);
        }
        faces.push(face);
    }
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(32);
    let mut best = 0usize;
    for _ in 0..EPA_MAX_ITERATIONS {
        // Closest live face.
        let mut bd = f64::INFINITY;
        for (i, f) in faces.iter().enumerate() {
            if f.alive && f.d < bd {
                bd = f.d;
                best = i;
            }
        }
        if !bd.is_finite() {
            break;
        }
        let f = faces[best];
        let p = sup(a, b, f.n);
        let dw = p.w.dot(f.n);
        if dw - f.d <= EPA_ABS_TOL * scale + EPA_REL_TOL * f.d.max(0.0) {
            break;
        }
        if verts.iter().any(|x| x.a == p.a && x.b == p.b) || verts.len() >= EPA_MAX_VERTICES {
            break;
        }
        let ni = verts.len() as u32;
        verts.push(p);
        edges.clear();
        for face in faces.iter_mut() {
            if !face.alive {
                continue;
            }
            let visible = if face.d.is_finite() {
                face.n.dot(p.w - verts[face.v[0] as usize].w) > 0.0
            } else {
                false
            };
            if !visible {
                continue;
            }
            face.alive = false;
            for e in 0..3 {
                let (x, y) = (face.v[e], face.v[(e + 1) % 3]);
                if let Some(k) = edges.iter().position(|&(u, w)| u == y && w == x) {
                    edges.swap_remove(k);
                } else {
                    edges.push((x, y));
                }
            }
        }
        // The chosen face is always visible (dw > d); guard against rounding anyway.
        if faces[best].alive {
            break;
        }
        // Recycle dead slots to keep the face list short.
        let mut slot = 0usize;
        for &(x, y) in &edges {
            let nf = make_face(&verts, x, y, ni);
            while slot < faces.len() && faces[slot].alive {
                slot += 1;
            }
            if slot < faces.len() {
                faces[slot] = nf;
            } else {
                faces.push(nf);
            }
        }
    }
    // The origin's projection on the closest face's plane lies in that face for a convex
    // polytope around the origin; with rounding (or a polytope that only touches the
    // origin) it can fall outside, and the face's barycentric witnesses are then not
    // `depth * normal` apart. Another live face at the same distance (within the
    // tolerance) that holds the projection gives the witnesses that are.
    let tol = EPA_ABS_TOL * scale + EPA_REL_TOL * faces[best].d.max(0.0);
    let inside = |f: &Face| {
        let (l0, l1, l2) = barycentric(&verts, f);
        l0.min(l1).min(l2) >= -1e-9
    };
    if !inside(&faces[best]) {
        let d0 = faces[best].d;
        if let Some(k) = (0..faces.len())
            .filter(|&k| faces[k].alive && faces[k].d.is_finite() && faces[k].d <= d0 + tol)
            .filter(|&k| inside(&faces[k]))
            .min_by(|&x, &y| faces[x].d.total_cmp(&faces[y].d))
        {
            best = k;
        }
    }
    let f = faces[best];
    let depth = f.d.max(0.0);
    let (x0, x1, x2) = (
        verts[f.v[0] as usize],
        verts[f.v[1] as usize],
        verts[f.v[2] as usize],
    );
    let (mut l0, mut l1, mut l2) = barycentric(&verts, &f);
    if l0 < 0.0 || l1 < 0.0 || l2 < 0.0 {
        l0 = l0.max(0.0);
        l1 = l1.max(0.0);
        l2 = l2.max(0.0);
        let s = l0 + l1 + l2;
        (l0, l1, l2) = if s > 0.0 {
            (l0 / s, l1 / s, l2 / s)
        } else {
            (1.0, 0.0, 0.0)
        };
    }
    let pa = x0.a * l0 + x1.a * l1 + x2.a * l2;
    let pb = x0.b * l0 + x1.b * l1 + x2.b * l2;
    let normal = if f.n.length_squared() > 0.0 {
        f.n
    } else {
        DVec3::X
    };
    Epa {
        depth,
        normal,
        pa,
        pb,
    }
}
