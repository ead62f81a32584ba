//! Progress lines for batch jobs (`--log-every`): when standard error is not a terminal (a
//! Slurm job, `nohup`, CI, a pipe), `run`, `resume` and `render` print a fixed-width thermo
//! line every so often instead of the progress bar, and `validate` a line per check; see
//! docs/outputs.md, "Logs for batch jobs".
//!
//! The lines only read the state (at the steps they are printed at): they never change what
//! is simulated.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often a progress line is printed.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum LogEvery {
    /// Every this much wall-clock time (and at the end).
    Wall(Duration),
    /// At every multiple of this many steps (and at the end).
    Steps(u64),
}

/// The interval when stderr is not a terminal and `--log-every` is not given.
pub const DEFAULT_LOG_EVERY: LogEvery = LogEvery::Wall(Duration::from_secs(10));

/// What `--log-every` accepts (for its error message).
pub const LOG_EVERY_SYNTAX: &str =
    "a number of steps (500) or a wall-clock time with a unit: 10s, 2.5m, 1h";

/// Parses `--log-every`: `N` (steps) or a wall-clock time `Ts`, `Tm`, `Th`.
pub fn parse_log_every(s: &str) -> Result<LogEvery, String> {
    let t = s.trim();
    let bad = |why: &str| format!("'{s}' {why}: expected {LOG_EVERY_SYNTAX}");
    if let Ok(n) = t.parse::<u64>() {
        if n == 0 {
            return Err(bad("is zero"));
        }
        return Ok(LogEvery::Steps(n));
    }
    let (num, unit) = match t.char_indices().last() {
        Some((i, 's')) => (&t[..i], 1.0),
        Some((i, 'm')) => (&t[..i], 60.0),
        Some((i, 'h')) => (&t[..i], 3600.0),
        _ => return Err(bad("is not an interval")),
    };
    let x: f64 = num.trim().parse().map_err(|_| bad("is not an interval"))?;
    let secs = x * unit;
    if !(secs.is_finite() && secs > 0.0 && secs < 1e9) {
        return Err(bad("is not a positive time"));
    }
    Ok(LogEvery::Wall(Duration::from_secs_f64(secs)))
}

/// The `--log-every` option of `run`, `resume`, `render` and `validate`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct LogArgs {
    /// Print a progress line every N steps (e.g. 500) or every T of wall-clock time (10s,
    /// 2.5m, 1h), and one at the end. Default when standard error is not a terminal (batch
    /// jobs, pipes): 10s; on a terminal the progress bar shows instead, unless this option is
    /// given. --quiet turns the lines off.
    #[arg(long, value_name = "N|T", value_parser = parse_log_every)]
    pub log_every: Option<LogEvery>,
}

impl LogArgs {
    /// The interval of the progress lines, or `None` when none are printed: `--quiet`, or a
    /// terminal (the progress bar's) without an explicit `--log-every`.
    pub fn lines(&self, quiet: bool) -> Option<LogEvery> {
        match self.log_every {
            _ if quiet => None,
            Some(every) => Some(every),
            None if std::io::stderr().is_terminal() => None,
            None => Some(DEFAULT_LOG_EVERY),
        }
    }
}

/// A wall-clock duration in a 9-character column: `12.3 s`, `45.0 min`, `3.25 h`.
pub fn clock(secs: f64) -> String {
    if !secs.is_finite() || secs < 0.0 {
        "-".into()
    } else if secs < 100.0 {
        format!("{secs:.1} s")
    } else if secs < 6000.0 {
        format!("{:.1} min", secs / 60.0)
    } else {
        format!("{:.2} h", secs / 3600.0)
    }
}

/// What one line reports about the state after a step.
#[derive(Copy, Clone, Debug)]
pub struct Sample {
    /// Step count of the world.
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// Kinetic energy (translation and rotation), J.
    pub kinetic: f64,
    /// Touching contacts.
    pub contacts: usize,
}

/// The steps a GPU run (which otherwise goes on without stopping) runs at first in wall-clock
/// mode, before it has a rate to aim at the next line with.
const FIRST_CHUNK: u64 = 100;

