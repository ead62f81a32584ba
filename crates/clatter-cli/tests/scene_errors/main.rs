//! `clatter run BAD.toml --out DIR` on invalid scene files: the command fails without a panic,
//! the error names the file, the line and the field, and nothing is written to DIR.
//!
//! The cases are split by topic: scene fields and values (`fields.rs`), shapes from mesh
//! files and composite shapes (`shapes.rs`); `harness.rs` runs them.

mod fields;
mod harness;
mod shapes;
