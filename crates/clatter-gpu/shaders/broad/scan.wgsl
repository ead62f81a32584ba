// Exclusive prefix sum (reduce-then-scan, no look-back): `scan_block` scans each block of
// 256 elements in workgroup memory and writes the block's total to `sums`; the host scans
// `sums` the same way (recursively) and `scan_add` adds each block's offset back. Used for
// cell ranges, pair offsets and the b-side adjacency.

@group(2) @binding(0) var<storage, read_write> data: array<u32>;
@group(2) @binding(1) var<storage, read_write> sums: array<u32>;

var<workgroup> tile: array<u32, 256>;

@compute @workgroup_size(256)
fn scan_block(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) lid: u32) {
    let block = wid.y * nwg.x + wid.x;
    let i = block * WG + lid;
    let len = arrayLength(&data);
    let v = select(0u, data[i], i < len);
    tile[lid] = v;
    workgroupBarrier();
    // Hillis-Steele inclusive scan of the tile.
    for (var off = 1u; off < WG; off <<= 1u) {
        var add = 0u;
        if lid >= off {
            add = tile[lid - off];
        }
        workgroupBarrier();
        tile[lid] += add;
        workgroupBarrier();
    }
    if i < len {
        data[i] = tile[lid] - v;
    }
    if lid == WG - 1u && block < arrayLength(&sums) {
        sums[block] = tile[lid];
    }
}

@compute @workgroup_size(256)
fn scan_add(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
            @builtin(local_invocation_index) lid: u32) {
    let block = wid.y * nwg.x + wid.x;
    let i = block * WG + lid;
    if i < arrayLength(&data) {
        data[i] += sums[block];
    }
}
