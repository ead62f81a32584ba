//! `Simulation`: a world stepped on the CPU (rayon) or the GPU (wgpu), its state as numpy
//! arrays.
//!
//! Stepping goes through the backend layer every front end shares (`clatter_backend`): the
//! executor chosen as `clatter run --backend` chooses it, stepped by its `Stepper` under its
//! `Watch` (the blow-up checks of `clatter run`; on the GPU the cheap ones run on the
//! device). After GPU steps the host `World` is left behind and read back lazily, only as
//! much as a getter needs ([`Behind`]): the body state for the body arrays, the contact
//! list too for `contacts()`, `write_vtk` and `save_checkpoint`; the step count and time
//! come from the device without a read. A setter first brings the world up to date, then
//! marks the GPU copy stale; the next step uploads the world again.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use numpy::ndarray::{Array1, Array2};
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use clatter::health::touching_contacts;
use clatter::{Checkpoint, Partner, World};
use clatter_backend::{BackendChoice, CHECK_EVERY, Device, Readback, Stepper, Watch};

use crate::errors::{BackendError, blow_up_error, checkpoint_error, device_error, watch_error};
use crate::scene::ParsedScene;

/// Steps run between two checks for Ctrl-C (the GIL is released while they run).
const CHUNK: u64 = 1024;

/// Python's name for asking for the GPU, in the backend layer's messages.
const GPU_OPTION: &str = "backend=\"gpu\"";

/// What of the GPU's state the host world lacks (always `Nothing` on the CPU).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Behind {
    /// The world is current.
    Nothing,
    /// The body state is current; the contact list is not.
    Contacts,
    /// Bodies and contacts are the state of the last upload.
    All,
}

/// A running simulation of one scene.
///
/// `Simulation(scene, backend="auto", threads=None)`: `scene` is a `clatter.Scene` (or a
/// path to a scene file); `backend` is "cpu" (the multi-threaded reference pipeline), "gpu"
/// (wgpu compute shaders; raises `BackendError` when no adapter is found) or "auto" (the GPU
/// when a hardware adapter is found and the scene fits it, else the CPU; `backend_reason`
/// says why); `threads` is the CPU worker count (default: all cores; results are bitwise
/// identical for any count).
#[pyclass(module = "clatter._clatter")]
pub struct Simulation {
    world: World,
    source: String,
    text: String,
    stepper: Stepper,
    pool: Option<rayon::ThreadPool>,
    reason: String,
    /// The host world was changed by a setter since the GPU copy was made.
    gpu_stale: bool,
    /// What of the GPU's state the host world lacks.
    behind: Behind,
    /// The blow-up checks of `clatter run`, with their energy baseline (renewed by setters).
    watch: Watch,
    /// Whether the initial-overlap check has run.
    started: bool,
}

