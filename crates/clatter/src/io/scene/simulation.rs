//! `[simulation]`: how long to run, the time step, gravity, the Verlet skin and the periodic
//! box. The table is required, and it is validated first.

use std::ops::Range;

use glam::Vec3;
use toml::Spanned;

use super::periodic::periodic_box;
use super::raw::RawSimulation;
use super::{RunLength, SceneError, SourceFile};
use crate::periodic::Periodic;

/// The validated `[simulation]` table.
pub(super) struct Simulation {
    /// `duration` or `steps`.
    pub(super) length: RunLength,
    /// `dt`, when given (else the world picks one from the contact duration).
    pub(super) dt: Option<f32>,
    /// `gravity` (default `[0, 0, -9.81]`).
    pub(super) gravity: Vec3,
    /// `skin`, when given.
    pub(super) skin: Option<f32>,
    /// The periodic box and the span of its table, which later checks point at.
    pub(super) periodic: Option<(Periodic, Range<usize>)>,
}

/// Validates `[simulation]`: it must be there, with exactly one of `duration` and `steps`.
pub(super) fn simulation(
    cx: &SourceFile,
    raw: &Option<Spanned<RawSimulation>>,
) -> Result<Simulation, SceneError> {
    let (length, dt, gravity, skin, periodic) = match raw {
        None => {
            return cx.err(
                0..0,
                "simulation",
                "missing table [simulation] (it needs `duration` or `steps`)",
            );
        }
        Some(sim) => {
            let s = sim.get_ref();
            let length = match (&s.duration, &s.steps) {
                (Some(_), Some(st)) => {
                    return cx.err(
                        st.span(),
                        "simulation.steps",
                        "give either `duration` or `steps`, not both",
                    );
                }
                (Some(d), None) => RunLength::Duration(cx.positive(d, "simulation.duration")?),
                (None, Some(st)) => {
                    if *st.get_ref() <= 0 {
                        return cx.err(
                            st.span(),
                            "simulation.steps",
                            format!("must be a positive integer, got {}", st.get_ref()),
                        );
                    }
                    RunLength::Steps(*st.get_ref() as u64)
                }
                (None, None) => {
                    return cx.err(
                        sim.span(),
                        "simulation",
                        "needs `duration` (seconds) or `steps`",
                    );
                }
            };
            let dt =
                s.dt.as_ref()
                    .map(|d| cx.positive(d, "simulation.dt").map(|x| x as f32))
                    .transpose()?;
            let gravity = match &s.gravity {
                Some(g) => cx.vec3(g, "simulation.gravity")?,
                None => Vec3::new(0.0, 0.0, -9.81),
            };
            let skin = s
                .skin
                .as_ref()
                .map(|d| cx.non_negative(d, "simulation.skin").map(|x| x as f32))
                .transpose()?;
            let periodic = match &s.periodic {
                None => None,
                Some(p) => Some((periodic_box(cx, p.get_ref())?, p.span())),
            };
            (length, dt, gravity, skin, periodic)
        }
    };
    Ok(Simulation {
        length,
        dt,
        gravity,
        skin,
        periodic,
    })
}
