//! File formats, kept apart from the engine: what clatter reads ([`scene`] files, triangle
//! [`mesh`] files cleaned by [`mesh_repair`]) and what it writes ([`vtk`] frames for
//! ParaView, [`checkpoint`]s that resume a run bitwise). Each module is also re-exported at
//! the crate root (`clatter::scene`, `clatter::checkpoint`, ...).

pub mod checkpoint;
pub mod mesh;
pub mod mesh_repair;
pub mod scene;
pub mod vtk;