#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (scene, backend = "auto", threads = None))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        backend: &str,
        threads: Option<usize>,
    ) -> PyResult<Simulation> {
        let parsed = parsed_scene(py, scene)?;
        let parsed = parsed.get();
        let world = parsed.scene.world();
        Simulation::build(
            world,
            parsed.scene.source.clone(),
            parsed.text.clone(),
            backend,
            threads,
        )
    }

    /// A simulation continued from a checkpoint written by `save_checkpoint` or by
    /// `clatter run --checkpoint-every` (bitwise the state it was saved in).
    #[staticmethod]
    #[pyo3(signature = (path, backend = "auto", threads = None))]
    fn from_checkpoint(path: PathBuf, backend: &str, threads: Option<usize>) -> PyResult<Self> {
        let ckpt = Checkpoint::load(&path).map_err(|e| checkpoint_error(&e))?;
        let (scene, world) = ckpt.world().map_err(|e| checkpoint_error(&e))?;
        Simulation::build(world, scene.source, ckpt.scene_text, backend, threads)
    }

    /// Advances `n` steps (the GIL is released while stepping; Ctrl-C is honoured between
    /// blocks of 1024 steps). Raises `SimulationError` with `clatter run`'s message (the body,
    /// the step and the likely cause) when the run blows up: bodies starting deeply
    /// overlapped, a non-finite state, energy growing without bound, a body through a wall,
    /// an overlap deeper than half a body (checked every 10 steps, as `clatter run` does).
    #[pyo3(signature = (n = 1))]
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        self.prepare(py)?;
        let mut left = n;
        while left > 0 {
            let m = left.min(CHUNK);
            let stepped = py.detach(|| {
                let (watch, stepper, world) = (&self.watch, &mut self.stepper, &mut self.world);
                let mut run = || watch.step(stepper, world, m, Readback::Nothing);
                match &self.pool {
                    Some(p) => p.install(run),
                    None => run(),
                }
            });
            if self.stepper.is_gpu() {
                self.behind = Behind::All;
            }
            stepped.map_err(|e| watch_error(py, &e))?;
            left -= m;
            if left > 0 {
                py.check_signals()?;
            }
        }
        Ok(())
    }

    /// Simulated time, s.
    #[getter]
    fn time(&self) -> f64 {
        self.stepper.time(&self.world)
    }

    /// Steps taken since the scene's start.
    #[getter]
    fn step_count(&self) -> u64 {
        self.stepper.step_count(&self.world)
    }

    /// The time step, s (the scene's `dt`, or 1/50 of the shortest contact duration).
    #[getter]
    fn dt(&self) -> f32 {
        self.world.dt
    }

    /// Gravity, m/s^2, as a (3,) float32 array.
    #[getter]
    fn gravity<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        Array1::from(self.world.gravity.to_array().to_vec()).into_pyarray(py)
    }

    /// Number of bodies.
    #[getter]
    fn n_bodies(&self) -> usize {
        self.world.len()
    }

    fn __len__(&self) -> usize {
        self.world.len()
    }

    /// The backend stepping the world: "cpu" or "gpu (ADAPTER NAME)".
    #[getter]
    fn backend(&self) -> String {
        self.stepper.name()
    }

    /// Why this backend was chosen (the `backend: ...` line of `clatter run`).
    #[getter]
    fn backend_reason(&self) -> &str {
        &self.reason
    }

    /// Where the scene came from.
    #[getter]
    fn source(&self) -> &str {
        &self.source
    }

    /// The scene's TOML text (what checkpoints store).
    #[getter]
    fn scene_toml(&self) -> &str {
        &self.text
    }

    /// Centres of mass, m: (N, 3) float64 (a copy; positions are kept to 48 bits, so a
    /// step's displacement is kept anywhere in a domain of kilometres). Settable (rounded to
    /// that grid by the next step; the broad phase is rebuilt before it).
    #[getter]
    fn positions<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = &self.bodies(py)?.state.position;
        Ok(array2(py, p.iter().flat_map(|v| v.to_array()).collect(), 3))
    }

    #[setter]
    fn set_positions(&mut self, value: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        let v = dvec3_input(&value, self.world.len(), "positions")?;
        let world = self.edit(value.py())?;
        world.state.position = v;
        world.set_needs_rebuild(true);
        Ok(())
    }

    /// Orientations as unit quaternions (w, x, y, z) in the frame the shapes were authored
    /// in (as in scene files and final.csv): (N, 4) float32.
    #[getter]
    fn orientations<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let world = self.bodies(py)?;
        let n = world.len();
        let mut out = Vec::with_capacity(4 * n);
        for i in 0..n {
            let q = world.user_orientation(i);
            out.extend([q.w, q.x, q.y, q.z]);
        }
        Ok(array2(py, out, 4))
    }

    /// Velocities of the centres of mass, m/s: (N, 3) float32. Settable.
    #[getter]
    fn velocities<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        Ok(vec3_array(py, &self.bodies(py)?.state.velocity))
    }

    #[setter]
    fn set_velocities(&mut self, value: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        let v = vec3_input(&value, self.world.len(), "velocities")?;
        self.edit(value.py())?.state.velocity = v;
        Ok(())
    }

    /// Angular velocities in the world frame, rad/s: (N, 3) float32. Settable (the angular
    /// momentum follows from the current orientation and inertia).
    #[getter]
    fn angular_velocities<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        Ok(vec3_array(py, &self.bodies(py)?.state.omega))
    }

    #[setter]
    fn set_angular_velocities(
        &mut self,
        value: PyArrayLike2<'_, f64, AllowTypeChange>,
    ) -> PyResult<()> {
        let v = vec3_input(&value, self.world.len(), "angular_velocities")?;
        let world = self.edit(value.py())?;
        let st = &mut world.state;
        for (i, w) in v.into_iter().enumerate() {
            let q: Quat = st.orientation[i];
            let body_w = q.conjugate() * w;
            st.angular_momentum[i] = q * (world.consts.inertia[i] * body_w);
            st.omega[i] = w;
        }
        Ok(())
    }

    /// Masses, kg: (N,) float32.
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        Array1::from(self.world.consts.mass.clone()).into_pyarray(py)
    }

    /// Whether each body has been removed by a `[[sink]]`: (N,) bool. A removed body's rows
    /// of the state arrays are its state when it was removed (setters do not move it); the
    /// energies and the momentum leave it out, so sums over the arrays should too.
    #[getter]
    fn removed<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let r = self.bodies(py)?.state.removed.clone();
        Ok(Array1::from(r).into_pyarray(py))
    }

    /// Bounding-sphere radii, m: (N,) float32.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        Array1::from(self.world.consts.radius.clone()).into_pyarray(py)
    }

    /// Each body's shape index (order of the scene's `[[shape]]` entries): (N,) int64.
    #[getter]
    fn shape_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ids(py, &self.world.consts.shape)
    }

    /// Each body's material index (order of the scene's `[[material]]` entries): (N,) int64.
    #[getter]
    fn material_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ids(py, &self.world.consts.material)
    }

    /// Total kinetic energy (translational plus rotational), J.
    fn kinetic_energy(&mut self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.bodies(py)?.kinetic_energy())
    }

    /// Gravitational potential energy relative to the origin, J.
    fn potential_energy(&mut self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.bodies(py)?.potential_energy())
    }

    /// Total linear momentum, kg m/s, as a tuple (px, py, pz).
    fn momentum(&mut self, py: Python<'_>) -> PyResult<(f64, f64, f64)> {
        let p = self.bodies(py)?.momentum();
        Ok((p[0], p[1], p[2]))
    }

    /// The contacts that touched in the last step, as a dict of arrays (M rows):
    ///
    /// - `body` (int64): a body; for a body pair the lower id.
    /// - `other` (int64): the other body, or -1 for a wall contact.
    /// - `wall` (int64): the wall index (order of the scene's walls, a container's five or
    ///   six planes after the `[[wall]]` entries), or -1 for a body pair.
    /// - `point` (M, 3): the centroid of the contact manifold, m (float64, like `positions`).
    /// - `point_count` (int64): how many points the manifold has (1 to 4).
    /// - `normal` (M, 3): unit, pointing from `body` towards the other side.
    /// - `depth` (M,): the deepest overlap of the manifold, m.
    /// - `force` (M, 3): the force on `body` from the other side, N (the other body gets
    ///   the opposite).
    /// - `normal_force` (M,): its normal part, N (positive when pushing apart).
    ///
    /// Points, normals and depths are recomputed at the current positions (contacts that no
    /// longer overlap are left out); forces are those of the last step.
    fn contacts<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let world = self.current(py)?;
        let reports = py.detach(|| touching_contacts(world));
        let m = reports.len();
        let (mut body, mut other, mut wall, mut boundary, mut count) = (
            Vec::with_capacity(m),
            Vec::with_capacity(m),
            Vec::with_capacity(m),
            Vec::with_capacity(m),
            Vec::with_capacity(m),
        );
        let (mut point, mut normal, mut force) = (
            Vec::with_capacity(3 * m),
            Vec::with_capacity(3 * m),
            Vec::with_capacity(3 * m),
        );
        let (mut depth, mut normal_force) = (Vec::with_capacity(m), Vec::with_capacity(m));
        for c in &reports {
            body.push(c.body as i64);
            let pts = c.manifold.points();
            let centroid = pts.iter().map(|p| p.point).sum::<Vec3>() / pts.len().max(1) as f32;
            // Manifolds are relative to the body's position: back to the world, in f64.
            let at = self.world.state.position[c.body as usize] + centroid.as_dvec3();
            point.extend(at.to_array());
            count.push(pts.len() as i64);
            // The manifold's normal points from the body towards the other body for a pair,
            // from the wall or mesh towards the body for a wall or mesh boundary; `force_b`
            // acts on the other body for a pair, on the body for a wall or mesh.
            let (n, f) = match c.other {
                Partner::Body(j) => {
                    other.push(j as i64);
                    wall.push(-1);
                    boundary.push(-1);
                    (c.manifold.normal, -c.force.force_b)
                }
                Partner::Wall(w) => {
                    other.push(-1);
                    wall.push(w as i64);
                    boundary.push(-1);
                    (-c.manifold.normal, c.force.force_b)
                }
                Partner::Boundary(k) => {
                    other.push(-1);
                    wall.push(-1);
                    boundary.push(k as i64);
                    (-c.manifold.normal, c.force.force_b)
                }
            };
            normal.extend(n.to_array());
            force.extend(f.to_array());
            depth.push(c.manifold.max_depth());
            normal_force.push(c.force.normal_force);
        }
        let d = PyDict::new(py);
        d.set_item("body", Array1::from(body).into_pyarray(py))?;
        d.set_item("other", Array1::from(other).into_pyarray(py))?;
        d.set_item("wall", Array1::from(wall).into_pyarray(py))?;
        d.set_item("boundary", Array1::from(boundary).into_pyarray(py))?;
        d.set_item("point", array2(py, point, 3))?;
        d.set_item("point_count", Array1::from(count).into_pyarray(py))?;
        d.set_item("normal", array2(py, normal, 3))?;
        d.set_item("depth", Array1::from(depth).into_pyarray(py))?;
        d.set_item("force", array2(py, force, 3))?;
        d.set_item("normal_force", Array1::from(normal_force).into_pyarray(py))?;
        Ok(d)
    }

    /// Writes the current step as ParaView files in `dir` (created if needed):
    /// `bodies_NNNNNN.vtu` and, with `contacts=True`, `contacts_NNNNNN.vtu` (the files of
    /// `clatter run --format vtk --contacts`, see docs/outputs.md), and adds them to
    /// `bodies.pvd` / `contacts.pvd` there, so calls at several steps make a time series.
    /// Returns the paths written.
    #[pyo3(signature = (dir, contacts = true))]
    fn write_vtk(
        &mut self,
        py: Python<'_>,
        dir: PathBuf,
        contacts: bool,
    ) -> PyResult<Vec<PathBuf>> {
        let io = |what: &Path, e: std::io::Error| {
            PyOSError::new_err(format!("cannot write {}: {e}", what.display()))
        };
        std::fs::create_dir_all(&dir).map_err(|e| io(&dir, e))?;
        let w = self.current(py)?;
        let step = w.step_count;
        let mut written = Vec::new();
        type Writer = fn(&Path, &World) -> std::io::Result<()>;
        let mut series: Vec<(&str, Writer)> = vec![("bodies", clatter::vtk::write_bodies)];
        if contacts {
            series.push(("contacts", clatter::vtk::write_contacts));
        }
        for (name, write) in series {
            let file = format!("{name}_{step:06}.vtu");
            let path = dir.join(&file);
            write(&path, w).map_err(|e| io(&path, e))?;
            let pvd_path = dir.join(format!("{name}.pvd"));
            let mut pvd = clatter::vtk::Pvd::continuing(&pvd_path, step);
            pvd.push(step, w.time, file).map_err(|e| io(&pvd_path, e))?;
            written.push(path);
        }
        Ok(written)
    }

    /// Writes the complete state to `path` (atomically): `Simulation.from_checkpoint(path)`
    /// and `clatter resume path` continue from it bitwise.
    fn save_checkpoint(&mut self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        self.current(py)?;
        let bytes = self.world.checkpoint_bytes(&self.source, &self.text, &[]);
        clatter::checkpoint::write_atomic(&path, &bytes)
            .map_err(|e| PyOSError::new_err(format!("cannot write {}: {e}", path.display())))
    }

    fn __repr__(&self) -> String {
        format!(
            "<Simulation {}: {} bodies, step {}, t = {:.6} s, {}>",
            self.source,
            self.world.len(),
            self.step_count(),
            self.time(),
            self.backend()
        )
    }
}

