// The narrow phase of scenes made only of spheres: the sphere-sphere and sphere-plane cases of
// narrow.wgsl, without the polyhedron code (which is large, and slow to compile on software
// adapters). Same interface and bindings as narrow.wgsl.

@group(1) @binding(0) var<storage, read> shape_f: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> shape_u: array<u32>;

const NRW_HDR: u32 = 12u;

// The separating-axis hint of narrow.wgsl: spheres need none, always 0.
var<private> nrw_hint_in: u32 = 0u;
var<private> nrw_hint_out: u32 = 0u;
// The contact memory of narrow.wgsl: spheres remember nothing.
var<private> nrw_mem_in: vec2<u32> = vec2<u32>(NO_HINT, 0u);
var<private> nrw_mem_out: vec2<u32> = vec2<u32>(NO_HINT, 0u);
// The anchored margins of narrow.wgsl: spheres anchor nothing (never written).
var<private> nrw_anchored: bool = false;
var<private> nrw_anchor_in: array<vec4<f32>, 2>;
var<private> nrw_anchor_out: array<vec4<f32>, 2>;
var<private> nrw_anchor_written: bool = false;

struct Manifold {
    normal: vec3<f32>,
    count: u32,
    points: array<vec4<f32>, 4>,
}

fn shape_is_sphere(s: u32) -> bool {
    return shape_u[s * NRW_HDR] == 0u;
}

fn shape_radius(s: u32) -> f32 {
    return bitcast<f32>(shape_u[s * NRW_HDR + 1u]);
}

// As narrow.rs's sphere_sphere.
fn collide(sa: u32, xa: vec3<f32>, qa: vec4<f32>, sb: u32, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    var m = Manifold();
    let ra = shape_radius(sa);
    let rb = shape_radius(sb);
    let d = xb - xa;
    let dist2 = dot(d, d);
    let rsum = ra + rb;
    if dist2 >= rsum * rsum {
        return m;
    }
    let dist = sqrt(dist2);
    var normal = vec3<f32>(0.0, 0.0, 1.0);
    if dist > 1e-12 * rsum {
        normal = d / dist;
    }
    let depth = rsum - dist;
    m.normal = normal;
    m.count = 1u;
    m.points[0] = vec4<f32>(xa + normal * (ra - 0.5 * depth), depth);
    return m;
}

// contacts_split.wgsl's `collide_kind` (scenes with polyhedra): here every pair is two spheres.
fn collide_kind(kind: u32, sa: u32, xa: vec3<f32>, qa: vec4<f32>, sb: u32, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    return collide(sa, xa, qa, sb, xb, qb);
}

// As narrow.rs's collide_plane for a sphere.
fn collide_plane(n: vec3<f32>, offset: f32, s: u32, x: vec3<f32>, q: vec4<f32>) -> Manifold {
    var m = Manifold();
    let radius = shape_radius(s);
    let depth = radius - (dot(n, x) - offset);
    if depth <= 0.0 {
        return m;
    }
    m.normal = n;
    m.count = 1u;
    m.points[0] = vec4<f32>(x - n * (radius - 0.5 * depth), depth);
    return m;
}
