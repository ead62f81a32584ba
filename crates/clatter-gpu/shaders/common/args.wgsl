// Group 2 of the kernels that size later dispatches (prepare, grid, pairs_total): the
// indirect dispatch arguments they write, and the host's template of rebuild-only sizes.
// Only these kernels bind `args` as storage; the others read it as indirect arguments.
@group(2) @binding(0) var<storage, read_write> args: array<u32>;
@group(2) @binding(1) var<storage, read_write> arg_template: array<u32>;

// Writes `groups` workgroups into slot `slot`, split over y beyond 65535 (see thread_index).
fn write_args(slot: u32, groups: u32) {
    let x = min(groups, 65535u);
    args[slot * 3u] = x;
    args[slot * 3u + 1u] = select(0u, (groups + 65534u) / 65535u, groups > 0u);
    args[slot * 3u + 2u] = 1u;
}
