//! clatter: Discrete Element Method simulation of rigid convex polyhedra and spheres.
//!
//! The step is a fixed pipeline of stages named the same on every backend:
//! **bin**, **sort**, **pairs** ([`broad`]), **narrow** ([`clatter_geom::narrow`]),
//! **forces** ([`forces`]) and **integrate** ([`world::World::step`]).

pub mod broad;
pub mod checkpoint;
pub mod forces;
pub mod health;
pub mod material;
pub mod pile;
pub mod scene;
pub mod shape_spec;
pub mod world;

pub use checkpoint::{Checkpoint, CheckpointError};
pub use clatter_geom as geom;
pub use health::{BlowUp, Health};
pub use material::{ContactLaw, Material, PairParams};
pub use world::{BodyInit, ContactState, SimError, StepStats, Wall, World, WorldDesc};
