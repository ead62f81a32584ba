//! clatter: Discrete Element Method simulation of rigid convex polyhedra and spheres.
//!
//! - [`World`] holds the bodies ([`bodies`]: state and constants), the materials
//!   ([`material`]), the walls, the triangle-mesh boundaries ([`mesh_boundary`]) and the
//!   contact list ([`contact_list`]).
//! - [`World::step`] runs the stages of [`step`]: **broad**, **contacts** (narrow phase and
//!   the contact [`law`]), **integrate**; the GPU backend (`clatter-gpu`) runs the same
//!   stages under the same names.
//! - [`contract`] defines the records and constants both backends share.
//! - [`sink`]: boxes that remove the bodies entering them (counted, see
//!   [`World::discharged`]).
//! - [`io`] holds the file formats, apart from the engine: [`scene`] reads scene files,
//!   [`mesh`] reads triangle meshes (cleaned by [`mesh_repair`]), [`checkpoint`] saves and
//!   restores runs, [`vtk`] writes ParaView frames. They are re-exported at the crate root.
//! - [`domain`]: a world stepped by several ranks (MPI processes), bitwise as one process
//!   steps it (docs/parallel.md).
//! - [`health`] finds runs that blow up; [`analysis`] and [`pile`] are application helpers
//!   (measurements of a run, pile builders for benchmarks).

pub mod analysis;
pub mod bodies;
pub mod contact_list;
pub mod contract;
pub mod domain;
pub mod exact_sum;
pub mod health;
pub mod io;
pub mod law;
pub mod material;
pub mod mesh_boundary;
pub mod periodic;
pub mod pile;
pub mod precise;
pub mod shape_spec;
pub mod sink;
pub mod step;
pub mod turn;
pub mod world;

pub use io::{checkpoint, mesh, mesh_repair, scene, vtk};
pub use step::broad;

pub use checkpoint::{Checkpoint, CheckpointError};
pub use clatter_geom as geom;
pub use contact_list::{ContactSprings, ContactState, Contacts, Partner};
pub use contract::{BodyConsts, BodyState, ContactForce, PairParams};
pub use health::{BlowUp, Health};
pub use material::{Cohesion, ContactLaw, Material, Materials};
pub use mesh_boundary::{Boundary, BoundaryMotion};
pub use periodic::Periodic;
pub use sink::{Discharged, Sink};
pub use world::{BodyInit, SimError, StepStats, Wall, World, WorldDesc};

/// The most worker threads a run may ask for: 16 per core this machine has (at least 64).
///
/// Results are identical for any thread count, so more threads than cores only slow a run
/// down; a typo such as `--threads 100000` would start that many OS threads (gigabytes of
/// stacks, minutes before the first step). The CLI's `--threads` and Python's `threads=`
/// refuse more than this, saying so.
pub fn thread_limit() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (16 * cores).max(64)
}
