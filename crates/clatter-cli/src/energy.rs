//! `energy.csv` and `energy.svg`: the kinetic, potential and total energy and the momentum
//! of a run over time, so that a glance tells whether it behaved (a settling pile: kinetic
//! energy falling by orders of magnitude, total energy only ever decreasing; a blow-up: the
//! kinetic energy climbing along a straight line on the log axis).
//!
//! The plot is a plain SVG (three stacked panels, [`crate::plot`]).

use std::io::Write;
use std::path::Path;

use clatter::World;

use crate::output::AtomicFile;
use crate::plot::{Panel, Series, chart};

/// The CSV header of `energy.csv`.
pub const ENERGY_HEADER: &str = "step,time,kinetic,potential,total,px,py,pz";

/// One sample: step, time, kinetic, potential, total, px, py, pz.
pub type Sample = [f64; 8];

/// The energy series of a run, written to `energy.csv` as it goes.
pub struct EnergySeries {
    file: Option<AtomicFile>,
    samples: Vec<Sample>,
}

impl EnergySeries {
    /// A series written to `path` (or kept in memory only, with `None`), continuing the
    /// samples of an existing `energy.csv` before `step` (a resumed run).
    pub fn create(path: Option<&Path>, step: u64) -> anyhow::Result<EnergySeries> {
        let mut samples = Vec::new();
        let file = match path {
            Some(path) => {
                if step > 0
                    && let Ok(text) = std::fs::read_to_string(path)
                    && text.lines().next() == Some(ENERGY_HEADER)
                {
                    for line in text.lines().skip(1) {
                        let row: Vec<f64> =
                            line.split(',').filter_map(|c| c.parse().ok()).collect();
                        if let Ok(row) = Sample::try_from(row)
                            && (row[0] as u64) < step
                        {
                            samples.push(row);
                        }
                    }
                }
                let mut f = AtomicFile::create(path)?;
                writeln!(f.writer(), "{ENERGY_HEADER}")?;
                for s in &samples {
                    write_row(f.writer(), s)?;
                }
                Some(f)
            }
            None => None,
        };
        Ok(EnergySeries { file, samples })
    }

    /// Records the state of `world`.
    pub fn sample(&mut self, world: &World) -> anyhow::Result<()> {
        let (k, p, m) = world.energies_and_momentum();
        self.record(world.step_count, world.time, k, p, m)
    }

    /// Records a sample computed elsewhere (the GPU's, `clatter_gpu::EnergySample`); a
    /// second sample of the same step is dropped.
    pub fn record(
        &mut self,
        step: u64,
        time: f64,
        k: f64,
        p: f64,
        m: [f64; 3],
    ) -> anyhow::Result<()> {
        let s = [step as f64, time, k, p, k + p, m[0], m[1], m[2]];
        if self.samples.last().is_some_and(|l| l[0] == s[0]) {
            return Ok(());
        }
        if let Some(f) = &mut self.file {
            write_row(f.writer(), &s)?;
        }
        self.samples.push(s);
        Ok(())
    }

    /// Commits `energy.csv` and writes the plot to `svg`.
    pub fn finish(self, svg: Option<&Path>, title: &str) -> anyhow::Result<()> {
        if let Some(f) = self.file {
            f.commit()?;
        }
        if let Some(svg) = svg {
            let mut f = AtomicFile::create(svg)?;
            f.writer()
                .write_all(plot(&self.samples, title).as_bytes())?;
            f.commit()?;
        }
        Ok(())
    }
}

fn write_row(w: &mut impl Write, s: &Sample) -> std::io::Result<()> {
    writeln!(
        w,
        "{},{},{},{},{},{},{},{}",
        s[0] as u64, s[1], s[2], s[3], s[4], s[5], s[6], s[7]
    )
}

/// The SVG: kinetic energy (log scale), potential and total energy relative to the start,
/// momentum components; time on the x axes.
pub fn plot(samples: &[Sample], title: &str) -> String {
    let t: Vec<f64> = samples.iter().map(|r| r[1]).collect();
    let col = |c: usize| samples.iter().map(|r| r[c]).collect::<Vec<f64>>();
    let (p0, e0) = samples.first().map_or((0.0, 0.0), |r| (r[3], r[4]));
    let kinetic = col(2);
    let potential: Vec<f64> = col(3).iter().map(|p| p - p0).collect();
    let total: Vec<f64> = col(4).iter().map(|e| e - e0).collect();
    let (px, py, pz) = (col(5), col(6), col(7));
    chart(
        title,
        &[
            Panel {
                y_label: "kinetic energy (J, log)",
                x_label: "",
                series: vec![Series::line("kinetic", &t, &kinetic)],
                log: true,
            },
            Panel {
                y_label: "energy - value at start (J)",
                x_label: "",
                series: vec![
                    Series::line("potential", &t, &potential),
                    Series::line("total", &t, &total),
                ],
                log: false,
            },
            Panel {
                y_label: "momentum (kg m/s)",
                x_label: "time (s)",
                series: vec![
                    Series::line("px", &t, &px),
                    Series::line("py", &t, &py),
                    Series::line("pz", &t, &pz),
                ],
                log: false,
            },
        ],
    )
}