/// The thermo lines of one run from `start` to `total` steps.
pub struct Thermo {
    every: LogEvery,
    total: u64,
    width: usize,
    started: Instant,
    last_at: Instant,
    last_step: u64,
    /// Steps per second between the last two lines (none before the first line).
    rate: Option<f64>,
    printed: bool,
}

impl Thermo {
    /// The lines of a run at step `start` going to step `total`.
    pub fn new(every: LogEvery, start: u64, total: u64) -> Thermo {
        let now = Instant::now();
        Thermo {
            every,
            total,
            width: total.to_string().len().max(5),
            started: now,
            last_at: now,
            last_step: start,
            rate: None,
            printed: false,
        }
    }

    /// The header line.
    pub fn header(&self) -> String {
        format!(
            "{:>w$}  {:>11}  {:>9}  {:>11}  {:>9}  {:>9}  {:>9}",
            "step/total",
            "time_s",
            "steps/s",
            "kinetic_J",
            "contacts",
            "elapsed",
            "ETA",
            w = 2 * self.width + 1
        )
    }

    /// The furthest step a run at step `s` may go to before a line can be due: the next
    /// multiple of N, or in wall-clock mode about where the next line falls at the rate so
    /// far (a GPU run stops there; the CPU stops more often anyway).
    pub fn stop_before(&self, s: u64) -> u64 {
        match self.every {
            LogEvery::Steps(n) => (s / n + 1) * n,
            LogEvery::Wall(d) => {
                let since = self.last_at.elapsed().as_secs_f64();
                let done = s.saturating_sub(self.last_step);
                let rate = if done > 0 && since > 0.0 {
                    done as f64 / since
                } else {
                    match self.rate {
                        Some(r) => r,
                        None => return s + FIRST_CHUNK,
                    }
                };
                let left = (d.as_secs_f64() - since).max(0.0);
                s + ((rate * left) as u64).max(1)
            }
        }
    }

    /// Whether a line is due after step `s`.
    pub fn due(&self, s: u64) -> bool {
        s != self.last_step
            && match self.every {
                LogEvery::Steps(n) => s.is_multiple_of(n),
                LogEvery::Wall(d) => self.last_at.elapsed() >= d,
            }
    }

    /// Prints the line of `x` (the header first, once).
    pub fn line(&mut self, x: Sample) {
        if !self.printed {
            eprintln!("{}", self.header());
            self.printed = true;
        }
        let now = Instant::now();
        let text = self.format(x, now);
        eprintln!("{text}");
        let secs = now.duration_since(self.last_at).as_secs_f64();
        if x.step > self.last_step && secs > 0.0 {
            self.rate = Some((x.step - self.last_step) as f64 / secs);
        }
        self.last_at = now;
        self.last_step = x.step;
    }

    /// The last line, after the last step, unless that step's line is printed already.
    pub fn finish(&mut self, x: Sample) {
        if !self.printed || x.step != self.last_step {
            self.line(x);
        }
    }

    /// The line of `x` at `now`: the rate since the previous line, the ETA at that rate.
    fn format(&self, x: Sample, now: Instant) -> String {
        let secs = now.duration_since(self.last_at).as_secs_f64().max(1e-9);
        let rate = x.step.saturating_sub(self.last_step) as f64 / secs;
        let left = self.total.saturating_sub(x.step) as f64;
        let eta = if left == 0.0 { 0.0 } else { left / rate };
        format!(
            "{:>w$}/{:>w$}  {:>11.4e}  {:>9}  {:>11.4e}  {:>9}  {:>9}  {:>9}",
            x.step,
            self.total,
            x.time,
            // Within the column also on a first line right after the start.
            if rate < 1e6 {
                format!("{rate:.1}")
            } else {
                format!("{rate:.3e}")
            },
            x.kinetic,
            x.contacts,
            clock(now.duration_since(self.started).as_secs_f64()),
            clock(eta),
            w = self.width
        )
    }
}

/// The lines of `clatter validate`: one per check done, and in wall-clock mode one while a
/// long check runs.
pub struct SuiteLog {
    every: LogEvery,
    total: usize,
    started: Instant,
    state: Mutex<SuiteState>,
}

struct SuiteState {
    printed: bool,
    last_at: Instant,
    check: String,
    done: usize,
    check_started: Instant,
}

