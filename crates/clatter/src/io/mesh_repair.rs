//! Boundary meshes as users have them: the cleaning that [`crate::mesh_boundary::Boundary::new`]
//! does before it derives normals and adjacency.
//!
//! Meshes from CAD exports, scanners and other DEM codes (LIGGGHTS wants its drums wound with
//! the normals towards the grains) differ from a textbook closed manifold in ways that change
//! nothing in the physics, since clatter's triangles are two-sided. [`repair`] makes them
//! uniform, in this order:
//! 1. **Weld** vertices closer than the weld tolerance ([`WELD_RELATIVE`] times the mesh's
//!    bounding-box diagonal, or the scene's `mesh.weld` in metres) into the first of them (in
//!    file order): STL files repeat every vertex, and exports leave small gaps.
//! 2. **Drop degenerate triangles**: two corners welded together, or an area below
//!    [`SLIVER`] times the square of the longest edge (slivers: no normal to speak of).
//! 3. **Split T-junctions**: a vertex lying on a border edge of another triangle (within the
//!    weld tolerance) splits that triangle, so that both sides share the edge and the ghost
//!    contact filter sees the surface as continuous.
//! 4. **Drop duplicate triangles** (the same three vertices, in any order), keeping the first.
//! 5. **Orient**: each connected part is re-wound consistently with its first triangle (by
//!    id); a closed part wound inwards is turned outwards. Winding decides nothing in the
//!    contact code; this only keeps normals, outputs and pictures uniform.
//!
//! Edges shared by more than two triangles (non-manifold: a fin standing on a floor, two
//! sheets crossing) are kept: [`pair_edge_users`] pairs the triangles around such an edge by
//! how flat their continuation is, each pair sees the other as its neighbour across the edge
//! (as at an ordinary edge), and a triangle left over treats the edge as a border.
//!
//! Nothing here is refused but what cannot be a surface: a non-finite coordinate, an index out
//! of range, or no triangle left.

use std::collections::HashMap;

use glam::DVec3;

/// Default weld tolerance, relative to the mesh's bounding-box diagonal (after `scale`).
pub const WELD_RELATIVE: f64 = 1e-6;

/// A triangle whose area is below this times the square of its longest edge is degenerate.
pub const SLIVER: f64 = 1e-9;

/// What [`repair`] changed, for the scene's warning and note lines.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MeshRepairs {
    /// The weld tolerance used (m).
    pub weld_tolerance: f64,
    /// Vertices merged into another one at a different position (exact repeats, as in every
    /// STL file, are not counted).
    pub welded: usize,
    /// Triangles dropped as degenerate (welded corners, zero area, slivers).
    pub degenerate: usize,
    /// Triangles dropped as duplicates of an earlier one.
    pub duplicates: usize,
    /// Vertices inserted into the edges of triangles at T-junctions.
    pub t_junctions: usize,
    /// Edges shared by more than two triangles.
    pub non_manifold: usize,
    /// Triangles re-wound to agree with their neighbours (mixed windings).
    pub rewound: usize,
    /// Closed parts that were wound inwards (turned outwards).
    pub inward_parts: usize,
}

impl MeshRepairs {
    /// One warning line for the repairs a user should know of (dropped triangles, welds of
    /// distinct positions, T-junctions, non-manifold edges), or `None` for a clean mesh.
    pub fn warning(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.duplicates > 0 {
            parts.push(format!("dropped {} duplicate triangles", self.duplicates));
        }
        if self.degenerate > 0 {
            parts.push(format!(
                "dropped {} degenerate triangles (zero area or slivers)",
                self.degenerate
            ));
        }
        if self.welded > 0 {
            parts.push(format!(
                "welded {} vertices within {:.3e} m (mesh.weld)",
                self.welded, self.weld_tolerance
            ));
        }
        if self.t_junctions > 0 {
            parts.push(format!(
                "split triangles at {} T-junctions",
                self.t_junctions
            ));
        }
        if self.non_manifold > 0 {
            parts.push(format!(
                "{} edges shared by more than two triangles (kept, paired by flatness)",
                self.non_manifold
            ));
        }
        (!parts.is_empty()).then(|| parts.join("; "))
    }

