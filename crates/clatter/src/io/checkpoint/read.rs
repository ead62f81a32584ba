//! Reading a checkpoint's sections into its state, each section checked as it is read.

use super::bytes::Reader;
use super::*;

pub(super) fn read_meta(r: &mut Reader<'_>, st: &mut State) -> Result<(), CheckpointError> {
    st.bodies = r.u64()?;
    st.walls = r.u64()?;
    st.fingerprint = r.u32()?;
    st.dt = r.f32()?;
    st.time = r.f64()?;
    st.step_count = r.u64()?;
    st.rebuilds = r.u64()?;
    st.skin = r.f32()?;
    st.gravity = r.vec3()?;
    st.needs_rebuild = match r.bytes(1)?[0] {
        0 => false,
        1 => true,
        b => {
            return Err(CheckpointError::Malformed(format!(
                "rebuild flag {b} is neither 0 nor 1"
            )));
        }
    };
    r.finish()?;
    if !(st.dt.is_finite() && st.dt > 0.0) {
        return Err(CheckpointError::Malformed(format!(
            "time step {} is not a positive number",
            st.dt
        )));
    }
    if !(st.time.is_finite() && st.skin.is_finite() && st.skin >= 0.0 && st.gravity.is_finite()) {
        return Err(CheckpointError::Malformed(
            "non-finite time, skin or gravity".into(),
        ));
    }
    Ok(())
}

pub(super) fn read_bodies(r: &mut Reader<'_>, st: &mut State) -> Result<(), CheckpointError> {
    let n = r.count(3 * 8 + 17 * 4)?;
    if n as u64 != st.bodies {
        return Err(CheckpointError::Malformed(format!(
            "{n} body states for {} bodies",
            st.bodies
        )));
    }
    for i in 0..n {
        let x = r.dvec3()?;
        let v = r.vec3()?;
        let q = Quat::from_xyzw(r.f32()?, r.f32()?, r.f32()?, r.f32()?);
        let residual = Quat::from_xyzw(r.f32()?, r.f32()?, r.f32()?, r.f32()?);
        let l = r.vec3()?;
        let w = r.vec3()?;
        if !(x.is_finite()
            && v.is_finite()
            && q.is_finite()
            && residual.is_finite()
            && l.is_finite()
            && w.is_finite())
        {
            return Err(CheckpointError::Malformed(format!(
                "body {i} has a non-finite state"
            )));
        }
        if x.abs().max_element() > MAX_COORDINATE {
            return Err(CheckpointError::Malformed(format!(
                "body {i} is at {x}, too far from the origin"
            )));
        }
        st.body.position.push(x);
        st.body.velocity.push(v);
        st.body.orientation.push(q);
        st.body.orientation_residual.push(residual);
        st.body.angular_momentum.push(l);
        st.body.omega.push(w);
    }
    r.finish()
}

pub(super) fn read_removed(r: &mut Reader<'_>, st: &mut State) -> Result<(), CheckpointError> {
    let n = r.count(4)?;
    let mut last: Option<u32> = None;
    for _ in 0..n {
        let i = r.u32()?;
        if i as u64 >= st.bodies || last.is_some_and(|l| i <= l) {
            return Err(CheckpointError::Malformed(format!(
                "removed body {i} is out of range or out of order ({} bodies)",
                st.bodies
            )));
        }
        st.body.removed[i as usize] = true;
        last = Some(i);
    }
    r.finish()
}

/// Whether body `i` is flagged removed; an index out of range (a damaged file's) is not, and
/// is then refused by the checks that follow.
pub(super) fn is_removed(removed: &[bool], i: u32) -> bool {
    removed.get(i as usize).copied().unwrap_or(false)
}

/// The stored contact list without the contacts of bodies removed by a sink: body pairs,
/// wall pairs, springs and piece codes (empty without composites).
type Kept = (Vec<[u32; 2]>, Vec<[u32; 2]>, ContactSprings, Vec<u32>);

