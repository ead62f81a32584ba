//! `energy.csv` and `energy.svg`: the kinetic, potential and total energy and the momentum
//! of a run over time, so that a glance tells whether it behaved (a settling pile: kinetic
//! energy falling by orders of magnitude, total energy only ever decreasing; a blow-up: the
//! kinetic energy climbing along a straight line on the log axis).
//!
//! The plot is a plain SVG written here (three stacked panels, no dependency): `plotters`
//! would add some 20 crates of build time on a two-core machine for three line charts.

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use clatter::World;

use crate::output::AtomicFile;

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
        let (k, p) = (world.kinetic_energy(), world.potential_energy());
        let m = world.momentum();
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

const WIDTH: f64 = 900.0;
const PANEL: f64 = 230.0;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 150.0;
const TOP: f64 = 40.0;
const GAP: f64 = 40.0;
const COLOURS: [&str; 3] = ["#1f77b4", "#d62728", "#2ca02c"];

/// The SVG: kinetic energy (log scale), potential and total energy relative to the start,
/// momentum components; time on the x axes.
pub fn plot(samples: &[Sample], title: &str) -> String {
    let height = TOP + 3.0 * PANEL + 3.0 * GAP;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{height}\" viewBox=\"0 0 {WIDTH} {height}\" font-family=\"sans-serif\" font-size=\"12\">"
    );
    let _ = writeln!(s, "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>");
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"22\" font-size=\"15\" text-anchor=\"middle\">{}</text>",
        WIDTH / 2.0,
        xml_escape(title)
    );
    let t: Vec<f64> = samples.iter().map(|r| r[1]).collect();
    let col = |c: usize| samples.iter().map(|r| r[c]).collect::<Vec<f64>>();
    let (p0, e0) = samples.first().map_or((0.0, 0.0), |r| (r[3], r[4]));
    let kinetic = col(2);
    let potential: Vec<f64> = col(3).iter().map(|p| p - p0).collect();
    let total: Vec<f64> = col(4).iter().map(|e| e - e0).collect();
    panel(
        &mut s,
        0,
        "kinetic energy (J, log)",
        &t,
        &[("kinetic", &kinetic)],
        true,
    );
    panel(
        &mut s,
        1,
        "energy - value at start (J)",
        &t,
        &[("potential", &potential), ("total", &total)],
        false,
    );
    panel(
        &mut s,
        2,
        "momentum (kg m/s)",
        &t,
        &[("px", &col(5)), ("py", &col(6)), ("pz", &col(7))],
        false,
    );
    s.push_str("</svg>\n");
    s
}

fn panel(s: &mut String, k: usize, label: &str, t: &[f64], series: &[(&str, &[f64])], log: bool) {
    let y0 = TOP + k as f64 * (PANEL + GAP);
    let (x1, w) = (LEFT, WIDTH - LEFT - RIGHT);
    let _ = writeln!(
        s,
        "<rect x=\"{x1}\" y=\"{y0}\" width=\"{w}\" height=\"{PANEL}\" fill=\"none\" stroke=\"#444\"/>"
    );
    let _ = writeln!(
        s,
        "<text x=\"18\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 18 {})\">{}</text>",
        y0 + PANEL / 2.0,
        y0 + PANEL / 2.0,
        xml_escape(label)
    );
    let map = |v: f64| if log { (v.max(1e-300)).log10() } else { v };
    let values: Vec<f64> = series
        .iter()
        .flat_map(|(_, v)| v.iter())
        .filter(|v| v.is_finite() && (!log || **v > 0.0))
        .map(|&v| map(v))
        .collect();
    let (tmin, tmax) = range(t.iter().copied());
    let (mut vmin, mut vmax) = range(values.iter().copied());
    if vmax - vmin <= f64::EPSILON * vmax.abs().max(1e-300) {
        let pad = if vmax == 0.0 { 1.0 } else { vmax.abs() * 0.1 };
        vmin -= pad;
        vmax += pad;
    }
    let px = |x: f64| x1 + (x - tmin) / (tmax - tmin).max(1e-300) * w;
    let py = |v: f64| y0 + PANEL - (map(v) - vmin) / (vmax - vmin) * PANEL;
    // Ticks: five on each axis.
    for i in 0..=4 {
        let f = i as f64 / 4.0;
        let (xt, vt) = (tmin + f * (tmax - tmin), vmin + f * (vmax - vmin));
        let (x, y) = (x1 + f * w, y0 + PANEL - f * PANEL);
        let _ = writeln!(
            s,
            "<line x1=\"{x:.1}\" y1=\"{y0}\" x2=\"{x:.1}\" y2=\"{}\" stroke=\"#ddd\"/>",
            y0 + PANEL
        );
        let _ = writeln!(
            s,
            "<line x1=\"{x1}\" y1=\"{y:.1}\" x2=\"{}\" y2=\"{y:.1}\" stroke=\"#ddd\"/>",
            x1 + w
        );
        let _ = writeln!(
            s,
            "<text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            y0 + PANEL + 15.0,
            number(xt)
        );
        let shown = if log {
            format!("{:.1e}", 10f64.powf(vt))
        } else {
            number(vt)
        };
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{shown}</text>",
            x1 - 5.0,
            y + 4.0
        );
    }
    if k == 2 {
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">time (s)</text>",
            x1 + w / 2.0,
            y0 + PANEL + 32.0
        );
    }
    for (c, (name, v)) in series.iter().enumerate() {
        let colour = COLOURS[c % COLOURS.len()];
        let mut d = String::new();
        let mut pen_down = false;
        for (x, y) in t.iter().zip(v.iter()) {
            if !y.is_finite() || (log && *y <= 0.0) {
                pen_down = false;
                continue;
            }
            let _ = write!(
                d,
                "{}{:.2},{:.2} ",
                if pen_down { "L" } else { "M" },
                px(*x),
                py(*y)
            );
            pen_down = true;
        }
        let _ = writeln!(
            s,
            "<path d=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\"/>",
            d.trim_end()
        );
        let ly = y0 + 20.0 + 18.0 * c as f64;
        let lx = x1 + w + 15.0;
        let _ = writeln!(
            s,
            "<line x1=\"{lx}\" y1=\"{ly}\" x2=\"{}\" y2=\"{ly}\" stroke=\"{colour}\" stroke-width=\"2\"/>",
            lx + 25.0
        );
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\">{name}</text>",
            lx + 32.0,
            ly + 4.0
        );
    }
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) }
}

/// A tick label: at most four significant digits.
fn number(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&v.abs()) {
        let decimals = (3 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.2e}")
    }
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