    /// One informational line when a closed part was wound inwards or windings were mixed
    /// (changes nothing: triangles are two-sided), or `None`.
    pub fn note(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.inward_parts > 0 {
            parts.push("closed and wound inwards (normals towards the inside, as LIGGGHTS meshes often are)".to_string());
        }
        if self.rewound > 0 {
            parts.push(format!(
                "{} triangles wound against their neighbours",
                self.rewound
            ));
        }
        (!parts.is_empty()).then(|| {
            format!(
                "{}; triangles are two-sided, so the winding changes nothing",
                parts.join(", ")
            )
        })
    }
}

/// A cleaned mesh: welded vertices (scaled), triangles and what was done.
#[derive(Debug, Clone, PartialEq)]
pub struct Repaired {
    pub vertices: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub repairs: MeshRepairs,
}

/// Cleans a mesh (file coordinates times `scale`; see the module docs). `weld` is the weld
/// tolerance in metres (`None`: [`WELD_RELATIVE`] of the bounding-box diagonal). The error
/// says what cannot be a surface, naming the vertex or triangle (file numbering).
pub fn repair(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    scale: [f64; 3],
    weld: Option<f64>,
) -> Result<Repaired, String> {
    if triangles.is_empty() {
        return Err(format!(
            "empty mesh: {} vertices and no triangles (a boundary needs triangles)",
            vertices.len()
        ));
    }
    let scaled = scaled_vertices(vertices, scale)?;
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&i) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(format!(
                "triangle {t} uses vertex {i}, but the mesh has {} vertices",
                vertices.len()
            ));
        }
    }
    let (lo, hi) = bounds(&scaled);
    let tolerance = weld.unwrap_or(WELD_RELATIVE * (hi - lo).length());
    let mut repairs = MeshRepairs {
        weld_tolerance: tolerance,
        ..Default::default()
    };
    let (pos, remap) = weld_vertices(&scaled, tolerance, &mut repairs.welded);
    let mut tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| remap[i as usize]))
        .collect();
    let kept = drop_degenerate(&pos, &mut tris);
    repairs.degenerate = kept.dropped;
    if tris.is_empty() {
        return Err(format!(
            "every triangle is degenerate (zero area, or corners closer than the weld tolerance {tolerance:.3e} m), e.g. triangle {}",
            kept.first.unwrap_or(0)
        ));
    }
    repairs.t_junctions = split_t_junctions(&pos, &mut tris, tolerance);
    repairs.duplicates = drop_duplicates(&mut tris);
    let orient = orient(&pos, &mut tris);
    repairs.rewound = orient.rewound;
    repairs.inward_parts = orient.inward_parts;
    repairs.non_manifold = edge_users(&tris).values().filter(|u| u.len() > 2).count();
    Ok(Repaired {
        vertices: pos,
        triangles: tris,
        repairs,
    })
}

/// The vertices times `scale`, every coordinate finite.
fn scaled_vertices(vertices: &[[f64; 3]], scale: [f64; 3]) -> Result<Vec<DVec3>, String> {
    vertices
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let s = DVec3::new(v[0] * scale[0], v[1] * scale[1], v[2] * scale[2]);
            // Finite also as the f32 the mesh is kept in (a scale of 1e39 was NaN geometry).
            if s.is_finite() && s.as_vec3().is_finite() {
                Ok(s + DVec3::ZERO) // -0.0 and 0.0 weld together
            } else {
                Err(format!(
                    "vertex {i} has a non-finite coordinate (as a 32-bit float, after scaling): [{}, {}, {}]",
                    v[0], v[1], v[2]
                ))
            }
        })
        .collect()
}

fn bounds(p: &[DVec3]) -> (DVec3, DVec3) {
    p.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), v| (lo.min(*v), hi.max(*v)),
    )
}

