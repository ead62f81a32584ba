//! Plain SVG line charts (no dependency): stacked panels sharing a width, each with its own
//! axes, lines and point markers and a legend. Used by `energy.svg` (`clatter run`) and by the
//! plots of `clatter validate`. `plotters` would add some 20 crates of build time on a
//! two-core machine for a handful of line charts.

use std::fmt::Write as _;

const WIDTH: f64 = 900.0;
const PANEL: f64 = 230.0;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 170.0;
const TOP: f64 = 40.0;
const GAP: f64 = 40.0;
const COLOURS: [&str; 6] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b",
];

/// How a series is drawn.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Style {
    /// A polyline through the points (gaps at non-finite values).
    Line,
    /// A dashed polyline (analytic curves under measured points).
    Dashed,
    /// A circle at each point.
    Points,
}

/// One named series of a panel.
pub struct Series<'a> {
    /// Legend text.
    pub name: &'a str,
    /// Abscissae.
    pub x: &'a [f64],
    /// Ordinates (same length as `x`).
    pub y: &'a [f64],
    /// Line or markers.
    pub style: Style,
    /// The palette entry (`None`: the series' place in its panel), so that a measured curve
    /// and its reference can share a colour.
    pub colour: Option<usize>,
}

impl<'a> Series<'a> {
    /// A solid line.
    pub fn line(name: &'a str, x: &'a [f64], y: &'a [f64]) -> Self {
        Series {
            name,
            x,
            y,
            style: Style::Line,
            colour: None,
        }
    }

    /// A dashed line.
    pub fn dashed(name: &'a str, x: &'a [f64], y: &'a [f64]) -> Self {
        Series {
            name,
            x,
            y,
            style: Style::Dashed,
            colour: None,
        }
    }

    /// Point markers.
    pub fn points(name: &'a str, x: &'a [f64], y: &'a [f64]) -> Self {
        Series {
            name,
            x,
            y,
            style: Style::Points,
            colour: None,
        }
    }

    /// The same series drawn in palette entry `c`.
    pub fn colour(self, c: usize) -> Self {
        Series {
            colour: Some(c),
            ..self
        }
    }
}

/// One panel: a y label, an x label, its series, and whether the y axis is logarithmic.
pub struct Panel<'a> {
    /// Label of the y axis.
    pub y_label: &'a str,
    /// Label of the x axis (empty: none).
    pub x_label: &'a str,
    /// What is drawn.
    pub series: Vec<Series<'a>>,
    /// Log scale on y (values <= 0 are left out).
    pub log: bool,
}

/// The SVG document: a title over `panels` stacked top to bottom.
pub fn chart(title: &str, panels: &[Panel]) -> String {
    let height = TOP + panels.len() as f64 * (PANEL + GAP) + 10.0;
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
    for (k, p) in panels.iter().enumerate() {
        panel(&mut s, k, p);
    }
    s.push_str("</svg>\n");
    s
}