impl Simulation {
    fn build(
        world: World,
        source: String,
        text: String,
        backend: &str,
        threads: Option<usize>,
    ) -> PyResult<Simulation> {
        let pool = match threads {
            None => None,
            Some(0) => return Err(PyValueError::new_err("threads must be at least 1")),
            Some(n) if n > clatter::thread_limit() => {
                return Err(PyValueError::new_err(format!(
                    "threads={n} is more than {} (16 per core of this machine): results are identical for any count, so threads beyond the cores only slow the run",
                    clatter::thread_limit()
                )));
            }
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| BackendError::new_err(format!("cannot start {n} threads: {e}")))?,
            ),
        };
        let choice = match backend {
            "cpu" => BackendChoice::Cpu,
            "gpu" => BackendChoice::Gpu,
            "auto" => BackendChoice::Auto,
            other => {
                return Err(PyValueError::new_err(format!(
                    "backend must be \"auto\", \"cpu\" or \"gpu\", got {other:?}"
                )));
            }
        };
        let chosen = clatter_backend::choose(choice, &world, Device::Headless)
            .map_err(|e| BackendError::new_err(e.describe(GPU_OPTION)))?;
        let mut stepper = chosen.stepper;
        let watch = Watch::start(
            &mut stepper,
            &world,
            clatter::Health::new(&world),
            CHECK_EVERY,
            0,
        );
        Ok(Simulation {
            world,
            source,
            text,
            stepper,
            pool,
            reason: chosen.choice.describe(GPU_OPTION),
            gpu_stale: false,
            behind: Behind::Nothing,
            watch,
            started: false,
        })
    }

    /// Before steps: the world uploaded again if a setter changed it (with the checks'
    /// baseline renewed), and the initial-overlap check before the first.
    fn prepare(&mut self, py: Python<'_>) -> PyResult<()> {
        if self.gpu_stale {
            self.stepper
                .restart(&self.world)
                .map_err(|e| device_error(&e))?;
            let health = clatter::Health::new(&self.world);
            self.watch = Watch::start(&mut self.stepper, &self.world, health, CHECK_EVERY, 0);
            self.gpu_stale = false;
        }
        if !self.started {
            self.watch
                .health()
                .check_initial(&self.world)
                .map_err(|b| blow_up_error(py, &b))?;
            self.started = true;
        }
        Ok(())
    }

    /// The world with its body state current (read back from the GPU if it is behind).
    fn bodies(&mut self, py: Python<'_>) -> PyResult<&World> {
        if self.behind == Behind::All {
            let (stepper, world) = (&self.stepper, &mut self.world);
            py.detach(|| stepper.sync_bodies(world))
                .map_err(|e| device_error(&e))?;
            self.behind = Behind::Contacts;
        }
        Ok(&self.world)
    }

    /// The world with everything current: bodies and the contact list.
    fn current(&mut self, py: Python<'_>) -> PyResult<&World> {
        if self.behind != Behind::Nothing {
            let (stepper, world) = (&self.stepper, &mut self.world);
            py.detach(|| stepper.sync(world))
                .map_err(|e| device_error(&e))?;
            self.behind = Behind::Nothing;
        }
        Ok(&self.world)
    }

    /// The world for a setter to change: made current first, its GPU copy (if any) then
    /// stale, so the next step uploads it again with a new energy baseline.
    fn edit(&mut self, py: Python<'_>) -> PyResult<&mut World> {
        self.current(py)?;
        self.gpu_stale = true;
        Ok(&mut self.world)
    }
}

