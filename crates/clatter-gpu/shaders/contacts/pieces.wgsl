// Composite bodies (clumps), the twin of crates/clatter/src/world.rs `piece_at` / `piece_law`:
// the piece records of a composite shape in shape_u / shape_f (src/shapes.rs,
// KIND_COMPOSITE), the pair-list words' piece ids, and the wall slots. Included after the
// bind group 1 declarations (narrow.wgsl, narrow_spheres.wgsl or src/pipeline.rs SHAPES_DECL).
//
// In a scene with composites (`params.composites`), each word of a pair-list entry holds a
// body index in its low PIECE_SHIFT bits and that body's piece id above them; in other scenes
// the piece ids are 0 and the words are plain body indices. Every module that includes this
// file declares `const COMPOSITES: bool` first (src/pipeline.rs `composites_const`): the
// contact kernels are compiled once with it false (scenes without composites, which then run
// exactly the code they ran before composites came to the GPU) and once with it true.

const PIECE_SHIFT: u32 = 26u;
const BODY_MASK: u32 = 0x3ffffffu;
const PC_HDR: u32 = 12u;
const KIND_COMPOSITE: u32 = 2u;

fn body_of(word: u32) -> u32 {
    return word & BODY_MASK;
}

fn piece_of(word: u32) -> u32 {
    return word >> PIECE_SHIFT;
}

// A pair-list word: body i's piece k.
fn pair_word(i: u32, k: u32) -> u32 {
    return i | (k << PIECE_SHIFT);
}

// The CPU's piece code of a pair entry (`clatter::contacts::piece_code`, 8 bits per id): its
// order after the body pair is the list's order.
fn pair_code(p: vec2<u32>) -> u32 {
    return (piece_of(p.x) << 8u) | piece_of(p.y);
}

// Number of pieces of shape s (1 unless a composite).
fn piece_count(s: u32) -> u32 {
    let h = s * PC_HDR;
    if shape_u[h] == KIND_COMPOSITE {
        return shape_u[h + 2u];
    }
    return 1u;
}

// How far a rotation can carry a piece of shape s (0 unless a composite).
fn shape_reach(s: u32) -> f32 {
    let h = s * PC_HDR;
    if shape_u[h] == KIND_COMPOSITE {
        return bitcast<f32>(shape_u[h + 5u]);
    }
    return 0.0;
}

// One piece of a body, placed: its shape, centre, orientation, bounding radius, and the law's
// radius and sphere flag for its contacts.
struct Piece {
    shape: u32,
    x: vec3<f32>,
    q: vec4<f32>,
    radius: f32,
    law_radius: f32,
    is_sphere: bool,
}

// Piece k of a body with constants `st` at (x, q): the body itself unless its shape is a
// composite (then `x + q * offset`, `q * orientation`, as the CPU's `piece_at`).
fn piece_at(st: BodyConsts, k: u32, x: vec3<f32>, q: vec4<f32>) -> Piece {
    let h = st.shape * PC_HDR;
    // The contact kernels of scenes without composites are compiled with COMPOSITES false:
    // this is then the plain body, and the composite code is compiled out.
    if !COMPOSITES || shape_u[h] != KIND_COMPOSITE {
        return Piece(st.shape, x, q, st.radius, st.equivalent_radius, st.is_sphere != 0u);
    }
    let u = shape_u[h + 3u] + 3u * k;
    let f = shape_u[h + 4u] + 2u * k;
    let off = shape_f[f];
    return Piece(shape_u[u], x + quat_rotate(q, off.xyz), quat_mul(q, shape_f[f + 1u]), off.w,
                 bitcast<f32>(shape_u[u + 1u]), shape_u[u + 2u] != 0u);
}

// The spring slot of body i's piece k against wall w (wall_hist, wall_forces,
// wall_touching): `(i * num_walls + w) * max_pieces + k`, `i * num_walls + w` without
// composites.
fn wall_slot(i: u32, w: u32, k: u32) -> u32 {
    return (i * params.num_walls + w) * params.max_pieces + k;
}
