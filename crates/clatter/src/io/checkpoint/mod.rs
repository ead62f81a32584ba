//! Checkpoints: the complete state of a run in a versioned binary file, so that a run of
//! `2N` steps and a run of `N` steps, a restart from the checkpoint and `N` more steps end in
//! bitwise identical states.
//!
//! # Format (version 3)
//!
//! All integers and floats little-endian; floats are stored as their bit patterns.
//!
//! ```text
//! magic        8 bytes   "CLATCKPT"
//! version      u32       3
//! length       u64       the whole file, checksum included
//! sections     u32       number of sections
//! section*     tag [u8; 4], payload length u64, payload
//! checksum     u32       CRC-32 (IEEE) of every byte before it
//! ```
//!
//! Sections (unknown tags are skipped, so later versions can add optional ones):
//! - `SCEN`: the producer (`clatter 0.1.0`), the scene's name and its full TOML text: the
//!   static data (shapes, materials, walls, masses) is rebuilt from it on restore.
//! - `META`: body and wall counts, `dt`, `time`, `step_count`, broad-phase rebuilds, skin,
//!   gravity, the pending-rebuild flag, and a fingerprint of the bodies' mass properties (a
//!   scene that builds different bodies than when the checkpoint was written is refused).
//! - `BODY`: per body position (3 f64), velocity, orientation, the rounding residual of the
//!   compensated orientation update, angular momentum, angular velocity.
//! - `SINK` (optional; none = no body removed): the bodies removed by sinks, as a count and
//!   their indices in increasing order (u32).
//! - `RBLD`: the positions the Verlet list was built at (3 f64 each; empty before the first
//!   step).
//! - `CONT`: the contact list: body pairs, body-wall pairs, tangential and twisting springs,
//!   last forces, touching flags, separating-axis hints and separation budgets (a remembered
//!   contact written as none: see `restored_contact`). The derived gather ranges are rebuilt by
//!   running the broad phase at the `RBLD` positions, and the pairs it finds must equal the
//!   stored ones.
//! - `MESH` (only when the scene has `[[boundary]]` meshes): the time the mesh candidates
//!   were found at, then per body its `MESH_SLOTS` mesh contact slots (boundary, piece, touching,
//!   normal, tangential spring, twist, last force). The candidates are found again by the
//!   broad phase at the `RBLD` positions and that time.
//! - `MSHF` (with `MESH`; optional, absent in older files): a CRC-32 of the boundary meshes
//!   as built (vertices, triangles). The mesh files are read again on restore: one that
//!   changed since is refused (`checkpoint does not match its scene`).
//! - `PIEC` (worlds with composite bodies; optional): the orientations the Verlet list was
//!   built at (piece pairs are found at them) and one piece code per contact
//!   (`contacts::piece_code`). Restore rebuilds at the `RBLD` positions and these
//!   orientations and checks that the same piece pairs come out.
//! - `APP `: opaque bytes of the program that wrote the file (the CLI stores its run options).
//!
//! Files are written under `NAME.tmp`, synced and renamed ([`write_atomic`]), so a file with
//! its final name is always complete; a truncated or altered file fails the length or
//! checksum test with a clear [`CheckpointError`] and nothing is restored from it.
//!
//! Whoever adds per-pair or per-body *state* to [`World`] (not derived data) must add it here,
//! or restarts stop being bitwise exact (`tests/checkpoint.rs` checks that they are).

use std::path::Path;

use glam::{Quat, Vec3};
use thiserror::Error;

use crate::bodies::BodyStates;
use crate::contact_list::ContactSprings;
use crate::law::ContactForce;
use crate::mesh_boundary::{MESH_SLOTS, MeshSlot};
use crate::scene::{Scene, SceneError};
use crate::world::World;
use clatter_geom::narrow::{NO_HINT, SatHint, is_contact_hint};

mod bytes;
mod read;

