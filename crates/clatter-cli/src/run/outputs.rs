//! The files a run writes as it goes ([`Outputs`]): the frame series (trace.csv and the
//! VTK files), energy.csv, discharge.csv, the periodic checkpoint, and at the end
//! final.csv. Each is created before the first step and committed (renamed into place)
//! when complete.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use clatter::World;

use super::Plan;
use crate::energy::EnergySeries;
use crate::output::{AtomicFile, DischargeSeries, STATE_HEADER, carry_rows, write_state_rows};
use crate::vtk;

/// The files a run writes as it goes: the frame series, energy.csv, discharge.csv, and when
/// the next checkpoint is due (rank 0 of an MPI run writes them too, from the gathered
/// world: `crate::cluster`). Everything is created before the first step and committed
/// (renamed into place) when complete.
pub(crate) struct Outputs {
    series: Series,
    pub(crate) energy: Option<EnergySeries>,
    pub(super) discharge: Option<DischargeSeries>,
    /// The next checkpoint is due at simulated time `next * checkpoint_every`.
    pub(crate) next_checkpoint: Option<f64>,
}

impl Outputs {
    /// Creates the outputs of `plan` (none without `--out`) and writes their first rows.
    pub(crate) fn create(plan: &Plan, world: &World, start: u64) -> anyhow::Result<Outputs> {
        let mut series = Series {
            trace: None,
            bodies: None,
            shapes: None,
            boundaries: None,
            contacts: None,
            last_frame: None,
        };
        let mut energy = None;
        let mut discharge: Option<DischargeSeries> = None;
        if let Some(dir) = &plan.out {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create output directory {}", dir.display()))?;
            // The series of the directory go on only when they are this scene's: a checkpoint
            // resumed into another run's directory starts them afresh, not spliced onto rows
            // of another scene.
            let start = if start > 0 && !continues_in(dir, plan) {
                eprintln!(
                    "warning: {} holds the outputs of a run of another scene (its summary.json says so): the series start afresh at step {start}, not continued from that run's rows",
                    dir.display()
                );
                0
            } else {
                start
            };
            if plan.csv && plan.output_every.is_some() {
                let mut f = AtomicFile::create(&dir.join("trace.csv"))?;
                let header = format!("step,time,{STATE_HEADER}");
                writeln!(f.writer(), "{header}")?;
                carry_rows(&dir.join("trace.csv"), &header, start, f.writer())?;
                series.trace = Some(f);
            }
            if plan.vtk {
                series.bodies = Some(vtk::Pvd::continuing(&dir.join("bodies.pvd"), start));
                series.shapes = Some(vtk::Pvd::continuing(&dir.join("shapes.pvd"), start));
                if !world.boundaries.is_empty() {
                    series.boundaries =
                        Some(vtk::Pvd::continuing(&dir.join("boundaries.pvd"), start));
                }
                if plan.contacts {
                    series.contacts = Some(vtk::Pvd::continuing(&dir.join("contacts.pvd"), start));
                }
            }
            series.write(dir, world)?;
            let mut e = EnergySeries::create(Some(&dir.join("energy.csv")), start)?;
            e.sample(world)?;
            energy = Some(e);
            if !world.sinks.is_empty() {
                let mut d = DischargeSeries::create(&dir.join("discharge.csv"), start)?;
                d.sample(world)?;
                discharge = Some(d);
            }
        }
        let half_dt = 0.5 * world.dt as f64;
        let next_checkpoint = plan
            .checkpoint_every
            .map(|t| ((world.time + half_dt) / t).floor() + 1.0);
        Ok(Outputs {
            series,
            energy,
            discharge,
            next_checkpoint,
        })
    }

    /// Writes what is due after step `s`: a frame, energy and discharge rows, a checkpoint.
    pub(crate) fn after_step(
        &mut self,
        plan: &Plan,
        world: &World,
        output_step: bool,
    ) -> anyhow::Result<()> {
        let Some(dir) = &plan.out else {
            return Ok(());
        };
        let s = world.step_count;
        let half_dt = 0.5 * world.dt as f64;
        if output_step {
            self.series.write(dir, world)?;
        }
        if let Some(e) = &mut self.energy
            && s.is_multiple_of(plan.energy_every)
        {
            e.sample(world)?;
        }
        if let Some(d) = &mut self.discharge
            && s.is_multiple_of(plan.energy_every)
        {
            d.sample(world)?;
        }
        if let (Some(t), Some(next)) = (plan.checkpoint_every, &mut self.next_checkpoint)
            && world.time + half_dt >= *next * t
        {
            plan.checkpoint(world, &dir.join("checkpoint.ckpt"))?;
            *next = ((world.time + half_dt) / t).floor() + 1.0;
        }
        Ok(())
    }

