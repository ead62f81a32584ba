// Stage **integrate** (src/stages/integrate.rs), twin of crates/clatter/src/step/integrate.rs:
// each body gathers its contact forces in the CPU's fixed order (pairs as body a, as body b,
// then walls, then the mesh contacts' sum in slot order; no float atomics), then
// semi-implicit Euler and the compensated quaternion update. Wall contacts (contacts.wgsl
// `wall_contact`) and mesh contacts (mesh.wgsl `mesh_contacts`) are computed here, where
// they are summed, saving a second read of every body. Flags a rebuild once a body has moved half the
// skin; a non-finite state stops the pipeline. Then the sink test (crates/clatter/src/sink.rs):
// a body whose centre is inside a sink's closed box is removed (`position.w` = 1) and asks
// for a rebuild, which drops its pairs; removed bodies are skipped.

@compute @workgroup_size(256)
fn integrate(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
             @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let i = dealt_item(wid, nwg, lid, params.n);
    var touched = 0u;
    if i < params.n {
        touched = integrate_body(i);
    }
    add_status_wg(lid, ST_TOUCHING, touched);
}

// Whether `x` is inside a sink's closed box (the sinks' corners follow the walls).
fn in_sink(x: vec3<f32>) -> bool {
    for (var k = 0u; k < params.num_sinks; k++) {
        let lo = walls[params.num_walls + 2u * k].plane.xyz;
        let hi = walls[params.num_walls + 2u * k + 1u].plane.xyz;
        if all(x >= lo) && all(x <= hi) {
            return true;
        }
    }
    return false;
}

// Bit k set for wall w0 + k (of the next 32) when body i may touch it or touched it last
// step: a wall left out has the body's bounding sphere on its outer side, where
// `collide_plane` (narrow.wgsl) finds no contact by the same comparison, and a released
// slot, so its `wall_contact` would change nothing.
fn walls_in_reach(i: u32, w0: u32) -> u32 {
    let radius = shape_radius(statics[i].shape);
    var bits = 0u;
    for (var k = 0u; k < min(params.num_walls - w0, 32u); k++) {
        let w = w0 + k;
        let wall = walls[w];
        let centre_height = -plane_offset_from(i, wall.plane.xyz, wall.plane.w).x;
        if !(centre_height >= radius) || wall_touched(wall_slot(i, w, 0u)) {
            bits |= 1u << k;
        }
    }
    return bits;
}