impl SuiteLog {
    /// The lines of a suite of `total` checks.
    pub fn new(every: LogEvery, total: usize) -> SuiteLog {
        let now = Instant::now();
        SuiteLog {
            every,
            total,
            started: now,
            state: Mutex::new(SuiteState {
                printed: false,
                last_at: now,
                check: String::new(),
                done: 0,
                check_started: now,
            }),
        }
    }

    /// A check starts.
    pub fn begin(&self, check: &str) {
        let mut st = self.state.lock().unwrap_or_else(|e| e.into_inner());
        st.check = check.to_string();
        st.check_started = Instant::now();
    }

    /// Called as the check steps: a `running` line when the wall-clock interval has passed.
    pub fn tick(&self) {
        let LogEvery::Wall(d) = self.every else {
            return;
        };
        let mut st = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if st.last_at.elapsed() >= d {
            self.print(&mut st, "running", "");
        }
    }

    /// The check begun last is done with `rows` rows, `failed` of them failing and `differ`
    /// of them outside their tolerance where clatter is documented to differ from the
    /// published data (`DIFFERS` rows, which do not fail the suite).
    pub fn end(&self, rows: usize, failed: usize, differ: usize) {
        let mut st = self.state.lock().unwrap_or_else(|e| e.into_inner());
        st.done += 1;
        self.print(
            &mut st,
            "done",
            &format!("{rows:>6}  {failed:>6}  {differ:>6}"),
        );
    }

    fn print(&self, st: &mut SuiteState, status: &str, rows: &str) {
        if !st.printed {
            eprintln!(
                "{:<20}  {:>4}/{:<4}  {:<7}  {:>9}  {:>9}  {:>6}  {:>6}  {:>6}",
                "check", "done", "all", "status", "check", "elapsed", "rows", "failed", "differ"
            );
            st.printed = true;
        }
        let line = format!(
            "{:<20}  {:>4}/{:<4}  {:<7}  {:>9}  {:>9}  {rows}",
            st.check,
            st.done,
            self.total,
            status,
            clock(st.check_started.elapsed().as_secs_f64()),
            clock(self.started.elapsed().as_secs_f64()),
        );
        eprintln!("{}", line.trim_end());
        st.last_at = Instant::now();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals() {
        assert_eq!(parse_log_every("500"), Ok(LogEvery::Steps(500)));
        assert_eq!(
            parse_log_every("10s"),
            Ok(LogEvery::Wall(Duration::from_secs(10)))
        );
        assert_eq!(
            parse_log_every("2.5m"),
            Ok(LogEvery::Wall(Duration::from_secs(150)))
        );
        assert_eq!(
            parse_log_every(" 1h "),
            Ok(LogEvery::Wall(Duration::from_secs(3600)))
        );
        for bad in [
            "", "0", "-5", "0s", "-1s", "10x", "s", "1.5", "nans", "infs", "1e30h",
        ] {
            assert!(parse_log_every(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn columns_line_up() {
        let t = Thermo::new(LogEvery::Steps(100), 0, 40000);
        let x = Sample {
            step: 1200,
            time: 0.12,
            kinetic: 3.4567e-2,
            contacts: 1834,
        };
        let line = t.format(x, t.started + Duration::from_secs(2));
        assert_eq!(
            line,
            " 1200/40000    1.2000e-1      600.0    3.4567e-2       1834      2.0 s     64.7 s"
        );
        assert_eq!(line.len(), t.header().len(), "{}\n{line}", t.header());
        // A first line right after the start: a huge rate still fits its column.
        let fast = t.format(x, t.started + Duration::from_nanos(10));
        assert_eq!(fast.len(), t.header().len(), "{fast}");
        assert_eq!(clock(3.44), "3.4 s");
        assert_eq!(clock(600.0), "10.0 min");
        assert_eq!(clock(9000.0), "2.50 h");
    }

    #[test]
    fn step_mode_stops_at_multiples() {
        let t = Thermo::new(LogEvery::Steps(5), 3, 23);
        assert_eq!(t.stop_before(3), 5);
        assert_eq!(t.stop_before(5), 10);
        assert!(t.due(5) && t.due(10) && !t.due(7) && !t.due(3));
    }
}
