// The polyhedron parts of mesh.wgsl for scenes made only of spheres (compiled with
// narrow_spheres.wgsl): never called there, present so that mesh.wgsl compiles.

fn mesh_poly_tri(s: u32, x: vec3<f32>, q: vec4<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>,
                 normal: vec3<f32>) -> MeshHit {
    return mesh_no_hit();
}

fn mesh_plane_fallback(s: u32, x: vec3<f32>, q: vec4<f32>, gb: u32, pose: MeshPose, n: vec3<f32>,
                       offset: f32, size: f32) -> Manifold {
    return Manifold();
}
