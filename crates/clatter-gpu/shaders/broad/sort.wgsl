// Stage 2, **sort**: bodies sorted by cell key, giving each cell its range
// `sorted[cell_start[c]..cell_start[c + 1]]`. A counting sort: `bin` counted the bodies per
// cell, the scan turned the counts into starts, `scatter` drops each body into its cell
// (counting the cell back down to zero for the next rebuild), and `sort_cells` orders each
// cell by body index, so the result is the CPU's stable counting sort exactly, whatever order
// the atomics ran in.

@compute @workgroup_size(256)
fn scatter(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
           @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, nwg, lid);
    if i >= params.n || halted() {
        return;
    }
    let k = keys[i];
    let slot = cell_start[k] + atomicSub(&cell_count[k], 1u) - 1u;
    sorted[slot] = i;
}

@compute @workgroup_size(256)
fn sort_cells(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) lid: u32) {
    let c = thread_index(wid, nwg, lid);
    if c >= grid.cells || halted() {
        return;
    }
    let s = cell_start[c];
    let e = cell_start[c + 1u];
    // Insertion sort: cells hold a handful of bodies.
    for (var a = s + 1u; a < e; a++) {
        let v = sorted[a];
        var b = a;
        while b > s && sorted[b - 1u] > v {
            sorted[b] = sorted[b - 1u];
            b--;
        }
        sorted[b] = v;
    }
}
