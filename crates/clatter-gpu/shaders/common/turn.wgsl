// The pose of a turning mesh boundary, twin of clatter's src/turn.rs operation for operation
// (the constants TURN_* are generated from it): bitwise the CPU's. Every intermediate result
// and every constant passes through `turn_r`, an integer operation the compiler cannot see
// through (xor with a zero it does not know): so it can neither fuse a product and a sum
// into one multiply-add (one rounding instead of the CPU's two) nor reassociate or simplify
// a sum (Mesa's NIR does both to float code not marked exact, and `* params.one` alone did
// not stop it: lavapipe dropped the small parts of the angle's double-single sums).

// x, unchanged, but opaque to the compiler.
fn turn_r(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ (bitcast<u32>(params.one) ^ 0x3f800000u));
}

// `a b` exactly as (product, error): status.wgsl's two_prod behind turn_r.
fn turn_two_prod(a: f32, b: f32) -> vec2<f32> {
    let p = turn_r(a * b);
    let ca = turn_r(4097.0 * a);
    let ah = turn_r(ca - turn_r(ca - a));
    let al = turn_r(a - ah);
    let cb = turn_r(4097.0 * b);
    let bh = turn_r(cb - turn_r(cb - b));
    let bl = turn_r(b - bh);
    let e0 = turn_r(turn_r(ah * bh) - p);
    let e1 = turn_r(e0 + turn_r(ah * bl));
    let e2 = turn_r(e1 + turn_r(al * bh));
    return vec2<f32>(p, turn_r(e2 + turn_r(al * bl)));
}

// A boundary's pose: world = rotate(q, local) + t.
struct MeshPose {
    q: vec4<f32>,
    t: vec3<f32>,
}

// `(rate u) mod 2 pi` rounded to f32, in [0, 2 pi], for the double-single elapsed time u
// (`turn_angle`).
fn turn_angle(rate: f32, u: vec2<f32>) -> f32 {
    let tau_hi = turn_r(TURN_TAU_HI);
    let tau_lo = turn_r(TURN_TAU_LO);
    let a = turn_two_prod(rate, u.x);
    let a_lo = turn_r(a.y + turn_r(rate * u.y));
    let k = floor(turn_r(a.x * turn_r(TURN_INV_TAU)));
    let p = turn_two_prod(k, tau_hi);
    let p_lo = turn_r(p.y + turn_r(k * tau_lo));
    var hi = turn_r(a.x - p.x);
    var lo = turn_r(a_lo - p_lo);
    let r = turn_r(hi + lo);
    if r < 0.0 {
        hi = turn_r(hi + tau_hi);
        lo = turn_r(lo + tau_lo);
    } else if r >= tau_hi {
        hi = turn_r(hi - tau_hi);
        lo = turn_r(lo - tau_lo);
    }
    return turn_r(hi + lo);
}

// (sin x, cos x) for 0 <= x < 4: Cephes' sinf/cosf (`sin_cos`). WGSL's own sin and cos are
// not enough: Vulkan only asks for an absolute error of 2^-11, and lavapipe's is of that
// order, which moved a turning drum's wall by micrometres.
fn turn_sin_cos(x: f32) -> vec2<f32> {
    var j = u32(turn_r(x * turn_r(TURN_FOPI)));
    if (j & 1u) == 1u {
        j += 1u;
    }
    let y = f32(j);
    let z0 = turn_r(x - turn_r(y * turn_r(TURN_DP1)));
    let z1 = turn_r(z0 - turn_r(y * turn_r(TURN_DP2)));
    let z = turn_r(z1 - turn_r(y * turn_r(TURN_DP3)));
    let zz = turn_r(z * z);
    let s0 = turn_r(turn_r(turn_r(TURN_S0) * zz) + turn_r(TURN_S1));
    let s1 = turn_r(turn_r(s0 * zz) + turn_r(TURN_S2));
    let s = turn_r(turn_r(turn_r(s1 * zz) * z) + z);
    let c0 = turn_r(turn_r(turn_r(TURN_C0) * zz) + turn_r(TURN_C1));
    let c1 = turn_r(turn_r(c0 * zz) + turn_r(TURN_C2));
    let c2 = turn_r(turn_r(turn_r(c1 * zz) * zz) - turn_r(turn_r(0.5) * zz));
    let c = turn_r(c2 + turn_r(1.0));
    switch j & 7u {
        case 0u: {
            return vec2<f32>(s, c);
        }
        case 2u: {
            return vec2<f32>(c, -s);
        }
        case 4u: {
            return vec2<f32>(-s, -c);
        }
        default: {
            return vec2<f32>(-c, s);
        }
    }
}

// The rotation by `angle` about the unit `axis` (`axis_angle`; glam's from_axis_angle).
fn turn_axis_angle(axis: vec3<f32>, angle: f32) -> vec4<f32> {
    let sc = turn_sin_cos(angle * 0.5);
    return vec4<f32>(axis * sc.x, sc.y);
}

// a x b with each component's products rounded before they are subtracted (`cross`).
fn turn_cross(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        turn_r(turn_r(a.y * b.z) - turn_r(a.z * b.y)),
        turn_r(turn_r(a.z * b.x) - turn_r(a.x * b.z)),
        turn_r(turn_r(a.x * b.y) - turn_r(a.y * b.x)),
    );
}

// v rotated by the unit quaternion q (`rotate`; quat_rotate's formula).
fn turn_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * turn_cross(q.xyz, v);
    let c = turn_cross(q.xyz, t);
    var r: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        r[k] = turn_r(turn_r(v[k] + turn_r(q.w * t[k])) + c[k]);
    }
    return r;
}

// The rotation and the translation `centre - q centre` after turning by `angle` about `axis`
// through `centre` (`turn_pose`).
fn turn_pose(axis: vec3<f32>, centre: vec3<f32>, angle: f32) -> MeshPose {
    let q = turn_axis_angle(axis, angle);
    let r = turn_rotate(q, centre);
    return MeshPose(q, vec3<f32>(turn_r(centre.x - r.x), turn_r(centre.y - r.y), turn_r(centre.z - r.z)));
}
