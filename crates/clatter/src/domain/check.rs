//! The blow-up checks on a decomposed world ([`Domain::check`]): each rank checks the
//! bodies it owns and the contacts it owns (a body pair belongs to the owner of its first
//! body, a wall or mesh contact to its body's), and the verdicts are reduced so that every
//! rank finds the blow-up one process finds on the whole world ([`Health::check`]): the
//! same kind, body, numbers and message. A check step costs a few small reductions,
//! whatever the number of bodies; only a blow-up costs more (two all-gathers of a few
//! hundred bytes a rank).

use super::Domain;
use super::comm::Comm;
use super::rows::{Reader, Writer};
use crate::contact_list::Partner;
use crate::exact_sum::ExactSum;
use crate::health::{
    BlowUp, BlowUpKind, Health, OVERLAP_LIMIT, energy_grows, escape_of, fastest, first_escaped,
    first_non_finite,
};

/// No body (in a reduced minimum of scene ids).
const NONE: u64 = u64::MAX;

/// Where a contact comes in one process's overlap check: its kind (`0` body pairs, `1`
/// walls, `2` meshes), its body's and its other side's scene ids (a mesh contact: `0`), its
/// piece (a mesh contact: its rank among its body's).
type OrderKey = (u8, u32, u32, u32);

impl Domain {
    /// The blow-up checks of `health` on the whole world, `full` or cheap, as
    /// [`Health::check`] runs them on one process (collective; every rank gets the same
    /// verdict). What is reduced, in order, each stage only when the previous passed:
    ///
    /// 1. the kinetic and potential energy of each rank's bodies as exact sums
    ///    ([`ExactSum`]; one element-wise integer sum of `2 x 71` words, 1,136 bytes): the
    ///    totals one process finds, bit for bit, in any order;
    /// 2. when a total is not finite, the lowest id of a non-finite body (a minimum);
    /// 3. when the energy grows past the limit, each rank's fastest body (an all-gather of 16
    ///    bytes a rank, then the fastest, the lowest id of equals);
    /// 4. the lowest id of an escaped body (a minimum);
    /// 5. the deepest overlap ratio of each rank's contacts (a maximum, NaNs left out), and
    ///    when it is past the limit, which contact has it, the first in one process's order
    ///    (an all-gather of 48 bytes a rank).
    ///
    /// The rank that owns the body (or contact) blamed writes the report (its cause is
    /// found from the body's state) and every rank receives it (an all-gather).
    ///
    /// Ghost states owed by an overlapped step are brought first ([`Domain::sync_ghosts`]):
    /// the overlap check reads both bodies of a contact.
    pub fn check(&mut self, health: &Health, comm: &dyn Comm, full: bool) -> Result<(), BlowUp> {
        self.sync_ghosts(comm);
        let world = &self.local;
        // 1. The energies.
        let (ke, pe) = health.energy_sums(world);
        let mut words = ke.to_words();
        words.extend(pe.to_words());
        comm.sum_u64s(&mut words);
        let total = |w: &[u64]| ExactSum::from_words(w).map_or(f64::NAN, |s| s.value());
        let kinetic = total(&words[..ExactSum::WORDS]);
        let potential = total(&words[ExactSum::WORDS..]);
        // 2. A non-finite state.
        if !(kinetic.is_finite() && potential.is_finite()) {
            let mine = first_non_finite(world).map_or(NONE, |i| self.ids[i] as u64);
            let body = comm.min_u64(mine);
            if body != NONE {
                return Err(self.blame(comm, body, |i| {
                    health.blow_up(world, BlowUpKind::NonFinite, i, body as usize, false)
                }));
            }
        }
        // 3. Energy growth.
        let available = health.baseline() - potential;
        if energy_grows(kinetic, available) {
            let (e, i) = fastest(world);
            let mut w = Writer::default();
            w.f64(e);
            w.0.extend(i.map_or(NONE, |i| self.ids[i] as u64).to_le_bytes());
            let (mut body_kinetic, mut body) = (f64::NEG_INFINITY, NONE);
            for m in comm.all_gather(&w.0) {
                let mut r = Reader::new(&m);
                let e = r.f64();
                let id = u64::from(r.u32()) | u64::from(r.u32()) << 32;
                if e > body_kinetic || (e == body_kinetic && id < body) {
                    (body_kinetic, body) = (e, id);
                }
            }
            let body = if body == NONE { 0 } else { body };
            let kind = BlowUpKind::EnergyGrowth {
                kinetic,
                available,
                body_kinetic,
            };
            return Err(self.blame(comm, body, |i| {
                health.blow_up(world, kind.clone(), i, body as usize, false)
            }));
        }
        // 4. Escape.
        let mine = first_escaped(world).map_or(NONE, |i| self.ids[i] as u64);
        let body = comm.min_u64(mine);
        if body != NONE {
            return Err(self.blame(comm, body, |i| {
                health.blow_up(world, escape_of(world, i), i, body as usize, false)
            }));
        }
        // 5. Deep overlaps.
        self.check_overlaps(health, comm, full)
    }

