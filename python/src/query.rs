//! Collision queries over arrays of poses: the answers of `clatter query` (docs/queries.md)
//! as numpy arrays. `clatter.query` (Python) broadcasts its arguments and calls
//! [`query_arrays`].

use glam::{DQuat, Quat, Vec3};
use numpy::ndarray::{Array1, Array2, Array3, ArrayView2};
use numpy::{AllowTypeChange, IntoPyArray, PyArrayLike2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use serde::Deserialize;

use clatter::shape_spec::ShapeSpec;
use clatter_geom::query::{self, Motion};
use clatter_geom::{Pose, PreparedShape};

use crate::errors::QueryError;

type Arr2<'py> = PyArrayLike2<'py, f64, AllowTypeChange>;

/// One pose's answers; NaN where a query was not asked or found nothing.
#[derive(Clone, Copy)]
struct Row {
    intersects: bool,
    distance: f32,
    points: [Vec3; 2],
    normal: Vec3,
    depth: f32,
    contacts: [Vec3; 4],
    contact_count: usize,
    toi: f32,
    toi_points: [Vec3; 2],
    toi_normal: Vec3,
    toi_converged: bool,
}

const NAN3: Vec3 = Vec3::splat(f32::NAN);

impl Default for Row {
    fn default() -> Self {
        Row {
            intersects: false,
            distance: f32::NAN,
            points: [NAN3; 2],
            normal: NAN3,
            depth: f32::NAN,
            contacts: [NAN3; 4],
            contact_count: 0,
            toi: f32::NAN,
            toi_points: [NAN3; 2],
            toi_normal: NAN3,
            toi_converged: true,
        }
    }
}

/// The queries of `clatter query` for M pose pairs (the native half of `clatter.query`).
///
/// `shape_a`, `shape_b`: JSON text of a shape in the scene file's syntax; positions,
/// velocities and angular velocities (M, 3), orientations (M, 4) as w, x, y, z in the
/// authored frame; `queries` a subset of "intersects", "distance", "contact", "toi".
/// Returns a dict of arrays with M rows (see `clatter.query`).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (shape_a, position_a, orientation_a, velocity_a, angular_velocity_a,
                    shape_b, position_b, orientation_b, velocity_b, angular_velocity_b,
                    queries, toi_horizon))]
pub fn query_arrays<'py>(
    py: Python<'py>,
    shape_a: &str,
    position_a: Arr2<'py>,
    orientation_a: Arr2<'py>,
    velocity_a: Arr2<'py>,
    angular_velocity_a: Arr2<'py>,
    shape_b: &str,
    position_b: Arr2<'py>,
    orientation_b: Arr2<'py>,
    velocity_b: Arr2<'py>,
    angular_velocity_b: Arr2<'py>,
    queries: Vec<String>,
    toi_horizon: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let mut wants = [false; 4];
    for q in &queries {
        match q.as_str() {
            "intersects" => wants[0] = true,
            "distance" => wants[1] = true,
            "contact" => wants[2] = true,
            "toi" => wants[3] = true,
            other => {
                return Err(QueryError::new_err(format!(
                    "unknown query {other:?} (expected \"intersects\", \"distance\", \"contact\" or \"toi\")"
                )));
            }
        }
    }
    if !(toi_horizon.is_finite() && toi_horizon >= 0.0) {
        return Err(QueryError::new_err(
            "toi_horizon must be a finite number >= 0",
        ));
    }
    let sa = prepare("shape_a", shape_a)?;
    let sb = prepare("shape_b", shape_b)?;
    let m = position_a.as_array().nrows();
    let a = Bodies::new(
        "a",
        &sa,
        m,
        [
            position_a.as_array(),
            orientation_a.as_array(),
            velocity_a.as_array(),
            angular_velocity_a.as_array(),
        ],
    )?;
    let b = Bodies::new(
        "b",
        &sb,
        m,
        [
            position_b.as_array(),
            orientation_b.as_array(),
            velocity_b.as_array(),
            angular_velocity_b.as_array(),
        ],
    )?;
    let horizon = toi_horizon as f32;
    let rows: Vec<Row> = py.detach(|| {
        (0..m)
            .into_par_iter()
            .with_min_len(64)
            .map(|i| answer(&sa, &a, &sb, &b, i, wants, horizon))
            .collect()
    });
    let d = PyDict::new(py);
    let flat2 = |f: &dyn Fn(&Row) -> [Vec3; 2]| {
        let v: Vec<f32> = rows
            .iter()
            .flat_map(|r| f(r).into_iter().flat_map(|p| p.to_array()))
            .collect();
        Array3::from_shape_vec((m, 2, 3), v).expect("m x 2 x 3")
    };
    let vec3s = |f: &dyn Fn(&Row) -> Vec3| {
        let v: Vec<f32> = rows.iter().flat_map(|r| f(r).to_array()).collect();
        Array2::from_shape_vec((m, 3), v).expect("m x 3")
    };
    let scalars = |f: &dyn Fn(&Row) -> f32| Array1::from_iter(rows.iter().map(f));
    if wants[0] {
        let v = Array1::from_iter(rows.iter().map(|r| r.intersects));
        d.set_item("intersects", v.into_pyarray(py))?;
    }
    if wants[1] {
        d.set_item("distance", scalars(&|r| r.distance).into_pyarray(py))?;
    }
    if wants[1] || wants[2] {
        d.set_item("points", flat2(&|r| r.points).into_pyarray(py))?;
        d.set_item("normal", vec3s(&|r| r.normal).into_pyarray(py))?;
    }
    if wants[2] {
        d.set_item("depth", scalars(&|r| r.depth).into_pyarray(py))?;
        let v: Vec<f32> = rows
            .iter()
            .flat_map(|r| r.contacts.into_iter().flat_map(|p| p.to_array()))
            .collect();
        let contacts = Array3::from_shape_vec((m, 4, 3), v).expect("m x 4 x 3");
        d.set_item("contacts", contacts.into_pyarray(py))?;
        let counts = Array1::from_iter(rows.iter().map(|r| r.contact_count as i64));
        d.set_item("contact_count", counts.into_pyarray(py))?;
    }
    if wants[3] {
        d.set_item("toi", scalars(&|r| r.toi).into_pyarray(py))?;
        d.set_item("toi_points", flat2(&|r| r.toi_points).into_pyarray(py))?;
        d.set_item("toi_normal", vec3s(&|r| r.toi_normal).into_pyarray(py))?;
        let v = Array1::from_iter(rows.iter().map(|r| r.toi_converged));
        d.set_item("toi_converged", v.into_pyarray(py))?;
    }
    Ok(d)
}