/// Welds each vertex into the first earlier one within `tol` (exactly equal positions
/// always). Returns the kept positions and, per input vertex, its kept index; `welded`
/// counts merges of distinct positions.
fn weld_vertices(p: &[DVec3], tol: f64, welded: &mut usize) -> (Vec<DVec3>, Vec<u32>) {
    let mut exact: HashMap<[u64; 3], u32> = HashMap::new();
    let cell = if tol > 0.0 { tol } else { f64::INFINITY };
    let key = |v: DVec3| (v / cell).floor().as_i64vec3().to_array();
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut pos: Vec<DVec3> = Vec::new();
    let mut remap = Vec::with_capacity(p.len());
    for &v in p {
        let bits = [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        if let Some(&id) = exact.get(&bits) {
            remap.push(id);
            continue;
        }
        let near = if tol > 0.0 {
            nearest_kept(&grid, &pos, key(v), v, tol)
        } else {
            None
        };
        let id = match near {
            Some(id) => {
                *welded += 1;
                id
            }
            None => {
                pos.push(v);
                let id = (pos.len() - 1) as u32;
                if tol > 0.0 {
                    grid.entry(key(v)).or_default().push(id);
                }
                id
            }
        };
        exact.insert(bits, id);
        remap.push(id);
    }
    (pos, remap)
}

/// The lowest-numbered kept vertex within `tol` of `v` (cells of size `tol` around `c`).
fn nearest_kept(
    grid: &HashMap<[i64; 3], Vec<u32>>,
    pos: &[DVec3],
    c: [i64; 3],
    v: DVec3,
    tol: f64,
) -> Option<u32> {
    let mut best: Option<u32> = None;
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                let cell = [c[0] + dx, c[1] + dy, c[2] + dz];
                for &id in grid.get(&cell).into_iter().flatten() {
                    if pos[id as usize].distance(v) <= tol && best.is_none_or(|b| id < b) {
                        best = Some(id);
                    }
                }
            }
        }
    }
    best
}

/// What [`drop_degenerate`] removed.
struct Dropped {
    dropped: usize,
    /// The first dropped triangle's index (input numbering).
    first: Option<usize>,
}

/// Whether triangle `t` has an area (no welded corners, not a sliver).
fn is_proper(pos: &[DVec3], t: &[u32; 3]) -> bool {
    if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
        return false;
    }
    let [a, b, c] = t.map(|i| pos[i as usize]);
    let longest = (b - a)
        .length_squared()
        .max((c - b).length_squared())
        .max((a - c).length_squared());
    (b - a).cross(c - a).length() > SLIVER * longest
}

fn drop_degenerate(pos: &[DVec3], tris: &mut Vec<[u32; 3]>) -> Dropped {
    let mut out = Dropped {
        dropped: 0,
        first: None,
    };
    let mut k = 0;
    tris.retain(|t| {
        let ok = is_proper(pos, t);
        if !ok {
            out.dropped += 1;
            out.first.get_or_insert(k);
        }
        k += 1;
        ok
    });
    out
}

/// Drops triangles with the same vertex set as an earlier one; returns how many.
fn drop_duplicates(tris: &mut Vec<[u32; 3]>) -> usize {
    let mut seen = std::collections::HashSet::new();
    let before = tris.len();
    tris.retain(|t| {
        let mut s = *t;
        s.sort_unstable();
        seen.insert(s)
    });
    before - tris.len()
}

/// The triangles (and the edge's index in each, `k`: vertex `k` to `k + 1`) using each
/// undirected edge `(min, max)`, in triangle order.
pub(crate) fn edge_users(tris: &[[u32; 3]]) -> HashMap<(u32, u32), Vec<(u32, u8)>> {
    let mut edges: HashMap<(u32, u32), Vec<(u32, u8)>> = HashMap::new();
    for (t, w) in tris.iter().enumerate() {
        for k in 0..3u8 {
            let (a, b) = (w[k as usize], w[(k as usize + 1) % 3]);
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push((t as u32, k));
        }
    }
    edges
}