use bytes::{Reader, Writer, need, tag_name, tag_str};
pub use bytes::{crc32, sync_dir, write_atomic};
use read::*;

/// The first eight bytes of every checkpoint.
pub const MAGIC: [u8; 8] = *b"CLATCKPT";
/// The format version this build writes.
/// Version 4: positions (`BODY`, `RBLD`) in f64.
/// Version 5: the same layout; a remembered face contact's stored margin (the `separation`
/// of its separating-axis hint) is twice its room beyond the reference face's separation,
/// which the remembered path takes anew at each pose (`clatter_geom`'s `contact_margin`).
/// A version-4 margin read as a version-5 one is still safe (the new check implies the old),
/// so this build reads both; a build that reads only version 4 refuses version 5 files, as it
/// must: it would take the larger stored word for its own margin.
/// Version 6: the same layout; a remembered edge contact's stored margin is twice its room
/// (`clatter_geom`'s `remembered_edge`: the edge serves while half the word plus the best
/// edge axis's separation is positive; before, while the word plus it was). A version-4 or
/// 5 word read as a version-6 one is still safe: a positive word's half is below it, so the
/// new check implies the old; this build reads versions 4 to 6.
pub const FORMAT_VERSION: u32 = 6;
/// The oldest format version this build reads (see [`FORMAT_VERSION`]).
pub const OLDEST_READ_VERSION: u32 = 4;
const HEADER_LEN: usize = 8 + 4 + 8 + 4;
const TRAILER_LEN: usize = 4;
/// Bodies further than this from the origin are refused (the broad phase needs finite extents).
const MAX_COORDINATE: f64 = 1e30;

/// Why a checkpoint could not be read or restored.
#[derive(Debug, Error)]
pub enum CheckpointError {
    /// The file could not be read.
    // The cause is in the message and not also the error's `source`: a chain printer
    // (anyhow's `{:#}`) would print it twice.
    #[error("cannot read {path}: {error}")]
    Io { path: String, error: std::io::Error },
    /// The magic bytes are missing.
    #[error("not a clatter checkpoint (the file does not start with the bytes `CLATCKPT`)")]
    NotACheckpoint,
    /// Written by a version of clatter with another format.
    #[error(
        "checkpoint format version {found} is not supported (this build reads versions {oldest} to {supported})"
    )]
    UnsupportedVersion {
        /// The version in the file.
        found: u32,
        /// The oldest version this build reads.
        oldest: u32,
        /// The version this build writes (the newest it reads).
        supported: u32,
    },
    /// Shorter than its header says: an interrupted write or a cut file.
    #[error("truncated checkpoint: {actual} bytes, {}", match .expected { Some(e) => format!("the header says {e}"), None => "too short for the header".to_string() })]
    Truncated { actual: u64, expected: Option<u64> },
    /// The bytes were altered.
    #[error("corrupt checkpoint: checksum mismatch (stored {stored:08x}, computed {computed:08x})")]
    Checksum { stored: u32, computed: u32 },
    /// Structurally invalid although the checksum matched (a bug, or a hand-made file).
    #[error("malformed checkpoint: {0}")]
    Malformed(String),
    /// The stored scene builds a world that does not fit the stored state.
    #[error("checkpoint does not match its scene: {0}")]
    Mismatch(String),
    /// The stored scene text no longer parses (its message in this one, not also a
    /// `source`: see `Io`).
    #[error("the checkpoint's scene is invalid: {0}")]
    Scene(SceneError),
}

impl From<SceneError> for CheckpointError {
    fn from(e: SceneError) -> Self {
        CheckpointError::Scene(e)
    }
}

/// A parsed checkpoint: the scene it came from, the dynamic state, and the writer's app data.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    /// What wrote it, e.g. `clatter 0.1.0`.
    pub producer: String,
    /// The scene's name (file name as given, or `<default scene>`).
    pub scene_source: String,
    /// The full scene text.
    pub scene_text: String,
    /// Opaque bytes of the program that wrote the checkpoint.
    pub app: Vec<u8>,
    state: State,
}