/// The stored contact list without the contacts of removed bodies ([`Kept`]).
pub(super) fn without_removed(st: &State, removed: &[bool]) -> Kept {
    let np = st.pairs.len();
    let keep: Vec<bool> = st
        .pairs
        .iter()
        .map(|&[i, j]| !(is_removed(removed, i) || is_removed(removed, j)))
        .chain(st.wall_pairs.iter().map(|&[i, _]| !is_removed(removed, i)))
        .collect();
    pub(super) fn select<T: Clone>(v: &[T], keep: &[bool]) -> Vec<T> {
        v.iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| x.clone())
            .collect()
    }
    let sp = &st.springs;
    let springs = ContactSprings {
        history: select(&sp.history, &keep),
        twist: select(&sp.twist, &keep),
        forces: select(&sp.forces, &keep),
        touching: select(&sp.touching, &keep),
        hints: select(&sp.hints, &keep[..np]),
        separation_bound: select(&sp.separation_bound, &keep[..np]),
    };
    (
        select(&st.pairs, &keep[..np]),
        select(&st.wall_pairs, &keep[np..]),
        springs,
        if st.pieces.len() == keep.len() {
            select(&st.pieces, &keep)
        } else {
            st.pieces.clone()
        },
    )
}

pub(super) fn read_contacts(r: &mut Reader<'_>, st: &mut State) -> Result<(), CheckpointError> {
    if st
        .rebuild_position
        .iter()
        .any(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE)
    {
        return Err(CheckpointError::Malformed(
            "a rebuild position is non-finite or too far from the origin".into(),
        ));
    }
    let np = r.count(8)?;
    for _ in 0..np {
        st.pairs.push([r.u32()?, r.u32()?]);
    }
    let nw = r.count(8)?;
    for _ in 0..nw {
        st.wall_pairs.push([r.u32()?, r.u32()?]);
    }
    let nc = np + nw;
    r.need(
        nc.checked_mul(57)
            .ok_or_else(|| CheckpointError::Malformed("contact count overflows".into()))?,
    )?;
    for _ in 0..nc {
        st.springs.history.push(r.vec3()?);
        st.springs.twist.push(r.f32()?);
        let (force_b, torque_a, torque_b) = (r.vec3()?, r.vec3()?, r.vec3()?);
        st.springs
            .forces
            .push(ContactForce::new(force_b, torque_a, torque_b, r.f32()?));
        st.springs.touching.push(match r.bytes(1)?[0] {
            0 => false,
            1 => true,
            b => {
                return Err(CheckpointError::Malformed(format!(
                    "touching flag {b} is neither 0 nor 1"
                )));
            }
        });
    }
    r.need(np * 4)?;
    for _ in 0..np {
        st.springs.hints.push(r.u32()?);
    }
    r.need(np * 4)?;
    for _ in 0..np {
        st.springs.separation_bound.push(r.f32()?);
    }
    r.finish()
}

pub(super) fn read_mesh_slots(r: &mut Reader<'_>, st: &mut State) -> Result<(), CheckpointError> {
    st.mesh_rebuild_time = r.f64()?;
    if !st.mesh_rebuild_time.is_finite() {
        return Err(CheckpointError::Malformed(
            "non-finite mesh rebuild time".into(),
        ));
    }
    let n = r.count(77)?;
    if n as u64 != st.bodies * MESH_SLOTS as u64 {
        return Err(CheckpointError::Malformed(format!(
            "{n} mesh slots for {} bodies",
            st.bodies
        )));
    }
    for _ in 0..n {
        let (boundary, piece) = (r.u32()?, r.u32()?);
        let touching = match r.bytes(1)?[0] {
            0 => false,
            1 => true,
            b => {
                return Err(CheckpointError::Malformed(format!(
                    "mesh touching flag {b} is neither 0 nor 1"
                )));
            }
        };
        let (normal, history, twist) = (r.vec3()?, r.vec3()?, r.f32()?);
        let (force_b, torque_a, torque_b) = (r.vec3()?, r.vec3()?, r.vec3()?);
        let force = ContactForce::new(force_b, torque_a, torque_b, r.f32()?);
        st.mesh_slots.push(MeshSlot {
            boundary,
            piece,
            touching,
            normal,
            history,
            twist,
            force,
        });
    }
    r.finish()
}
