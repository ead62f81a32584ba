//! `Simulation`: a world stepped on the CPU (rayon) or the GPU (wgpu), its state as numpy
//! arrays.
//!
//! The host `World` is always current: after a GPU step the bodies and the contact list are
//! read back, so every getter, `contacts()`, `write_vtk` and `save_checkpoint` read one
//! place. A setter marks the GPU copy stale; the next step uploads the world again.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use numpy::ndarray::{Array1, Array2};
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use clatter::health::touching_contacts;
use clatter::{Checkpoint, Partner, World};

use crate::errors::{BackendError, SimulationError, checkpoint_error};
use crate::scene::ParsedScene;

/// Steps run between two checks for Ctrl-C (the GIL is released while they run).
const CHUNK: u64 = 1024;
/// Steps between two blow-up checks (energy growth, escape, deep overlaps), as `clatter run`.
const CHECK_EVERY: u64 = 10;

/// What steps the world.
enum Engine {
    Cpu,
    #[cfg(feature = "gpu")]
    Gpu(Box<clatter_gpu::GpuWorld>),
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
    engine: Engine,
    pool: Option<rayon::ThreadPool>,
    reason: String,
    /// The host world was changed by a setter since the GPU copy was made.
    gpu_stale: bool,
    /// The blow-up checks of `clatter run`, with their energy baseline (renewed by setters).
    health: clatter::Health,
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
        if !self.started {
            self.health
                .check_initial(&self.world)
                .map_err(|b| SimulationError::new_err(b.to_string()))?;
            self.started = true;
        }
        let mut left = n;
        while left > 0 {
            let m = left.min(CHUNK);
            py.detach(|| -> PyResult<()> {
                let mut done = 0;
                while done < m {
                    let k = (m - done).min(CHECK_EVERY);
                    self.advance(k)?;
                    self.health
                        .check(&self.world, false)
                        .map_err(|b| SimulationError::new_err(b.to_string()))?;
                    done += k;
                }
                Ok(())
            })?;
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
        self.world.time
    }

    /// Steps taken since the scene's start.
    #[getter]
    fn step_count(&self) -> u64 {
        self.world.step_count
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
        match &self.engine {
            Engine::Cpu => "cpu".into(),
            #[cfg(feature = "gpu")]
            Engine::Gpu(g) => format!("gpu ({})", g.context().adapter_name()),
        }
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

    /// Centres of mass, m: (N, 3) float64 (a copy; positions are kept in double precision,
    /// so a step's displacement is kept anywhere in a large domain). Settable, at full
    /// precision (the broad phase is rebuilt before the next step).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p = &self.world.state.position;
        array2(py, p.iter().flat_map(|v| v.to_array()).collect(), 3)
    }

    #[setter]
    fn set_positions(&mut self, value: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        let v = dvec3_input(&value, self.world.len(), "positions")?;
        self.world.state.position = v;
        self.world.set_needs_rebuild(true);
        self.gpu_stale = true;
        self.health = clatter::Health::new(&self.world);
        Ok(())
    }

