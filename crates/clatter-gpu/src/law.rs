//! The contact law on the GPU (`shaders/contacts/law.wgsl`) applied to a batch of contact states, so
//! that tests can hold it against its twin, `clatter::law`, on thousands of random contacts.

use crate::batch::{BatchBindings, run_batch};
use crate::{GpuContext, GpuError};
use clatter::contract::{ContactForce, PairContext};
use clatter::law::BodyMotion;
use clatter_geom::narrow::Manifold;
use glam::Vec3;

clatter::gpu_record! {
    /// One contact state (`LawQuery` in law_batch.wgsl).
    pub struct LawQueryRecord {
        pub context: PairContext,
        pub normal: Vec3,
        pub count: u32,
        pub p0: [f32; 4],
        pub p1: [f32; 4],
        pub p2: [f32; 4],
        pub p3: [f32; 4],
        pub a_position: [f32; 4],
        pub a_velocity: [f32; 4],
        pub a_omega: [f32; 4],
        pub b_position: [f32; 4],
        pub b_velocity: [f32; 4],
        pub b_omega: [f32; 4],
        pub hist: [f32; 4],
    }
}

clatter::gpu_record! {
    /// The law's answer (`LawAnswer` in law_batch.wgsl): force and the new springs.
    pub struct LawAnswerRecord {
        pub force: ContactForce,
        pub hist: [f32; 4],
    }
}

/// One contact state: the arguments of `clatter::law::contact_force`.
#[derive(Debug, Clone, Copy)]
pub struct LawQuery {
    /// The pair's law parameters, effective mass and radius, point share and step.
    pub context: PairContext,
    pub manifold: Manifold,
    pub a: BodyMotion,
    pub b: BodyMotion,
    /// Tangential spring.
    pub history: Vec3,
    /// Twisting spring.
    pub twist: f32,
}

fn v4(v: Vec3) -> [f32; 4] {
    [v.x, v.y, v.z, 0.0]
}

impl LawQuery {
    fn record(&self) -> LawQueryRecord {
        let m = &self.manifold;
        let pt = |k: usize| {
            let c = m.points[k];
            [c.point.x, c.point.y, c.point.z, c.depth]
        };
        LawQueryRecord {
            context: self.context,
            normal: m.normal,
            count: m.count as u32,
            p0: pt(0),
            p1: pt(1),
            p2: pt(2),
            p3: pt(3),
            a_position: v4(self.a.position),
            a_velocity: v4(self.a.velocity),
            a_omega: v4(self.a.omega),
            b_position: v4(self.b.position),
            b_velocity: v4(self.b.velocity),
            b_omega: v4(self.b.omega),
            hist: [self.history.x, self.history.y, self.history.z, self.twist],
        }
    }
}

/// Runs `shaders/contacts/law.wgsl`'s `contact_force` on every query: the force, and the new
/// tangential spring (xyz) and twist (w).
pub fn law_batch(
    ctx: &GpuContext,
    queries: &[LawQuery],
) -> Result<Vec<(ContactForce, [f32; 4])>, GpuError> {
    let source = [
        clatter::contract::wgsl_records(),
        // The manifold as narrow.wgsl declares it (no shape bindings needed here).
        "struct Manifold { normal: vec3<f32>, count: u32, points: array<vec4<f32>, 4> }\n".into(),
        include_str!("../shaders/common/common.wgsl").into(),
        include_str!("../shaders/contacts/law.wgsl").into(),
        include_str!("../shaders/test/law_batch.wgsl").into(),
    ]
    .join("\n");
    let records: Vec<LawQueryRecord> = queries.iter().map(LawQuery::record).collect();
    let bindings = BatchBindings {
        input: 0,
        output: 1,
        uniform: None,
    };
    let answers: Vec<LawAnswerRecord> =
        run_batch(ctx, "law batch", source, "law_batch", &records, bindings)?;
    Ok(answers.iter().map(|a| (a.force, a.hist)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_have_the_wgsl_layout() {
        use clatter::contract::{PairParams, layout_mismatch};
        assert_eq!(layout_mismatch::<LawQueryRecord>(), None);
        assert_eq!(layout_mismatch::<LawAnswerRecord>(), None);
        assert_eq!(
            std::mem::size_of::<LawQueryRecord>(),
            std::mem::size_of::<PairContext>() + 4 * 16 + 7 * 16 + 16
        );
        assert_eq!(
            std::mem::size_of::<PairParams>() % 16,
            0,
            "PairParams embeds at any 16-byte offset"
        );
    }
}