/// Splits triangles whose border edges (used by one triangle) pass through other vertices
/// (within `tol` of the edge, strictly between its ends), into fans, until none is left.
/// Returns the number of vertices inserted into edges.
fn split_t_junctions(pos: &[DVec3], tris: &mut Vec<[u32; 3]>, tol: f64) -> usize {
    // Vertices sorted by x, to find those near an edge by the edge's x range.
    let mut by_x: Vec<u32> = (0..pos.len() as u32).collect();
    by_x.sort_by(|&a, &b| pos[a as usize].x.total_cmp(&pos[b as usize].x));
    let used: Vec<bool> = {
        let mut u = vec![false; pos.len()];
        tris.iter().flatten().for_each(|&i| u[i as usize] = true);
        u
    };
    let mut inserted = 0;
    // Each pass splits every triangle at most once (on one edge); a triangle with T-vertices
    // on several edges is finished in later passes. The count of passes is bounded by 3.
    for _ in 0..3 {
        let edges = edge_users(tris);
        let mut border: Vec<(&(u32, u32), u32, u8)> = edges
            .iter()
            .filter(|(_, u)| u.len() == 1)
            .map(|(e, u)| (e, u[0].0, u[0].1))
            .collect();
        border.sort_unstable_by_key(|(_, t, k)| (*t, *k));
        let mut split_done = vec![false; tris.len()];
        let mut added: Vec<[u32; 3]> = Vec::new();
        for (_, t, k) in border {
            if split_done[t as usize] {
                continue;
            }
            let tri = tris[t as usize];
            let (a, b, c) = (
                tri[k as usize],
                tri[(k as usize + 1) % 3],
                tri[(k as usize + 2) % 3],
            );
            let on = vertices_on_segment(pos, &by_x, &used, a, b, tol);
            if on.is_empty() {
                continue;
            }
            inserted += on.len();
            split_done[t as usize] = true;
            // The fan a, v1, .., vn, b around c, wound like the triangle (a -> b -> c).
            let chain: Vec<u32> = std::iter::once(a)
                .chain(on.iter().copied())
                .chain(std::iter::once(b))
                .collect();
            tris[t as usize] = [chain[0], chain[1], c];
            for w in chain.windows(2).skip(1) {
                added.push([w[0], w[1], c]);
            }
        }
        if added.is_empty() && !split_done.iter().any(|&s| s) {
            break;
        }
        tris.extend(added);
    }
    inserted
}

/// The used vertices other than `a` and `b` within `tol` of the segment `a b` and strictly
/// inside it, ordered from `a` to `b`.
fn vertices_on_segment(
    pos: &[DVec3],
    by_x: &[u32],
    used: &[bool],
    a: u32,
    b: u32,
    tol: f64,
) -> Vec<u32> {
    let (pa, pb) = (pos[a as usize], pos[b as usize]);
    let (x0, x1) = (pa.x.min(pb.x) - tol, pa.x.max(pb.x) + tol);
    let start = by_x.partition_point(|&i| pos[i as usize].x < x0);
    let d = pb - pa;
    let len2 = d.length_squared();
    let mut on: Vec<(f64, u32)> = Vec::new();
    for &i in by_x[start..]
        .iter()
        .take_while(|&&i| pos[i as usize].x <= x1)
    {
        if i == a || i == b || !used[i as usize] {
            continue;
        }
        let p = pos[i as usize];
        let s = (p - pa).dot(d) / len2;
        if s <= 0.0 || s >= 1.0 {
            continue;
        }
        if (pa + d * s).distance(p) <= tol && p.distance(pa) > tol && p.distance(pb) > tol {
            on.push((s, i));
        }
    }
    on.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    on.into_iter().map(|(_, i)| i).collect()
}

/// What [`orient`] changed.
struct Oriented {
    rewound: usize,
    inward_parts: usize,
}