// Body i: wall contacts, gather, update. Returns the number of walls it touches.
fn integrate_body(i: u32) -> u32 {
    if bodies[i].position.w != 0.0 {
        // Removed by a sink: no mesh contacts (the CPU's next rebuild clears its slots).
        if params.num_boundaries > 0u {
            mesh_clear(i);
        }
        return 0u;
    }
    var touched = 0u;
    var f = vec3<f32>(0.0);
    var t = vec3<f32>(0.0);
    // Contacts that do not touch carry a zero force: only touching ones are read (1 in
    // `touching`; other values are separating-axis hints, see contacts.wgsl).
    for (var c = a_start[i]; c < a_start[i + 1u]; c++) {
        if touching[c] == 1u {
            f -= forces[c].force_b;
            t += forces[c].torque_a;
        }
    }
    for (var k = b_start[i]; k < b_start[i + 1u]; k++) {
        let c = b_adj[k];
        if touching[c] == 1u {
            f += forces[c].force_b;
            t += forces[c].torque_b;
        }
    }
    // Walls in the CPU's order: by wall, then piece (COMPOSITES: see pieces.wgsl).
    let st = statics[i];
    if !COMPOSITES {
        // Only the walls the body may reach or touched last step (its slot to release), in
        // the same order, 32 at a time. A loop, not a branch around each wall: lavapipe
        // runs a subgroup's lanes in lockstep and a branch's body for every lane, so a
        // wall's whole contact would cost every body; a loop ends when no lane has a wall
        // left.
        for (var w0 = 0u; w0 < params.num_walls; w0 += 32u) {
            var left = walls_in_reach(i, w0);
            while left != 0u {
                let w = w0 + firstTrailingBit(left);
                left &= left - 1u;
                let r = wall_contact(i, w, 0u);
                if r.touching {
                    f += r.force.force_b;
                    t += r.force.torque_b;
                    touched += 1u;
                }
            }
        }
    } else {
        let np = piece_count(st.shape);
        for (var w = 0u; w < params.num_walls; w++) {
            for (var k = 0u; k < np; k++) {
                let r = wall_contact(i, w, k);
                if r.touching {
                    f += r.force.force_b;
                    t += r.force.torque_b;
                    touched += 1u;
                }
            }
        }
    }
    if params.num_boundaries > 0u {
        let ms = mesh_contacts(i);
        if !ms.ok {
            atomicMax(&status[ST_MESH_FULL], i + 1u);
        }
        f += ms.f;
        t += ms.t;
        touched += ms.touched;
    }
    var b = bodies[i];
    let dt = params.dt;
    let v = b.velocity.xyz + (f * st.inv_inertia.w + params.gravity.xyz) * dt;
    // The displacement rounded once to f32, added to the double-single position (the CPU
    // adds it in f64): kept at any coordinate.
    let x = ds3_add(Ds3(b.position.xyz, b.position_lo.xyz), Ds3(v * dt, vec3<f32>(0.0)));
    let l = b.angular_momentum.xyz + t * dt;
    let q = b.orientation;
    var w: vec3<f32>;
    if st.isotropic != 0u {
        w = l * st.inv_inertia.x;
    } else {
        w = quat_rotate(q, quat_rotate_inv(q, l) * st.inv_inertia.xyz);
    }
    let h = 0.5 * dt;
    let dq = quat_mul(vec4<f32>(w * h, 0.0), q);
    // Compensated (Kahan) sum: what rounding loses of dq is carried in `residual`.
    // `params.one` is 1.0, but only at run time: without it the compiler may simplify
    // `((q + y) - q) - y` to zero (reassociation is allowed in shaders) and the
    // compensation is lost; then increments below half an ulp of q never turn the body.
    let y = dq - b.residual;
    let q2 = (q + y) * params.one;
    let residual = (q2 - q) - y;
    let n2 = dot(q2, q2);
    var qn = q2;
    if abs(n2 - 1.0) > 4.0 * 1.1920929e-7 {
        qn = q2 * (1.5 - 0.5 * n2);
    }
    let xs = ds_snap(periodic_wrap_ds(x));
    let xw = xs.hi;
    let removed = in_sink(xw);
    b.position = vec4<f32>(xw, select(0.0, 1.0, removed));
    b.position_lo = vec4<f32>(xs.lo, 0.0);
    b.velocity = vec4<f32>(v, 0.0);
    b.angular_momentum = vec4<f32>(l, 0.0);
    b.omega = vec4<f32>(w, 0.0);
    b.orientation = qn;
    b.residual = residual;
    bodies[i] = b;
    if params.spheres_only == 0u {
        // How far any point of the body can have moved in this step, which contacts_split.wgsl
        // `pair_quick` takes off pairs' gaps (the CPU's `BodyBound::moved`): the centre by
        // |v| dt, a point at the bounding radius r turned by at most |w| dt (the chord is
        // below the arc); a relative margin for the norms' rounding, and 4e-6 r for the
        // quaternion update's (at most 6 ulps of a turn, see the CPU's `axis_motion_bound`)
        // and the position's snap. A NaN or infinity spends every gap. Kept in the rebuild
        // position's spare w (src/buffers.rs `RebuildPos`).
        rebuild_pos[i].w = (length(v) + length(w) * st.radius) * dt * 1.00001 + 4e-6 * st.radius;
    }
    // The rebuild positions keep the high part only (the broad phase bins and pairs at it).
    let d = periodic_nearest((xw - rebuild_pos[i].xyz) + xs.lo);
    var d2 = dot(d, d);
    if COMPOSITES {
        // A rotation moves the pieces too: |dx| + 2 reach |q - q0| (the CPU's
        // `composite_moved`, with the closer of q0 and -q0).
        let reach = shape_reach(st.shape);
        if reach > 0.0 {
            let q0 = rebuild_pos[params.n + i];
            let dq = min(length(qn - q0), length(qn + q0));
            let dc = sqrt(d2) + 2.0 * reach * dq;
            d2 = max(d2, dc * dc);
        }
    }
    // NaN or infinity anywhere in the state shows up in d2 or in the quaternion.
    let finite = d2 <= 3.0e38 && abs(qn.w) <= 3.0e38 && all(abs(v) <= vec3<f32>(3.0e38));
    if !finite {
        atomicMin(&status[ST_BAD_BODY], i);
    } else if d2 > params.half_skin2 || removed
        || (params.num_boundaries > 0u && sqrt(d2) + mesh_moved() > 0.5 * params.skin) {
        // Bodies and meshes together may have closed half the skin (the CPU's check).
        atomicStore(&status[ST_REBUILD], 1u);
    }
    return touched;
}
