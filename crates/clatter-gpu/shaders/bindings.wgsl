// Group 0: the simulation's buffers, shared by every stage (src/world.rs creates them).
// A stage file is compiled as common.wgsl + bindings.wgsl [+ narrow.wgsl] + <stage>.wgsl.

const WG: u32 = 256u;
const NONE: u32 = 0xffffffffu;

// Status words (src/layout.rs, STATUS_*).
const ST_REBUILD: u32 = 0u;      // set by integrate: rebuild the pair list next step
const ST_OVERFLOW: u32 = 1u;     // pair list overflowed: everything stops until the host grows it
const ST_BAD_BODY: u32 = 2u;     // first body with a non-finite state, NONE if none
const ST_TOUCHING: u32 = 3u;     // contacts touching in the last step
const ST_PAIRS: u32 = 4u;        // candidate pairs in the list
const ST_STEPS: u32 = 5u;        // steps taken on the GPU (low 32 bits)
const ST_REBUILDING: u32 = 6u;   // this step rebuilds
const ST_REBUILDS: u32 = 7u;     // rebuilds so far
const ST_PAIRS_NEEDED: u32 = 8u; // pairs the last rebuild found (may exceed capacity)
const ST_WORK: u32 = 9u;         // pairs contacts_sat left for contacts_full this step
const ST_BBOX: u32 = 10u;        // 6 words: min xyz, max xyz as order-preserving u32
const ST_STALL: u32 = 16u;       // a lean step found a rebuild due: stopped until the next full step

// Indirect dispatch slots (3 words each, src/layout.rs ARG_*).
const ARG_BODIES_REBUILD: u32 = 0u;
const ARG_CELLS_REBUILD: u32 = 1u;
const ARG_PAIRS_NEW: u32 = 2u;   // new pair list, during a rebuild
const ARG_PAIRS: u32 = 3u;       // current pair list, every step
const ARG_COMMIT: u32 = 4u;      // max(new pairs, n + 1), during a rebuild
const ARG_WORK: u32 = 5u;        // contacts_full: the pairs contacts_sat could not separate
const ARG_STEP_BODIES: u32 = 6u; // integrate, every step (zero while halted)
const ARG_SCAN0: u32 = 7u;       // first scan-level slot; the host's template fills the rest

struct Params {
    gravity: vec4<f32>,
    n: u32,
    num_walls: u32,
    num_materials: u32,
    pair_capacity: u32,
    dt: f32,
    skin: f32,
    half_skin2: f32,
    min_cell: f32,
    max_cells: u32,
    num_args: u32,
    // 1 when every body is a sphere: the CPU then takes its sphere fast path, whose
    // effective radius is the bounding radius (else the volume-equivalent radius).
    spheres_only: u32,
    // Always 1.0, unknown to the compiler: see `integrate.wgsl`.
    one: f32,
}

struct BodyStatic {
    inv_inertia: vec4<f32>, // xyz: 1 / principal moments; w: 1 / mass
    mass: f32,
    radius: f32,            // bounding radius
    equivalent_radius: f32, // volume-equivalent sphere radius (Hertz)
    _pad: f32,
    shape: u32,
    material: u32,
    is_sphere: u32,
    isotropic: u32,
}

struct PairParams {
    hertz: u32,
    stiffness: f32,
    shear: f32,
    damping_factor: f32,
    friction: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

struct Wall {
    plane: vec4<f32>, // normal xyz, offset w
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Grid {
    min: vec4<f32>,
    cell_size: f32,
    cells: u32,
    _pad0: u32,
    _pad1: u32,
    dims: vec4<u32>,
}

// What one contact does: force on b (w: total normal force), torques on a and b.
struct ContactForce {
    force_b: vec4<f32>,
    torque_a: vec4<f32>,
    torque_b: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> bodies: array<BodyState>;
@group(0) @binding(2) var<storage, read> statics: array<BodyStatic>;
@group(0) @binding(3) var<storage, read> pair_table: array<PairParams>;
@group(0) @binding(4) var<storage, read> walls: array<Wall>;
@group(0) @binding(5) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> grid: Grid;
@group(0) @binding(7) var<storage, read_write> keys: array<u32>;
@group(0) @binding(8) var<storage, read_write> sorted: array<u32>;
@group(0) @binding(9) var<storage, read_write> cell_count: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read_write> cell_start: array<u32>;
@group(0) @binding(11) var<storage, read_write> rebuild_pos: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> new_a_start: array<u32>;
@group(0) @binding(13) var<storage, read_write> a_start: array<u32>;
@group(0) @binding(14) var<storage, read_write> new_pairs: array<vec2<u32>>;
@group(0) @binding(15) var<storage, read_write> pairs: array<vec2<u32>>;
@group(0) @binding(16) var<storage, read_write> new_hist: array<vec4<f32>>;
@group(0) @binding(17) var<storage, read_write> hist: array<vec4<f32>>; // xyz tangential spring, w twist
@group(0) @binding(18) var<storage, read_write> touching: array<u32>;
@group(0) @binding(19) var<storage, read_write> forces: array<ContactForce>;
@group(0) @binding(20) var<storage, read_write> b_count: array<atomic<u32>>;
@group(0) @binding(21) var<storage, read_write> b_start: array<u32>;
@group(0) @binding(22) var<storage, read_write> b_adj: array<u32>;
@group(0) @binding(23) var<storage, read_write> wall_hist: array<vec4<f32>>;
@group(0) @binding(24) var<storage, read_write> wall_forces: array<ContactForce>;
@group(0) @binding(25) var<storage, read_write> wall_touching: array<u32>;

// The linear index of a thread in a (possibly 2D) dispatch of WG-wide workgroups.
fn thread_index(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    return (wid.y * nwg.x + wid.x) * WG + lid;
}

// Whether the pipeline is stopped (pair overflow, a non-finite body, or a rebuild due in a
// lean step): nothing runs until the host acts, so the state stays at the start of the step
// that could not be done.
fn halted() -> bool {
    return atomicLoad(&status[ST_OVERFLOW]) != 0u || atomicLoad(&status[ST_BAD_BODY]) != NONE
        || atomicLoad(&status[ST_STALL]) != 0u;
}

var<workgroup> wg_flag: u32;
var<workgroup> wg_sum: atomic<u32>;

// `halted()` read once per workgroup (one global atomic load instead of one per thread) and
// handed to every thread as a uniform value, so a whole workgroup returns together and the
// barriers after it stay in uniform control flow. Also clears the workgroup's sum for
// `add_status_wg`. Call first thing, from every thread.
fn halted_wg(lid: u32) -> bool {
    if lid == 0u {
        wg_flag = select(0u, 1u, halted());
        atomicStore(&wg_sum, 0u);
    }
    return workgroupUniformLoad(&wg_flag) != 0u;
}

// Adds each thread's `k` to status word `word` with one global atomic per workgroup (not
// one per thread: millions of threads on one address serialise). Every thread of the
// workgroup must call it, after `halted_wg`.
fn add_status_wg(lid: u32, word: u32, k: u32) {
    if k != 0u {
        atomicAdd(&wg_sum, k);
    }
    workgroupBarrier();
    if lid == 0u {
        let total = atomicLoad(&wg_sum);
        if total != 0u {
            atomicAdd(&status[word], total);
        }
    }
}
