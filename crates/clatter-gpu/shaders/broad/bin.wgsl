// Stage 1, **bin**, and the step's bookkeeping: `prepare` decides whether this step
// rebuilds the pair list (a body moved more than half the skin, flagged by the last
// integrate) and sizes the rebuild's dispatches; `bbox` and `grid` size the uniform grid
// exactly as the CPU's `Grid::around`; `bin` gives each body its cell key and counts bodies
// per cell; `copy_cells` hands the counts to the scan that turns them into cell ranges.

// Order-preserving map of f32 to u32 (so atomicMin/atomicMax order floats).
fn ordered(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn unordered(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

// The sizes of the dispatches every step makes: the current pair list and the bodies; zero
// while the pipeline is stopped, so that batches recorded behind a
// stopped step launch nothing (a 4-million-body step launches some 150,000 workgroups, which
// would otherwise each start only to find the pipeline stopped). A rebuild resizes the pair
// dispatch later in its step (pairs_total).
fn write_step_args(stopped: bool) {
    let pairs = atomicLoad(&status[ST_PAIRS]);
    write_args(ARG_PAIRS, select(dealt_groups(pairs), 0u, stopped));
    write_args(ARG_STEP_BODIES, select(dealt_groups(params.n), 0u, stopped));
}

@compute @workgroup_size(1)
fn prepare() {
    // A full step runs the step a lean one stalled on (see prepare_lean).
    atomicStore(&status[ST_STALL], 0u);
    var rebuild = 0u;
    let stopped = halted();
    if !stopped {
        rebuild = atomicExchange(&status[ST_REBUILD], 0u);
        atomicStore(&status[ST_TOUCHING], 0u);
    }
    atomicStore(&status[ST_REBUILDING], rebuild);
    atomicStore(&status[ST_WORK], 0u);
    clear_classes();
    write_step_args(stopped);
    // Rebuild-only dispatches: the template's size when rebuilding, else nothing.
    for (var s = 0u; s < params.num_args; s++) {
        if s != ARG_PAIRS && s != ARG_STEP_BODIES {
            for (var k = 0u; k < 3u; k++) {
                args[s * 3u + k] = select(0u, arg_template[s * 3u + k], rebuild != 0u);
            }
        }
    }
    if rebuild != 0u {
        atomicAdd(&status[ST_REBUILDS], 1u);
        mesh_note_rebuild();
        for (var k = 0u; k < 3u; k++) {
            atomicStore(&status[ST_BBOX + k], 0xffffffffu);
            atomicStore(&status[ST_BBOX + 3u + k], 0u);
        }
    }
}

// The first kernel of a lean step (recorded without the rebuild's dispatches, see
// GpuWorld::encode_steps): if the last step flagged a rebuild, stop the pipeline (ST_STALL)
// until the next full step (the first of the next batch), which clears the stall and runs
// this step with the rebuild; otherwise what `prepare` does on a step that does not rebuild.
@compute @workgroup_size(1)
fn prepare_lean() {
    var stopped = halted();
    if !stopped && atomicLoad(&status[ST_REBUILD]) != 0u {
        atomicStore(&status[ST_STALL], 1u);
        stopped = true;
    }
    write_step_args(stopped);
    if stopped {
        return;
    }
    atomicStore(&status[ST_TOUCHING], 0u);
    atomicStore(&status[ST_REBUILDING], 0u);
    atomicStore(&status[ST_WORK], 0u);
    clear_classes();
}

// The last kernel of every step without the blow-up checks (with them, health.wgsl
// `end_step_gate`): counts it, unless the pipeline stopped during it.
@compute @workgroup_size(1)
fn end_step() {
    count_step();
}

var<workgroup> wg_box: array<atomic<u32>, 6>;

// The bounding box of the centres: reduced per workgroup in workgroup memory, then six
// global atomics per workgroup (not per body: they would all hit the same six words).
@compute @workgroup_size(256)
fn bbox(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    if lid < 3u {
        atomicStore(&wg_box[lid], 0xffffffffu);
        atomicStore(&wg_box[lid + 3u], 0u);
    }
    workgroupBarrier();
    let i = thread_index(wid, nwg, lid);
    if i < params.n {
        let p = bodies[i].position;
        for (var k = 0u; k < 3u; k++) {
            atomicMin(&wg_box[k], ordered(p[k]));
            atomicMax(&wg_box[3u + k], ordered(p[k]));
        }
    }
    workgroupBarrier();
    if lid < 3u {
        atomicMin(&status[ST_BBOX + lid], atomicLoad(&wg_box[lid]));
        atomicMax(&status[ST_BBOX + 3u + lid], atomicLoad(&wg_box[lid + 3u]));
    }
}

// One thread: the grid around the bodies with cells of at least `min_cell`, grown by 1.5x
// while it would have more than `max_cells` cells (the CPU's Grid::around, in the same f32
// arithmetic).
@compute @workgroup_size(1)
fn grid_size() {
    if halted() || atomicLoad(&status[ST_REBUILDING]) == 0u {
        return;
    }
    var lo: vec3<f32>;
    var hi: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        lo[k] = unordered(atomicLoad(&status[ST_BBOX + k]));
        hi[k] = unordered(atomicLoad(&status[ST_BBOX + 3u + k]));
    }
    let extent = max(hi - lo, vec3<f32>(0.0));
    let m = params.max_cells;
    var cell = max(params.min_cell, 1e-12);
    var dims = vec3<u32>(1u);
    loop {
        let d = floor(extent / cell) + vec3<f32>(1.0);
        if all(d <= vec3<f32>(f32(m))) {
            dims = vec3<u32>(d);
            // dims.x * dims.y * dims.z <= m, exactly, without overflow.
            if dims.x <= m / dims.y && dims.x * dims.y <= m / dims.z {
                break;
            }
        }
        cell *= 1.5;
    }
    grid.min = vec4<f32>(lo, 0.0);
    grid.cell_size = cell;
    grid.cells = dims.x * dims.y * dims.z;
    grid.dims = vec4<u32>(dims, 0u);
}

fn cell_of(p: vec3<f32>) -> vec3<u32> {
    let g = floor((p - grid.min.xyz) / grid.cell_size);
    let top = vec3<f32>(grid.dims.xyz - vec3<u32>(1u));
    return vec3<u32>(min(max(g, vec3<f32>(0.0)), top));
}

fn cell_key(c: vec3<u32>) -> u32 {
    return (c.z * grid.dims.y + c.y) * grid.dims.x + c.x;
}

@compute @workgroup_size(256)
fn bin(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
       @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, nwg, lid);
    if i >= params.n || halted() {
        return;
    }
    let k = cell_key(cell_of(bodies[i].position.xyz));
    keys[i] = k;
    atomicAdd(&cell_count[k], 1u);
}

// cell_start[c] = count of cell c (cells beyond the grid and the last entry are zero), to be
// scanned into the start of each cell's range.
@compute @workgroup_size(256)
fn copy_cells(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) lid: u32) {
    let c = thread_index(wid, nwg, lid);
    if c > params.max_cells || halted() {
        return;
    }
    cell_start[c] = atomicLoad(&cell_count[c]);
}

// Zeroes contacts_sat's per-class counts (status words ST_CLASSES..), with ST_WORK.
fn clear_classes() {
    for (var k = 0u; k < SPLIT_CLASSES; k++) {
        atomicStore(&status[ST_CLASSES + k], 0u);
    }
}