/// Re-winds every connected part (through edges shared by exactly two triangles) like its
/// lowest-numbered triangle; then turns a closed, consistently wound part with negative
/// volume outwards. A triangle is re-wound by swapping its last two corners.
fn orient(pos: &[DVec3], tris: &mut [[u32; 3]]) -> Oriented {
    let edges = edge_users(tris);
    let mut part = vec![u32::MAX; tris.len()];
    let mut out = Oriented {
        rewound: 0,
        inward_parts: 0,
    };
    let mut flip = vec![false; tris.len()];
    for seed in 0..tris.len() {
        if part[seed] != u32::MAX {
            continue;
        }
        let members = walk_part(seed, tris, &edges, &mut part, &mut flip);
        let consistent = members.iter().all(|&t| {
            (0..3).all(|k| {
                let e = edge_of(&tris[t], k, flip[t]);
                let users = &edges[&(e.0.min(e.1), e.0.max(e.1))];
                users.len() == 2
                    && users.iter().all(|&(u, j)| {
                        u as usize == t
                            || edge_of(&tris[u as usize], j as usize, flip[u as usize])
                                == (e.1, e.0)
                    })
            })
        });
        if consistent {
            let volume: f64 = members
                .iter()
                .map(|&t| {
                    let [a, b, c] = wound(&tris[t], flip[t]).map(|i| pos[i as usize]);
                    a.dot(b.cross(c))
                })
                .sum();
            if volume < 0.0 {
                out.inward_parts += 1;
                members.iter().for_each(|&t| flip[t] = !flip[t]);
            }
        }
    }
    for (t, f) in flip.iter().enumerate() {
        if *f {
            tris[t].swap(1, 2);
        }
    }
    // Re-wound against the file: those whose part kept its seed's winding and were flipped.
    out.rewound = count_against_seed(&part, &flip);
    out
}

/// Triangles flipped relative to their part's seed (those a mixed winding re-wound).
fn count_against_seed(part: &[u32], flip: &[bool]) -> usize {
    (0..part.len())
        .filter(|&t| flip[t] != flip[part[t] as usize])
        .count()
}

/// Triangle `t`'s corners, swapped when `flip`.
fn wound(t: &[u32; 3], flip: bool) -> [u32; 3] {
    if flip { [t[0], t[2], t[1]] } else { *t }
}

/// The directed edge `k` of triangle `t` as it runs once `flip` is applied: edge `k` of the
/// file's winding, reversed when flipped.
fn edge_of(t: &[u32; 3], k: usize, flip: bool) -> (u32, u32) {
    let (a, b) = (t[k], t[(k + 1) % 3]);
    if flip { (b, a) } else { (a, b) }
}

/// Breadth-first from `seed` over edges shared by exactly two triangles: marks the part
/// (`part[t] = seed`) and sets `flip` so that neighbours run along shared edges in opposite
/// directions. Returns the part's triangles.
fn walk_part(
    seed: usize,
    tris: &[[u32; 3]],
    edges: &HashMap<(u32, u32), Vec<(u32, u8)>>,
    part: &mut [u32],
    flip: &mut [bool],
) -> Vec<usize> {
    let mut members = vec![seed];
    part[seed] = seed as u32;
    let mut at = 0;
    while at < members.len() {
        let t = members[at];
        at += 1;
        for k in 0..3 {
            let e = edge_of(&tris[t], k, flip[t]);
            let users = &edges[&(e.0.min(e.1), e.0.max(e.1))];
            if users.len() != 2 {
                continue;
            }
            for &(u, j) in users {
                let u = u as usize;
                if u == t || part[u] != u32::MAX {
                    continue;
                }
                part[u] = seed as u32;
                // u must run along the edge as (e.1, e.0).
                flip[u] = edge_of(&tris[u], j as usize, false) == e;
                members.push(u);
            }
        }
    }
    members
}

