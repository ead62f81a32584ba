//! A turning mesh boundary's pose on the GPU (`shaders/common/turn.wgsl`) on a batch of
//! queries, so that tests can hold it bitwise against its twin, `clatter::turn`.

use crate::batch::{BatchBindings, run_batch};
use crate::layout::Params;
use crate::{GpuContext, GpuError};
use bytemuck::Zeroable;
use glam::{Quat, Vec3};

/// One query: a rotation's axis, rate and centre, and the motion's elapsed time.
#[derive(Debug, Clone, Copy)]
pub struct TurnQuery {
    /// Unit axis.
    pub axis: Vec3,
    /// Rate, rad/s (> 0).
    pub rate: f32,
    /// A point on the axis.
    pub centre: Vec3,
    /// Elapsed time as a double-single `(hi, lo)`.
    pub u: (f32, f32),
    /// An argument for `turn_sin_cos` alone, in `[0, 4)`.
    pub x: f32,
}

/// The GPU's answer to a [`TurnQuery`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnAnswer {
    /// `turn_angle(rate, u)`.
    pub angle: f32,
    /// The pose's rotation and translation at that angle (`turn_pose`).
    pub rotation: Quat,
    pub translation: Vec3,
    /// `turn_sin_cos(x)`.
    pub sin_cos: (f32, f32),
}

/// Runs `turn.wgsl`'s `turn_angle`, `turn_pose` and `turn_sin_cos` on every query.
pub fn turn_batch(ctx: &GpuContext, queries: &[TurnQuery]) -> Result<Vec<TurnAnswer>, GpuError> {
    let source = crate::pipeline::source(&[include_str!("../shaders/test/turn_batch.wgsl")]);
    let records: Vec<[f32; 12]> = queries
        .iter()
        .map(|q| {
            [
                q.axis.x, q.axis.y, q.axis.z, q.rate, q.centre.x, q.centre.y, q.centre.z, 0.0,
                q.u.0, q.u.1, q.x, 0.0,
            ]
        })
        .collect();
    let params = Params {
        one: 1.0,
        ..Params::zeroed()
    };
    let bindings = BatchBindings {
        input: 90,
        output: 91,
        uniform: Some((0, bytemuck::bytes_of(&params))),
    };
    let words: Vec<[f32; 12]> =
        run_batch(ctx, "turn batch", source, "turn_batch", &records, bindings)?;
    Ok(words
        .iter()
        .map(|w| TurnAnswer {
            angle: w[7],
            rotation: Quat::from_xyzw(w[0], w[1], w[2], w[3]),
            translation: Vec3::new(w[4], w[5], w[6]),
            sin_cos: (w[8], w[9]),
        })
        .collect())
}