#[derive(Debug, Clone, Default)]
struct State {
    bodies: u64,
    walls: u64,
    fingerprint: u32,
    dt: f32,
    time: f64,
    step_count: u64,
    rebuilds: u64,
    skin: f32,
    gravity: Vec3,
    needs_rebuild: bool,
    body: BodyStates,
    rebuild_position: Vec<glam::DVec3>,
    pairs: Vec<[u32; 2]>,
    wall_pairs: Vec<[u32; 2]>,
    springs: ContactSprings,
    mesh_rebuild_time: f64,
    mesh_slots: Vec<MeshSlot>,
    rebuild_orientation: Vec<Quat>,
    pieces: Vec<u32>,
    /// The boundary meshes' fingerprint (section `MSHF`; `None` in files written before it).
    mesh_fingerprint: Option<u32>,
}

impl Checkpoint {
    /// Parses and checks a checkpoint (magic, version, length, checksum, sections).
    pub fn from_bytes(bytes: &[u8]) -> Result<Checkpoint, CheckpointError> {
        let body_end = check_header(bytes)?;
        let sections = u32::from_le_bytes(bytes[20..24].try_into().expect("4 bytes"));
        let mut r = Reader {
            buf: &bytes[HEADER_LEN..body_end],
            pos: 0,
            what: "section table",
        };
        let mut found: Vec<[u8; 4]> = Vec::new();
        let mut piec = None;
        let mut mshf = None;
        let (mut scene, mut meta, mut body, mut rbld, mut cont, mut app) =
            (None, None, None, None, None, None);
        let mut sink = None;
        let mut mesh = None;
        for _ in 0..sections {
            let tag: [u8; 4] = r.bytes(4)?.try_into().expect("4 bytes");
            let n = r.len_u64()?;
            let payload = r.bytes(n)?;
            if found.contains(&tag) {
                return Err(CheckpointError::Malformed(format!(
                    "section `{}` appears twice",
                    tag_name(&tag)
                )));
            }
            found.push(tag);
            let reader = Reader {
                buf: payload,
                pos: 0,
                what: tag_str(&tag),
            };
            match &tag {
                b"SCEN" => scene = Some(reader),
                b"META" => meta = Some(reader),
                b"BODY" => body = Some(reader),
                b"RBLD" => rbld = Some(reader),
                b"SINK" => sink = Some(reader),
                b"CONT" => cont = Some(reader),
                b"APP " => app = Some(payload.to_vec()),
                b"MESH" => mesh = Some(reader),
                b"PIEC" => piec = Some(reader),
                b"MSHF" => mshf = Some(reader),
                _ => {} // optional section of a later version
            }
        }
        if r.pos != r.buf.len() {
            return Err(CheckpointError::Malformed(format!(
                "{} bytes after the last section",
                r.buf.len() - r.pos
            )));
        }
        let mut s = need(scene, "SCEN")?;
        let producer = s.string()?;
        let scene_source = s.string()?;
        let scene_text = s.string()?;
        s.finish()?;
        let mut st = State::default();
        read_meta(&mut need(meta, "META")?, &mut st)?;
        read_bodies(&mut need(body, "BODY")?, &mut st)?;
        st.body.removed = vec![false; st.bodies as usize];
        if let Some(mut r) = sink {
            read_removed(&mut r, &mut st)?;
        }
        let mut rb = need(rbld, "RBLD")?;
        let nr = rb.count(24)?;
        if nr != 0 && nr != st.bodies as usize {
            return Err(CheckpointError::Malformed(format!(
                "{nr} rebuild positions for {} bodies",
                st.bodies
            )));
        }
        st.rebuild_position = rb.dvec3s(nr)?;
        rb.finish()?;
        read_contacts(&mut need(cont, "CONT")?, &mut st)?;
        if let Some(mut m) = mesh {
            read_mesh_slots(&mut m, &mut st)?;
        }
        if let Some(mut r) = piec {
            read_pieces(&mut r, &mut st)?;
        }
        if let Some(mut r) = mshf {
            st.mesh_fingerprint = Some(r.u32()?);
            r.finish()?;
        }
        Ok(Checkpoint {
            producer,
            scene_source,
            scene_text,
            app: app.unwrap_or_default(),
            state: st,
        })
    }