    /// Stage 5 of [`Domain::check`]: the deepest overlap, as one pass over one process's
    /// candidates in order finds it (`health::worst_overlap`): the first candidate, then
    /// each deeper one. So the worst is the first of the deepest (NaN ratios never win),
    /// unless the very first candidate's ratio is NaN, which then stays (and is not past the
    /// limit).
    fn check_overlaps(&self, health: &Health, comm: &dyn Comm, full: bool) -> Result<(), BlowUp> {
        let world = &self.local;
        let candidates = health.overlap_candidates(world, full);
        let ratios: Vec<f32> = candidates
            .iter()
            .map(|(_, c)| health.overlap_ratio(world, c))
            .collect();
        let deepest = ratios
            .iter()
            .filter(|r| !r.is_nan())
            .fold(f32::NEG_INFINITY, |a, &b| a.max(b));
        // Never NaN: the largest of the ratios that are not.
        let deepest = comm.max_f32(deepest);
        if deepest <= OVERLAP_LIMIT {
            return Ok(());
        }
        // Past the limit somewhere: which contact, in one process's order.
        let key = |k: usize| -> OrderKey {
            let ((kind, piece), c) = &candidates[k];
            let other = match c.other {
                Partner::Body(j) => self.ids[j as usize],
                Partner::Wall(w) => w,
                Partner::Boundary(_) => 0,
            };
            (*kind, self.ids[c.body as usize], other, *piece)
        };
        let first = (!candidates.is_empty()).then(|| (key(0), ratios[0].is_nan()));
        let worst = ratios.iter().position(|&r| r == deepest).map(key);
        let mut w = Writer::default();
        for entry in [first, worst.map(|k| (k, false))] {
            let (present, k, flag) = match entry {
                Some((k, flag)) => (1, k, flag),
                None => (0, (0, 0, 0, 0), false),
            };
            for x in [present, k.0 as u32, k.1, k.2, k.3] {
                w.u32(x);
            }
            w.u32(flag as u32);
        }
        let mut first: Option<(OrderKey, bool)> = None;
        let mut worst: Option<OrderKey> = None;
        for m in comm.all_gather(&w.0) {
            let mut r = Reader::new(&m);
            let mut read = || {
                let present = r.u32() != 0;
                let k = (r.u32() as u8, r.u32(), r.u32(), r.u32());
                let flag = r.u32() != 0;
                present.then_some((k, flag))
            };
            if let Some((k, nan)) = read()
                && first.is_none_or(|f| k < f.0)
            {
                first = Some((k, nan));
            }
            if let Some((k, _)) = read()
                && worst.is_none_or(|w| k < w)
            {
                worst = Some(k);
            }
        }
        if first.is_some_and(|f| f.1) {
            return Ok(());
        }
        let Some(worst) = worst else {
            return Ok(());
        };
        let mine = (0..candidates.len()).find(|&k| key(k) == worst);
        Err(self.report(
            comm,
            mine.map(|k| {
                let c = &candidates[k].1;
                let i = c.body as usize;
                let kind = health.deep_overlap(world, c, ratios[k]);
                health.blow_up(world, kind, i, self.ids[i] as usize, true)
            }),
        ))
    }

