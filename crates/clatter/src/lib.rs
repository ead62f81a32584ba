//! clatter: Discrete Element Method simulation of rigid convex polyhedra and spheres.
//!
//! - [`World`] holds the bodies ([`bodies`]: state and constants), the materials
//!   ([`material`]), the walls, the triangle-mesh boundaries ([`boundary`]) and the contact
//!   list ([`contacts`]).
//! - [`World::step`] runs the stages of [`step`]: **broad**, **contacts** (narrow phase and
//!   the contact [`law`]), **integrate**; the GPU backend (`clatter-gpu`) runs the same
//!   stages under the same names.
//! - [`contract`] defines the records and constants both backends share.
//! - [`sink`]: boxes that remove the bodies entering them (counted, see
//!   [`World::discharged`]).
//! - [`scene`] reads scene files, [`checkpoint`] saves and restores runs, [`health`] finds
//!   runs that blow up, [`vtk`] writes ParaView frames.

pub mod analysis;
pub mod bodies;
pub mod boundary;
pub mod checkpoint;
pub mod contacts;
pub mod contract;
pub mod health;
pub mod law;
pub mod material;
pub mod mesh;
pub mod mesh_repair;
pub mod periodic;
pub mod pile;
pub mod scene;
pub mod shape_spec;
pub mod sink;
pub mod step;
pub mod vtk;
pub mod world;

pub use step::broad;

pub use boundary::{Boundary, BoundaryMotion};
pub use checkpoint::{Checkpoint, CheckpointError};
pub use clatter_geom as geom;
pub use contacts::{ContactSprings, ContactState, Contacts, Partner};
pub use contract::{BodyConsts, BodyState, ContactForce, PairParams};
pub use health::{BlowUp, Health};
pub use material::{Cohesion, ContactLaw, Material, Materials};
pub use periodic::Periodic;
pub use sink::{Discharged, Sink};
pub use world::{BodyInit, SimError, StepStats, Wall, World, WorldDesc};