    /// Reads and checks a checkpoint file.
    pub fn load(path: &Path) -> Result<Checkpoint, CheckpointError> {
        let bytes = std::fs::read(path).map_err(|error| CheckpointError::Io {
            path: path.display().to_string(),
            error,
        })?;
        Checkpoint::from_bytes(&bytes)
    }

    /// Steps taken when the checkpoint was written.
    pub fn step_count(&self) -> u64 {
        self.state.step_count
    }

    /// Simulated time when the checkpoint was written, s.
    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// Number of bodies.
    pub fn bodies(&self) -> u64 {
        self.state.bodies
    }

    /// Parses the stored scene.
    pub fn scene(&self) -> Result<Scene, CheckpointError> {
        Ok(Scene::parse(&self.scene_text, &self.scene_source)?)
    }

    /// The world exactly as it was when the checkpoint was written, built on `scene` (which
    /// must be [`Checkpoint::scene`]).
    pub fn restore(&self, scene: &Scene) -> Result<World, CheckpointError> {
        self.restore_onto(scene.world())
    }

    /// The state restored onto `world`, built the way the checkpointed world was (for worlds
    /// that come from no scene file, such as `clatter bench`'s piles: the static data is the
    /// caller's, the checks on body and wall counts and mass properties still apply).
    pub fn restore_onto(&self, world: World) -> Result<World, CheckpointError> {
        let st = &self.state;
        let mut w = world;
        if w.len() as u64 != st.bodies || w.walls.len() as u64 != st.walls {
            return Err(CheckpointError::Mismatch(format!(
                "the scene has {} bodies and {} walls, the checkpoint {} and {}",
                w.len(),
                w.walls.len(),
                st.bodies,
                st.walls
            )));
        }
        if st
            .mesh_fingerprint
            .is_some_and(|f| f != mesh_fingerprint(&w.boundaries))
        {
            return Err(CheckpointError::Mismatch(
                "the scene's boundary meshes are not the ones the checkpoint was written with (a mesh file changed since?): the run would not go on as it was"
                    .to_string(),
            ));
        }
        if fingerprint(&w) != st.fingerprint {
            return Err(CheckpointError::Mismatch(
                "the scene builds bodies with other masses or sizes than when the checkpoint was written (written by another version of clatter?)"
                    .to_string(),
            ));
        }
        w.dt = st.dt;
        w.skin = st.skin;
        w.gravity = st.gravity;
        if st.rebuild_position.is_empty() {
            if !(st.pairs.is_empty() && st.wall_pairs.is_empty() && st.needs_rebuild) {
                return Err(CheckpointError::Malformed(
                    "a contact list without the positions it was built at".into(),
                ));
            }
        } else {
            // Rebuild the derived gather ranges exactly as the run did, from the same positions
            // (and the meshes where they were then; for composites, the orientations).
            // A body removed by a sink after the list was built is still in the stored
            // list (the next step rebuilds without it): its contacts are dropped first,
            // which changes nothing the next rebuild carries over.
            w.state.removed.clone_from(&st.body.removed);
            w.state.position.clone_from(&st.rebuild_position);
            w.time = st.mesh_rebuild_time;
            if w.has_composites() {
                if st.rebuild_orientation.len() != w.len() {
                    return Err(CheckpointError::Malformed(
                        "a world with composite bodies needs the orientations its contact list was built at (section PIEC)".into(),
                    ));
                }
                w.state.orientation.clone_from(&st.rebuild_orientation);
            }
            w.rebuild_contacts();
            let (pairs, wall_pairs, springs, pieces) = without_removed(st, &st.body.removed);
            let c = &w.contacts;
            if c.pairs() != pairs.as_slice()
                || c.wall_pairs() != wall_pairs.as_slice()
                || c.pieces() != pieces.as_slice()
            {
                return Err(CheckpointError::Mismatch(format!(
                    "the broad phase finds {} body pairs and {} wall pairs at the stored positions, the checkpoint lists {} and {}",
                    c.pairs().len(),
                    c.wall_pairs().len(),
                    pairs.len(),
                    wall_pairs.len()
                )));
            }
            w.contacts
                .set_springs(springs)
                .map_err(CheckpointError::Malformed)?;
        }
        if !w.boundaries.is_empty() || !st.mesh_slots.is_empty() {
            w.set_mesh_slots(st.mesh_slots.clone())
                .map_err(|e| CheckpointError::Mismatch(format!("the scene's boundaries: {e}")))?;
        }
        w.state.clone_from(&st.body);
        w.rebuilds = st.rebuilds;
        w.set_needs_rebuild(st.needs_rebuild);
        w.time = st.time;
        w.step_count = st.step_count;
        Ok(w)
    }