    /// The energy and discharge rows of a step whose totals were reduced over MPI ranks
    /// (`clatter::domain::Domain::totals`, bitwise one process's): what [`Outputs::after_step`]
    /// writes at a sample step with no frame or checkpoint, without the world.
    #[cfg(feature = "mpi")]
    pub(crate) fn sample_totals(&mut self, t: &clatter::domain::Totals) -> anyhow::Result<()> {
        if let Some(e) = &mut self.energy {
            e.record(t.step, t.time, t.kinetic, t.potential, t.momentum)?;
        }
        if let Some(d) = &mut self.discharge {
            d.record(t.step, t.time, t.removed, t.removed_mass)?;
        }
        Ok(())
    }

    /// The last step: a VTK frame, an energy sample and a checkpoint even off the period;
    /// commits the series and writes final.csv.
    pub(crate) fn finish(mut self, plan: &Plan, dir: &Path, world: &World) -> anyhow::Result<()> {
        if plan.vtk && self.series.last_frame != Some(world.step_count) {
            self.series.write_vtk(dir, world)?;
        }
        if let Some(f) = self.series.trace.take() {
            f.commit()?;
        }
        if let Some(mut d) = self.discharge.take() {
            d.sample(world)?;
            d.commit()?;
        }
        if let Some(mut e) = self.energy.take() {
            e.sample(world)?;
            e.finish(
                Some(&dir.join("energy.svg")),
                &format!("{}: energy and momentum", plan.scene.source),
            )?;
        }
        if plan.checkpoint_every.is_some() {
            plan.checkpoint(world, &dir.join("checkpoint.ckpt"))?;
        }
        let mut f = AtomicFile::create(&dir.join("final.csv"))?;
        writeln!(f.writer(), "{STATE_HEADER}")?;
        write_state_rows(f.writer(), world, "")?;
        f.commit()
    }
}

/// The frame series of one run: trace.csv and the VTK files.
struct Series {
    trace: Option<AtomicFile>,
    bodies: Option<vtk::Pvd>,
    shapes: Option<vtk::Pvd>,
    boundaries: Option<vtk::Pvd>,
    contacts: Option<vtk::Pvd>,
    last_frame: Option<u64>,
}

impl Series {
    fn write(&mut self, dir: &Path, world: &World) -> anyhow::Result<()> {
        let step = world.step_count;
        if let Some(f) = &mut self.trace {
            write_state_rows(f.writer(), world, &format!("{},{},", step, world.time))?;
        }
        self.write_vtk(dir, world)
    }

    fn write_vtk(&mut self, dir: &Path, world: &World) -> anyhow::Result<()> {
        let step = world.step_count;
        type Writer = fn(&Path, &World) -> std::io::Result<()>;
        let kinds: [(&mut Option<vtk::Pvd>, &str, Writer); 4] = [
            (&mut self.bodies, "bodies", vtk::write_bodies),
            (&mut self.shapes, "shapes", vtk::write_shapes),
            (&mut self.boundaries, "boundaries", vtk::write_boundaries),
            (&mut self.contacts, "contacts", vtk::write_contacts),
        ];
        for (pvd, kind, write) in kinds {
            let Some(pvd) = pvd else { continue };
            let name = format!("{kind}_{step:06}.vtu");
            let path = dir.join(&name);
            write(&path, world).with_context(|| format!("cannot write {}", path.display()))?;
            pvd.push(step, world.time, name).with_context(|| {
                format!("cannot write {}", dir.join(format!("{kind}.pvd")).display())
            })?;
        }
        self.last_frame = Some(step);
        Ok(())
    }
}

/// A fingerprint of a scene's text (64-bit FNV-1a, as hex): `summary.json`'s `scene_hash`,
/// by which a resumed run knows the directory's series are its own scene's.
pub(crate) fn scene_hash(text: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Whether `dir`'s series may be `plan`'s scene's: not when its `summary.json` names
/// another scene by its `scene_hash`. Without a summary (or one written before the field
/// existed) they may be: a killed run of this scene leaves its VTK frames and indexes, and
/// no summary.
fn continues_in(dir: &Path, plan: &Plan) -> bool {
    let Ok(bytes) = std::fs::read(dir.join("summary.json")) else {
        return true;
    };
    let Ok(summary) = serde_json::from_slice::<serde_json::Value>(&bytes) else {
        return true;
    };
    match summary.get("scene_hash").and_then(|h| h.as_str()) {
        Some(h) => h == scene_hash(&plan.scene_text),
        None => true,
    }
}