/// A shape from its JSON description, or a `QueryError` naming the argument.
fn prepare(name: &str, json: &str) -> PyResult<PreparedShape> {
    let err = |e: String| QueryError::new_err(format!("{name}: {e}"));
    let value: serde_json::Value = serde_json::from_str(json).map_err(|e| err(e.to_string()))?;
    let spec = ShapeSpec::deserialize(&value).map_err(|e| err(e.to_string()))?;
    spec.to_kind()
        .map_err(err)?
        .prepare()
        .map_err(|e| err(e.to_string()))
}

/// One side's poses (principal frame) and motions.
struct Bodies {
    poses: Vec<Pose>,
    motions: Vec<Motion>,
}

impl Bodies {
    /// Checks the arrays (M rows, finite, non-zero quaternions) and builds the poses the way
    /// a scene file places a body: `position` is the centre of mass, `orientation` rotates
    /// the shape as authored.
    fn new(
        side: &str,
        shape: &PreparedShape,
        m: usize,
        [pos, ori, vel, ang]: [ArrayView2<'_, f64>; 4],
    ) -> PyResult<Bodies> {
        for (what, a, cols) in [
            ("position", &pos, 3),
            ("orientation", &ori, 4),
            ("velocity", &vel, 3),
            ("angular_velocity", &ang, 3),
        ] {
            if a.shape() != [m, cols] {
                return Err(QueryError::new_err(format!(
                    "{what}_{side} must have shape ({m}, {cols}), got {:?}",
                    a.shape()
                )));
            }
            if let Some(i) = a
                .rows()
                .into_iter()
                .position(|r| !r.iter().all(|x| x.is_finite()))
            {
                return Err(QueryError::new_err(format!(
                    "{what}_{side}[{i}] must be finite"
                )));
            }
        }
        let v = |r: numpy::ndarray::ArrayView1<'_, f64>| {
            Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)
        };
        let mut poses = Vec::with_capacity(m);
        let mut motions = Vec::with_capacity(m);
        for i in 0..m {
            let o = ori.row(i);
            let q = DQuat::from_xyzw(o[1], o[2], o[3], o[0]);
            let len = q.length();
            if !(len > 0.0 && len.is_finite()) {
                return Err(QueryError::new_err(format!(
                    "orientation_{side}[{i}] must be a non-zero quaternion [w, x, y, z]"
                )));
            }
            let q: Quat = (q / len).as_quat();
            poses.push(Pose::new(v(pos.row(i)), (q * shape.frame).normalize()));
            motions.push(Motion {
                linear: v(vel.row(i)),
                angular: v(ang.row(i)),
            });
        }
        Ok(Bodies { poses, motions })
    }
}

/// The answers for pose pair `i` (what `clatter query` answers for one line).
fn answer(
    sa: &PreparedShape,
    a: &Bodies,
    sb: &PreparedShape,
    b: &Bodies,
    i: usize,
    [intersects, distance, contact, toi]: [bool; 4],
    horizon: f32,
) -> Row {
    let (shape_a, shape_b) = (&sa.shape, &sb.shape);
    let (pa, pb) = (&a.poses[i], &b.poses[i]);
    let mut r = Row::default();
    if intersects {
        r.intersects = query::intersects(shape_a, pa, shape_b, pb);
    }
    if distance {
        let d = query::distance(shape_a, pa, shape_b, pb);
        r.distance = d.distance;
        r.points = d.points;
        r.normal = d.normal;
    }
    if contact {
        // As in `clatter query`: with both queries, `points` and `normal` are the contact's.
        let c = query::contact(shape_a, pa, shape_b, pb);
        r.depth = c.depth;
        r.points = c.points;
        r.normal = c.normal;
        let pts = c.manifold.points();
        r.contact_count = pts.len();
        for (k, p) in pts.iter().take(4).enumerate() {
            r.contacts[k] = *p;
        }
    }
    if toi
        && let Some(t) = query::time_of_impact(
            shape_a,
            pa,
            &a.motions[i],
            shape_b,
            pb,
            &b.motions[i],
            horizon,
        )
    {
        r.toi = t.time;
        r.toi_points = t.points;
        r.toi_normal = t.normal;
        r.toi_converged = t.converged;
    }
    r
}