    /// [`Checkpoint::scene`] and [`Checkpoint::restore`] in one.
    pub fn world(&self) -> Result<(Scene, World), CheckpointError> {
        let scene = self.scene()?;
        let world = self.restore(&scene)?;
        Ok((scene, world))
    }
}

impl World {
    /// The complete state as checkpoint bytes. `scene_text` must be the text the world was
    /// built from (named `scene_source`); `app` is stored as is and returned by
    /// [`Checkpoint::app`](Checkpoint#structfield.app).
    pub fn checkpoint_bytes(&self, scene_source: &str, scene_text: &str, app: &[u8]) -> Vec<u8> {
        let n = self.len();
        let c = &self.contacts;
        let sp = c.springs();
        let nc = sp.history.len();
        let st = &self.state;
        let mut w = Writer::with_capacity(
            HEADER_LEN + 80 * n + 84 * nc + scene_text.len() + app.len() + 256,
        );
        w.buf.extend_from_slice(&MAGIC);
        w.u32(FORMAT_VERSION);
        w.u64(0); // length, patched below
        let mesh = !self.boundaries.is_empty();
        w.u32(7 + 2 * mesh as u32 + self.has_composites() as u32);
        w.section(b"SCEN", |w| {
            w.string(concat!("clatter ", env!("CARGO_PKG_VERSION")));
            w.string(scene_source);
            w.string(scene_text);
        });
        w.section(b"META", |w| {
            w.u64(n as u64);
            w.u64(self.walls.len() as u64);
            w.u32(fingerprint(self));
            w.f32(self.dt);
            w.f64(self.time);
            w.u64(self.step_count);
            w.u64(self.rebuilds);
            w.f32(self.skin);
            w.vec3(self.gravity);
            w.buf.push(self.needs_rebuild() as u8);
        });
        w.section(b"BODY", |w| {
            w.u64(n as u64);
            for i in 0..n {
                w.dvec3(st.position[i]);
                w.vec3(st.velocity[i]);
                for q in [st.orientation[i], st.orientation_residual[i]] {
                    for v in [q.x, q.y, q.z, q.w] {
                        w.f32(v);
                    }
                }
                w.vec3(st.angular_momentum[i]);
                w.vec3(st.omega[i]);
            }
        });
        w.section(b"SINK", |w| {
            let removed: Vec<u32> = (0..n as u32).filter(|&i| st.removed[i as usize]).collect();
            w.u64(removed.len() as u64);
            for i in removed {
                w.u32(i);
            }
        });
        w.section(b"RBLD", |w| {
            w.u64(self.rebuild_position().len() as u64);
            for &p in self.rebuild_position() {
                w.dvec3(p);
            }
        });
        w.section(b"CONT", |w| {
            w.u64(c.pairs().len() as u64);
            for p in c.pairs() {
                w.u32(p[0]);
                w.u32(p[1]);
            }
            w.u64(c.wall_pairs().len() as u64);
            for p in c.wall_pairs() {
                w.u32(p[0]);
                w.u32(p[1]);
            }
            for k in 0..nc {
                w.vec3(sp.history[k]);
                w.f32(sp.twist[k]);
                let f = &sp.forces[k];
                w.vec3(f.force_b);
                w.vec3(f.torque_a);
                w.vec3(f.torque_b);
                w.f32(f.normal_force);
                w.buf.push(sp.touching[k] as u8);
            }
            // A remembered contact (its hint and margin) is written as none: its margin is
            // anchored on the relative pose of the full test that stored it, which the
            // pair's edge memory keeps and a checkpoint does not, so a resumed run cannot
            // serve it and runs the full test at its first step, for the same manifold
            // (`restored_contact`). Written as it is, a resumed run's next checkpoint
            // would differ from a straight run's in these words alone.
            for (&h, &b) in sp.hints.iter().zip(&sp.separation_bound) {
                w.u32(restored_contact(h, b).0);
            }
            for (&h, &b) in sp.hints.iter().zip(&sp.separation_bound) {
                w.f32(restored_contact(h, b).1);
            }
        });
        if mesh {
            w.section(b"MESH", |w| {
                w.f64(self.mesh_rebuild_time());
                let slots = self.mesh_slots();
                w.u64(slots.len() as u64);
                for s in slots {
                    w.u32(s.boundary);
                    w.u32(s.piece);
                    w.buf.push(s.touching as u8);
                    w.vec3(s.normal);
                    w.vec3(s.history);
                    w.f32(s.twist);
                    w.vec3(s.force.force_b);
                    w.vec3(s.force.torque_a);
                    w.vec3(s.force.torque_b);
                    w.f32(s.force.normal_force);
                }
            });
        }
        if mesh {
            w.section(b"MSHF", |w| w.u32(mesh_fingerprint(&self.boundaries)));
        }
        if self.has_composites() {
            w.section(b"PIEC", |w| {
                w.u64(self.rebuild_orientation().len() as u64);
                for q in self.rebuild_orientation() {
                    for v in [q.x, q.y, q.z, q.w] {
                        w.f32(v);
                    }
                }
                w.u64(c.pieces().len() as u64);
                for &p in c.pieces() {
                    w.u32(p);
                }
            });
        }
        w.section(b"APP ", |w| w.buf.extend_from_slice(app));
        let total = (w.buf.len() + TRAILER_LEN) as u64;
        w.buf[12..20].copy_from_slice(&total.to_le_bytes());
        let crc = crc32(&w.buf);
        w.u32(crc);
        w.buf
    }
}