/// The `ParsedScene` of a `clatter.Scene`, a `ParsedScene` or a path.
fn parsed_scene<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, ParsedScene>> {
    if let Ok(p) = scene.cast::<ParsedScene>() {
        return Ok(p.clone());
    }
    if scene.hasattr("_parsed")? {
        let p = scene.call_method0("_parsed")?;
        return Ok(p.cast_into::<ParsedScene>()?);
    }
    if let Ok(path) = scene.extract::<PathBuf>() {
        return Bound::new(py, ParsedScene::load(py, &path)?);
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "scene must be a clatter.Scene or the path of a scene file, got {}",
        scene.get_type().name()?
    )))
}

fn array2<T: numpy::Element>(py: Python<'_>, flat: Vec<T>, cols: usize) -> Bound<'_, PyArray2<T>> {
    let rows = flat.len() / cols;
    Array2::from_shape_vec((rows, cols), flat)
        .expect("rows * cols elements")
        .into_pyarray(py)
}

fn vec3_array<'py>(py: Python<'py>, v: &[Vec3]) -> Bound<'py, PyArray2<f32>> {
    array2(py, v.iter().flat_map(|v| v.to_array()).collect(), 3)
}

fn ids<'py>(py: Python<'py>, v: &[u32]) -> Bound<'py, PyArray1<i64>> {
    Array1::from_iter(v.iter().map(|&i| i as i64)).into_pyarray(py)
}