    /// Orientations as unit quaternions (w, x, y, z) in the frame the shapes were authored
    /// in (as in scene files and final.csv): (N, 4) float32.
    #[getter]
    fn orientations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        let n = self.world.len();
        let mut out = Vec::with_capacity(4 * n);
        for i in 0..n {
            let q = self.world.user_orientation(i);
            out.extend([q.w, q.x, q.y, q.z]);
        }
        array2(py, out, 4)
    }

    /// Velocities of the centres of mass, m/s: (N, 3) float32. Settable.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        vec3_array(py, &self.world.state.velocity)
    }

    #[setter]
    fn set_velocities(&mut self, value: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        let v = vec3_input(&value, self.world.len(), "velocities")?;
        self.world.state.velocity = v;
        self.gpu_stale = true;
        self.health = clatter::Health::new(&self.world);
        Ok(())
    }

    /// Angular velocities in the world frame, rad/s: (N, 3) float32. Settable (the angular
    /// momentum follows from the current orientation and inertia).
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        vec3_array(py, &self.world.state.omega)
    }

    #[setter]
    fn set_angular_velocities(
        &mut self,
        value: PyArrayLike2<'_, f64, AllowTypeChange>,
    ) -> PyResult<()> {
        let v = vec3_input(&value, self.world.len(), "angular_velocities")?;
        let st = &mut self.world.state;
        for (i, w) in v.into_iter().enumerate() {
            let q: Quat = st.orientation[i];
            let body_w = q.conjugate() * w;
            st.angular_momentum[i] = q * (self.world.consts.inertia[i] * body_w);
            st.omega[i] = w;
        }
        self.gpu_stale = true;
        self.health = clatter::Health::new(&self.world);
        Ok(())
    }

    /// Masses, kg: (N,) float32.
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        Array1::from(self.world.consts.mass.clone()).into_pyarray(py)
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
    fn kinetic_energy(&self) -> f64 {
        self.world.kinetic_energy()
    }

    /// Gravitational potential energy relative to the origin, J.
    fn potential_energy(&self) -> f64 {
        self.world.potential_energy()
    }

    /// Total linear momentum, kg m/s, as a tuple (px, py, pz).
    fn momentum(&self) -> (f64, f64, f64) {
        let p = self.world.momentum();
        (p[0], p[1], p[2])
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
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let reports = py.detach(|| touching_contacts(&self.world));
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
    fn write_vtk(&self, dir: PathBuf, contacts: bool) -> PyResult<Vec<PathBuf>> {
        let io = |what: &Path, e: std::io::Error| {
            PyOSError::new_err(format!("cannot write {}: {e}", what.display()))
        };
        std::fs::create_dir_all(&dir).map_err(|e| io(&dir, e))?;
        let w = &self.world;
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
    fn save_checkpoint(&self, path: PathBuf) -> PyResult<()> {
        let bytes = self.world.checkpoint_bytes(&self.source, &self.text, &[]);
        clatter::checkpoint::write_atomic(&path, &bytes)
            .map_err(|e| PyOSError::new_err(format!("cannot write {}: {e}", path.display())))
    }

    fn __repr__(&self) -> String {
        format!(
            "<Simulation {}: {} bodies, step {}, t = {:.6} s, {}>",
            self.source,
            self.world.len(),
            self.world.step_count,
            self.world.time,
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
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| BackendError::new_err(format!("cannot start {n} threads: {e}")))?,
            ),
        };
        let (engine, reason) = choose(backend, &world)?;
        let health = clatter::Health::new(&world);
        Ok(Simulation {
            world,
            source,
            text,
            engine,
            pool,
            reason,
            gpu_stale: false,
            health,
            started: false,
        })
    }

    /// `m` steps on the chosen engine; the host world is current afterwards.
    fn advance(&mut self, m: u64) -> PyResult<()> {
        match &mut self.engine {
            Engine::Cpu => {
                let world = &mut self.world;
                let health = &self.health;
                let mut run = || -> PyResult<()> {
                    for _ in 0..m {
                        if let Err(e) = world.step() {
                            let report = health.non_finite(world, &e);
                            return Err(SimulationError::new_err(report.to_string()));
                        }
                    }
                    Ok(())
                };
                match &self.pool {
                    Some(p) => p.install(run),
                    None => run(),
                }
            }
            #[cfg(feature = "gpu")]
            Engine::Gpu(gpu) => {
                let world = &mut self.world;
                let gpu_err = |e: clatter_gpu::GpuError| BackendError::new_err(e.to_string());
                if self.gpu_stale {
                    let ctx = gpu.context().clone();
                    **gpu = clatter_gpu::GpuWorld::new(ctx, world).map_err(gpu_err)?;
                    self.gpu_stale = false;
                }
                let report = gpu.step_into(m, world).map_err(gpu_err)?;
                world.set_contact_state(gpu.contact_state().map_err(gpu_err)?);
                if let Some(body) = report.bad_body {
                    let e = clatter::SimError::NonFinite {
                        body,
                        step: world.step_count + 1,
                        time: world.time + world.dt as f64,
                        dt: world.dt,
                    };
                    let report = self.health.non_finite(world, &e);
                    return Err(SimulationError::new_err(report.to_string()));
                }
                Ok(())
            }
        }
    }
}

/// The engine for `backend` and the reason, as `clatter run --backend` chooses it.
fn choose(backend: &str, world: &World) -> PyResult<(Engine, String)> {
    match backend {
        "cpu" => Ok((Engine::Cpu, "cpu".into())),
        "gpu" | "auto" => choose_gpu(backend == "auto", world),
        other => Err(PyValueError::new_err(format!(
            "backend must be \"auto\", \"cpu\" or \"gpu\", got {other:?}"
        ))),
    }
}

#[cfg(not(feature = "gpu"))]
fn choose_gpu(auto: bool, _world: &World) -> PyResult<(Engine, String)> {
    if auto {
        Ok((
            Engine::Cpu,
            "cpu (auto: this module was built without GPU support)".into(),
        ))
    } else {
        Err(BackendError::new_err(
            "backend=\"gpu\": this module was built without GPU support (build it with the `gpu` feature)",
        ))
    }
}

/// `clatter_gpu::backend::choose`, the CLI's own choice, with Python's wording of errors.
#[cfg(feature = "gpu")]
fn choose_gpu(auto: bool, world: &World) -> PyResult<(Engine, String)> {
    use clatter_gpu::backend::{self, BackendChoice, Device, Stepper};
    let choice = if auto {
        BackendChoice::Auto
    } else {
        BackendChoice::Gpu
    };
    match backend::choose(choice, world, Device::Headless) {
        Ok(chosen) => {
            let reason = chosen
                .note
                .as_deref()
                .map_or("cpu", |n| n.trim_start_matches("backend: "))
                .replace("--backend gpu", "backend=\"gpu\"");
            let engine = match chosen.stepper {
                Stepper::Cpu => Engine::Cpu,
                Stepper::Gpu(g) => Engine::Gpu(g),
            };
            Ok((engine, reason))
        }
        Err(e) => Err(BackendError::new_err(e.to_string().replacen(
            "--backend gpu",
            "backend=\"gpu\"",
            1,
        ))),
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
        if !row.iter().all(|x| x.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "{what}[{i}] must be finite, got {row}"
            )));
        }
        out.push(glam::DVec3::new(row[0], row[1], row[2]));
    }
    Ok(out)
}