fn panel(s: &mut String, k: usize, p: &Panel) {
    let log = p.log;
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
        xml_escape(p.y_label)
    );
    let map = |v: f64| if log { (v.max(1e-300)).log10() } else { v };
    let values: Vec<f64> = p
        .series
        .iter()
        .flat_map(|se| se.y.iter())
        .filter(|v| v.is_finite() && (!log || **v > 0.0))
        .map(|&v| map(v))
        .collect();
    let (tmin, tmax) = range(p.series.iter().flat_map(|se| se.x.iter().copied()));
    // x: the data's own range, with the round ticks inside it.
    let (tmin, tmax) = pad(tmin, tmax);
    let slack = 1e-9 * (tmax - tmin);
    let xticks: Vec<f64> = nice(tmin, tmax)
        .2
        .into_iter()
        .filter(|t| *t >= tmin - slack && *t <= tmax + slack)
        .collect();
    let (vmin, vmax) = range(values.iter().copied());
    let (vmin, vmax, yticks) = if log {
        let (lo, hi) = pad(vmin, vmax);
        let ticks = (0..=4).map(|i| lo + i as f64 / 4.0 * (hi - lo)).collect();
        (lo, hi, ticks)
    } else {
        nice(vmin, vmax)
    };
    let px = |x: f64| x1 + (x - tmin) / (tmax - tmin) * w;
    let py = |v: f64| y0 + PANEL - (map(v) - vmin) / (vmax - vmin) * PANEL;
    for xt in xticks {
        let x = px(xt);
        let _ = writeln!(
            s,
            "<line x1=\"{x:.1}\" y1=\"{y0}\" x2=\"{x:.1}\" y2=\"{}\" stroke=\"#ddd\"/>",
            y0 + PANEL
        );
        let _ = writeln!(
            s,
            "<text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            y0 + PANEL + 15.0,
            number(xt)
        );
    }
    for vt in yticks {
        let y = y0 + PANEL - (vt - vmin) / (vmax - vmin) * PANEL;
        let _ = writeln!(
            s,
            "<line x1=\"{x1}\" y1=\"{y:.1}\" x2=\"{}\" y2=\"{y:.1}\" stroke=\"#ddd\"/>",
            x1 + w
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
    if !p.x_label.is_empty() {
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            x1 + w / 2.0,
            y0 + PANEL + 32.0,
            xml_escape(p.x_label)
        );
    }
    for (c, se) in p.series.iter().enumerate() {
        let colour = COLOURS[se.colour.unwrap_or(c) % COLOURS.len()];
        let visible = |y: f64| y.is_finite() && !(log && y <= 0.0);
        if se.style == Style::Points {
            for (x, y) in se.x.iter().zip(se.y.iter()) {
                if visible(*y) && x.is_finite() {
                    let _ = writeln!(
                        s,
                        "<circle cx=\"{:.2}\" cy=\"{:.2}\" r=\"3.5\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\"/>",
                        px(*x),
                        py(*y)
                    );
                }
            }
        } else {
            let mut d = String::new();
            let mut pen_down = false;
            for (x, y) in se.x.iter().zip(se.y.iter()) {
                if !visible(*y) || !x.is_finite() {
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
            let dash = if se.style == Style::Dashed {
                " stroke-dasharray=\"6 4\""
            } else {
                ""
            };
            let _ = writeln!(
                s,
                "<path d=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\"{dash}/>",
                d.trim_end()
            );
        }
        legend(s, se, colour, c, x1 + w, y0);
    }
}

/// The legend entry of series number `c` (of a panel whose plot box ends at `right` and
/// starts at `y0`): its marker or line, then its name.
fn legend(s: &mut String, se: &Series, colour: &str, c: usize, right: f64, y0: f64) {
    let ly = y0 + 20.0 + 18.0 * c as f64;
    let lx = right + 15.0;
    if se.style == Style::Points {
        let _ = writeln!(
            s,
            "<circle cx=\"{}\" cy=\"{ly}\" r=\"3.5\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\"/>",
            lx + 12.0
        );
    } else {
        let _ = writeln!(
            s,
            "<line x1=\"{lx}\" y1=\"{ly}\" x2=\"{}\" y2=\"{ly}\" stroke=\"{colour}\" stroke-width=\"2\"{}/>",
            lx + 25.0,
            if se.style == Style::Dashed {
                " stroke-dasharray=\"6 4\""
            } else {
                ""
            }
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\">{}</text>",
        lx + 32.0,
        ly + 4.0,
        xml_escape(se.name)
    );
}

/// `[lo, hi]` widened when empty or flat.
fn pad(lo: f64, hi: f64) -> (f64, f64) {
    if hi - lo <= f64::EPSILON * hi.abs().max(1e-300) {
        let d = if hi == 0.0 { 1.0 } else { hi.abs() * 0.1 };
        (lo - d, hi + d)
    } else {
        (lo, hi)
    }
}

/// An axis from `lo` to `hi` widened to round numbers, and its ticks (4 to 10 of them, at
/// 1, 2, 2.5 or 5 times a power of ten).
fn nice(lo: f64, hi: f64) -> (f64, f64, Vec<f64>) {
    let (lo, hi) = pad(lo, hi);
    let raw = (hi - lo) / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|f| f * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let (a, b) = ((lo / step).floor(), (hi / step).ceil());
    let ticks = (0..=(b - a) as i64)
        .map(|k| (a + k as f64) * step)
        .map(|t| if t.abs() < 1e-9 * step { 0.0 } else { t })
        .collect();
    (a * step, b * step, ticks)
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

/// `s` with XML's special characters escaped.
pub fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