/// A CRC-32 of the bits of every body's mass properties and size: equal when a scene builds
/// the same bodies.
fn fingerprint(w: &World) -> u32 {
    let mut bytes = Vec::with_capacity(w.len() * 28);
    for i in 0..w.len() {
        let c = &w.consts;
        bytes.extend_from_slice(&c.shape[i].to_le_bytes());
        bytes.extend_from_slice(&c.material[i].to_le_bytes());
        bytes.extend_from_slice(&c.mass[i].to_le_bytes());
        for x in c.inertia[i].to_array() {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
        bytes.extend_from_slice(&c.radius[i].to_le_bytes());
    }
    crc32(&bytes)
}

/// A fingerprint of the boundary meshes as built (vertices and triangles, after scaling
/// and repair): a checkpoint stores the scene's text, not its mesh files, which `resume`
/// reads again; a file changed since is refused rather than run on silently.
fn mesh_fingerprint(boundaries: &[crate::Boundary]) -> u32 {
    let mut bytes = Vec::new();
    for b in boundaries {
        bytes.extend_from_slice(&(b.vertices.len() as u64).to_le_bytes());
        for v in &b.vertices {
            for x in v.to_array() {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
        bytes.extend_from_slice(&(b.triangles.len() as u64).to_le_bytes());
        for t in &b.triangles {
            for i in t {
                bytes.extend_from_slice(&i.to_le_bytes());
            }
        }
    }
    crc32(&bytes)
}

/// Checks a checkpoint's header and trailer (magic, version, declared length, checksum)
/// and returns where its body ends (the start of the trailer).
fn check_header(bytes: &[u8]) -> Result<usize, CheckpointError> {
    let len = bytes.len();
    if len < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return if len < MAGIC.len() && bytes == &MAGIC[..len] && len > 0 {
            Err(CheckpointError::Truncated {
                actual: len as u64,
                expected: None,
            })
        } else {
            Err(CheckpointError::NotACheckpoint)
        };
    }
    if len < 12 {
        return Err(CheckpointError::Truncated {
            actual: len as u64,
            expected: None,
        });
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if !(OLDEST_READ_VERSION..=FORMAT_VERSION).contains(&version) {
        return Err(CheckpointError::UnsupportedVersion {
            found: version,
            oldest: OLDEST_READ_VERSION,
            supported: FORMAT_VERSION,
        });
    }
    if len < 20 {
        return Err(CheckpointError::Truncated {
            actual: len as u64,
            expected: None,
        });
    }
    let declared = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
    if (len as u64) < declared {
        return Err(CheckpointError::Truncated {
            actual: len as u64,
            expected: Some(declared),
        });
    }
    if len < HEADER_LEN + TRAILER_LEN {
        return Err(CheckpointError::Malformed(format!(
            "the header declares {declared} bytes, less than a header"
        )));
    }
    if (len as u64) > declared {
        return Err(CheckpointError::Malformed(format!(
            "{} bytes after the end the header declares ({declared} bytes)",
            len as u64 - declared
        )));
    }
    let body_end = len - TRAILER_LEN;
    let stored = u32::from_le_bytes(bytes[body_end..].try_into().expect("4 bytes"));
    let computed = crc32(&bytes[..body_end]);
    if stored != computed {
        return Err(CheckpointError::Checksum { stored, computed });
    }
    Ok(body_end)
}

/// The `PIEC` section: the rebuild orientations and the piece codes of a composite world.
fn read_pieces(r: &mut Reader, st: &mut State) -> Result<(), CheckpointError> {
    let nq = r.count(16)?;
    if nq != 0 && nq != st.bodies as usize {
        return Err(CheckpointError::Malformed(format!(
            "{nq} rebuild orientations for {} bodies",
            st.bodies
        )));
    }
    for _ in 0..nq {
        let (x, y, z, w) = (r.f32()?, r.f32()?, r.f32()?, r.f32()?);
        st.rebuild_orientation.push(Quat::from_xyzw(x, y, z, w));
    }
    let np = r.count(4)?;
    for _ in 0..np {
        st.pieces.push(r.u32()?);
    }
    r.finish()
}

/// A pair's separating-axis hint and separation bound as a checkpoint holds them: a
/// remembered contact ([`clatter_geom::narrow::is_contact_hint`]) as no hint and a bound
/// of 0, what the full test leaves on a touching pair it does not remember. The step
/// after a restore runs the full test for such a pair (a remembered margin needs its
/// anchor, which no checkpoint holds; a composite's, which has none, would serve, for the
/// full test's manifold, bitwise): the same results as the contact kept, and a straight
/// run's checkpoint and a resumed run's are the same bytes.
fn restored_contact(hint: SatHint, bound: f32) -> (SatHint, f32) {
    if is_contact_hint(hint) {
        (NO_HINT, 0.0)
    } else {
        (hint, bound)
    }
}