/// An (N, 3) array of finite numbers as vectors, or a ValueError naming `what`.
fn vec3_input(
    value: &PyArrayLike2<'_, f64, AllowTypeChange>,
    n: usize,
    what: &str,
) -> PyResult<Vec<Vec3>> {
    Ok(dvec3_input(value, n, what)?
        .into_iter()
        .map(|v| v.as_vec3())
        .collect())
}

/// [`vec3_input`] at full precision (positions).
fn dvec3_input(
    value: &PyArrayLike2<'_, f64, AllowTypeChange>,
    n: usize,
    what: &str,
) -> PyResult<Vec<glam::DVec3>> {
    let a = value.as_array();
    if a.shape() != [n, 3] {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape ({n}, 3), got {:?}",
            a.shape()
        )));
    }
    let mut out = Vec::with_capacity(n);
    for (i, row) in a.rows().into_iter().enumerate() {
        // Finite also as f32: the step bins positions and keeps velocities in f32 (1e39
        // was infinite there, and a step of a position that large never ended).
        if !row.iter().all(|&x| x.is_finite() && (x as f32).is_finite()) {
            return Err(PyValueError::new_err(format!(
                "{what}[{i}] must be finite (at most {:e} in size), got {row}",
                f32::MAX
            )));
        }
        out.push(glam::DVec3::new(row[0], row[1], row[2]));
    }
    Ok(out)
}