/// Pairs the triangles around an edge shared by more than two (`users`, with the directions
/// `u` from the edge into each triangle, in its plane): the pairs whose continuation is
/// flattest (most opposite `u`) first, each triangle at most once, ties by triangle order.
/// Returns the pairs as positions in `users`.
pub fn pair_edge_users(dirs: &[DVec3]) -> Vec<(usize, usize)> {
    let mut cand: Vec<(f64, usize, usize)> = Vec::new();
    for i in 0..dirs.len() {
        for j in i + 1..dirs.len() {
            cand.push((dirs[i].dot(dirs[j]), i, j));
        }
    }
    cand.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    let mut taken = vec![false; dirs.len()];
    let mut pairs = Vec::new();
    for (_, i, j) in cand {
        if !taken[i] && !taken[j] {
            taken[i] = true;
            taken[j] = true;
            pairs.push((i, j));
        }
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        (
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
    }

    fn fix(v: &[[f64; 3]], t: &[[u32; 3]]) -> Repaired {
        repair(v, t, [1.0; 3], None).unwrap()
    }

    #[test]
    fn a_clean_mesh_is_unchanged() {
        let (v, t) = tetra();
        let r = fix(&v, &t);
        assert_eq!(r.triangles, t);
        assert_eq!(r.repairs.warning(), None);
        assert_eq!(r.repairs.note(), None);
    }

    #[test]
    fn inward_and_mixed_windings_become_the_clean_winding() {
        let (v, t) = tetra();
        let inward: Vec<[u32; 3]> = t.iter().map(|t| [t[0], t[2], t[1]]).collect();
        let r = fix(&v, &inward);
        assert_eq!(r.triangles, t);
        assert_eq!(r.repairs.inward_parts, 1);
        assert!(r.repairs.note().unwrap().contains("inwards"));
        let mut mixed = t.clone();
        mixed[1] = [t[1][0], t[1][2], t[1][1]];
        mixed[3] = [t[3][0], t[3][2], t[3][1]];
        let r = fix(&v, &mixed);
        assert_eq!(r.triangles, t);
        assert_eq!(r.repairs.rewound, 2);
    }

    #[test]
    fn duplicates_degenerates_and_gaps() {
        let (mut v, mut t) = tetra();
        t.push([3, 1, 0]); // a duplicate of triangle 1, other winding
        t.push([0, 1, 1]); // welded corners
        v.push([0.5, 0.5, 1e-12]); // a sliver's apex, on the line from 1 to 2 nearly
        t.push([1, 2, 4]);
        // A copy of vertex 3 moved by less than the weld tolerance.
        v.push([0.0, 0.0, 1.0 + 1e-9]);
        t[3] = [1, 2, 5];
        let r = fix(&v, &t);
        assert_eq!(r.triangles, tetra().1);
        assert_eq!(r.repairs.duplicates, 1);
        assert_eq!(r.repairs.degenerate, 2);
        assert_eq!(r.repairs.welded, 1);
        let w = r.repairs.warning().unwrap();
        assert!(
            w.contains("1 duplicate") && w.contains("2 degenerate"),
            "{w}"
        );
    }

    #[test]
    fn a_t_junction_is_split() {
        // A unit square: one big triangle on one side of the diagonal, two on the other,
        // meeting the diagonal's midpoint.
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
        ];
        let t = vec![[0, 1, 2], [0, 4, 3], [4, 2, 3]];
        let r = fix(&v, &t);
        assert_eq!(r.repairs.t_junctions, 1);
        let edges = edge_users(&r.triangles);
        let border = edges.values().filter(|u| u.len() == 1).count();
        assert_eq!(border, 4, "{:?}", r.triangles);
        assert_eq!(r.triangles.len(), 4);
        let area: f64 = r
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| r.vertices[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        assert!((area - 1.0).abs() < 1e-12);
    }

    #[test]
    fn refusals_name_the_culprit() {
        let (v, t) = tetra();
        assert!(
            repair(&v, &[], [1.0; 3], None)
                .unwrap_err()
                .contains("empty")
        );
        assert!(
            repair(&v, &[[0, 1, 9]], [1.0; 3], None)
                .unwrap_err()
                .contains("triangle 0 uses vertex 9")
        );
        let mut nan = v.clone();
        nan[2][0] = f64::NAN;
        assert!(
            repair(&nan, &t, [1.0; 3], None)
                .unwrap_err()
                .contains("vertex 2")
        );
        assert!(
            repair(&v, &[[0, 1, 1], [2, 2, 3]], [1.0; 3], None)
                .unwrap_err()
                .contains("every triangle is degenerate")
        );
    }

    #[test]
    fn flattest_pairs_first() {
        // A floor's two halves (opposite directions) and a fin (up).
        let d = [DVec3::X, DVec3::Z, -DVec3::X];
        assert_eq!(pair_edge_users(&d), vec![(0, 2)]);
    }
}