    /// The blow-up of body `body` (a scene id), written by the rank that owns it from its
    /// local index (`blow_up(i)`), on every rank (collective).
    fn blame(&self, comm: &dyn Comm, body: u64, blow_up: impl FnOnce(usize) -> BlowUp) -> BlowUp {
        let local = u32::try_from(body)
            .ok()
            .and_then(|b| self.ids.binary_search(&b).ok())
            .filter(|&i| !self.local.is_ghost(i));
        self.report(comm, local.map(blow_up))
    }

    /// The one rank's report that is `Some`, on every rank (collective: an all-gather).
    fn report(&self, comm: &dyn Comm, mine: Option<BlowUp>) -> BlowUp {
        let bytes = mine.as_ref().map_or(Vec::new(), encode);
        comm.all_gather(&bytes)
            .iter()
            .find(|m| !m.is_empty())
            .map(|m| decode(m))
            .expect("the body blamed by a blow-up is owned by a rank")
    }
}

/// A blow-up as bytes, for [`Domain::report`].
fn encode(b: &BlowUp) -> Vec<u8> {
    let mut w = Writer::default();
    match &b.kind {
        BlowUpKind::NonFinite => w.u32(0),
        BlowUpKind::EnergyGrowth {
            kinetic,
            available,
            body_kinetic,
        } => {
            w.u32(1);
            w.f64(*kinetic);
            w.f64(*available);
            w.f64(*body_kinetic);
        }
        BlowUpKind::Escaped { wall, distance } => {
            w.u32(2);
            w.u32(*wall);
            w.f32(*distance);
        }
        BlowUpKind::DeepOverlap {
            other,
            depth,
            size,
            limit,
        } => {
            w.u32(3);
            let (tag, x) = match *other {
                Partner::Body(j) => (0, j),
                Partner::Wall(k) => (1, k),
                Partner::Boundary(k) => (2, k),
            };
            w.u32(tag);
            w.u32(x);
            w.f32(*depth);
            w.f32(*size);
            w.f32(*limit);
        }
    }
    w.0.extend((b.body as u64).to_le_bytes());
    w.0.extend(b.step.to_le_bytes());
    w.f64(b.time);
    w.bytes(b.cause.as_bytes());
    w.0
}

/// [`encode`]'s blow-up back.
fn decode(m: &[u8]) -> BlowUp {
    let mut r = Reader::new(m);
    let kind = match r.u32() {
        0 => BlowUpKind::NonFinite,
        1 => BlowUpKind::EnergyGrowth {
            kinetic: r.f64(),
            available: r.f64(),
            body_kinetic: r.f64(),
        },
        2 => BlowUpKind::Escaped {
            wall: r.u32(),
            distance: r.f32(),
        },
        _ => {
            let (tag, x) = (r.u32(), r.u32());
            let other = match tag {
                0 => Partner::Body(x),
                1 => Partner::Wall(x),
                _ => Partner::Boundary(x),
            };
            BlowUpKind::DeepOverlap {
                other,
                depth: r.f32(),
                size: r.f32(),
                limit: r.f32(),
            }
        }
    };
    let body = (u64::from(r.u32()) | u64::from(r.u32()) << 32) as usize;
    let step = u64::from(r.u32()) | u64::from(r.u32()) << 32;
    let time = r.f64();
    let cause = String::from_utf8_lossy(r.bytes()).into_owned();
    BlowUp {
        kind,
        body,
        step,
        time,
        cause,
    }
}
