// The mesh-boundary hooks of integrate.wgsl for scenes without `[[boundary]]` meshes: no
// contacts, no motion. Scenes with meshes compile mesh.wgsl instead, so the others keep
// the integrate kernel they had (no private arrays for mesh contacts).

struct MeshSum {
    f: vec3<f32>,
    t: vec3<f32>,
    touched: u32,
    ok: bool,
}

fn mesh_contacts(i: u32) -> MeshSum {
    return MeshSum(vec3<f32>(0.0), vec3<f32>(0.0), 0u, true);
}

fn mesh_clear(i: u32) {
}

fn mesh_moved() -> f32 {
    return 0.0;
}
