//! `clatter validate`: the standard DEM verification suite (docs/validation.md).
//!
//! Every check builds a [`World`] through the library API, steps it on the chosen backend
//! ([`Ctx::sim`]) and compares what it measures with a truth that does not come from clatter:
//! a closed form (Hertz theory, rigid-body impulse ratios, free fall, slip to roll, torque-free
//! precession) or an independent f64 integration of the same contact law ([`mod@reference`]).
//! One [`Row`] per compared quantity; the command prints the table, writes `validation.json`
//! and one SVG plot per check with `--out`, and fails unless every row passes.

mod chung_ooi;
mod conservation;
mod mfix;
mod mfix_stack_roll;
mod mindlin;
mod pile;
mod ranks;
mod reference;
mod restitution;
mod sphere_floor;

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context as _;
use clatter::World;
use clatter::domain::Comm;
use clatter_backend::{Device, Readback, Stepper};
use clatter_gpu::GpuContext;

use crate::args::{Pipeline, Progress};
use crate::backend::Backend;
use crate::log::SuiteLog;
use crate::output::AtomicFile;

/// The exit status of `clatter validate` when some row fails (1: an error stopped the suite;
/// 3 is `clatter run`'s blow-up status).
pub const FAILED_EXIT: u8 = 4;

/// Some row failed (the table and summary line are already printed).
#[derive(Debug)]
pub struct Failed;

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "some validation rows failed")
    }
}

impl std::error::Error for Failed {}

/// How a row's error is computed (and so what its tolerance means).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// `|measured - expected| / |expected|`.
    Relative,
    /// `|measured - expected| / scale`, the scale named in the row's note (e.g. the incident
    /// slip speed, for quantities that cross zero).
    Normalised,
    /// `|measured - expected|` (ranges: `expected` is the middle, the tolerance the half
    /// width).
    Absolute,
}

impl ErrorKind {
    fn name(self) -> &'static str {
        match self {
            ErrorKind::Relative => "relative",
            ErrorKind::Normalised => "normalised",
            ErrorKind::Absolute => "absolute",
        }
    }
}

/// One compared quantity.
#[derive(Clone, Debug)]
pub struct Row {
    /// Check name, e.g. `chung-ooi-4`.
    pub check: String,
    /// The case within the check, e.g. `theta=30deg`.
    pub case: String,
    /// What is compared, with its unit.
    pub quantity: String,
    /// The truth.
    pub expected: f64,
    /// What clatter gave.
    pub measured: f64,
    /// The error ([`ErrorKind`]).
    pub error: f64,
    /// The largest error that passes.
    pub tolerance: f64,
    /// How `error` is computed.
    pub kind: ErrorKind,
    /// Where the truth comes from (closed form, f64 ODE, ...).
    pub truth: String,
    /// The time step the world ran with, s.
    pub dt: f64,
    /// Set on a row against published data that clatter's law is documented not to
    /// reproduce (docs/validation.md, "Known differences"): why. Such a row, when outside its
    /// tolerance, reads `DIFFERS` instead of `FAIL` and does not fail the suite, but is
    /// counted and named in the verdict.
    pub known: Option<&'static str>,
}

impl Row {
    /// Whether the row is within its tolerance.
    pub fn pass(&self) -> bool {
        self.error.is_finite() && self.error <= self.tolerance
    }

    /// Outside its tolerance and not a documented difference: fails the suite.
    pub fn fails(&self) -> bool {
        !self.pass() && self.known.is_none()
    }

    /// Outside its tolerance where clatter is documented to differ from the published data.
    pub fn differs(&self) -> bool {
        !self.pass() && self.known.is_some()
    }

    /// The row marked as a documented difference from the published data (see
    /// [`Row::known`]).
    pub fn known(mut self, why: &'static str) -> Row {
        self.known = Some(why);
        self
    }

    /// A row with a relative error.
    #[allow(clippy::too_many_arguments)]
    pub fn relative(
        check: &str,
        case: &str,
        quantity: &str,
        expected: f64,
        measured: f64,
        tolerance: f64,
        truth: &str,
        dt: f64,
    ) -> Row {
        Row {
            check: check.into(),
            case: case.into(),
            quantity: quantity.into(),
            expected,
            measured,
            error: (measured - expected).abs() / expected.abs(),
            tolerance,
            kind: ErrorKind::Relative,
            truth: truth.into(),
            dt,
            known: None,
        }
    }

    /// A row whose error is normalised by `scale`.
    #[allow(clippy::too_many_arguments)]
    pub fn normalised(
        check: &str,
        case: &str,
        quantity: &str,
        expected: f64,
        measured: f64,
        scale: f64,
        tolerance: f64,
        truth: &str,
        dt: f64,
    ) -> Row {
        Row {
            check: check.into(),
            case: case.into(),
            quantity: quantity.into(),
            expected,
            measured,
            error: (measured - expected).abs() / scale.abs(),
            tolerance,
            kind: ErrorKind::Normalised,
            truth: truth.into(),
            dt,
            known: None,
        }
    }

    /// A row that passes when `measured` lies in `[lo, hi]`.
    #[allow(clippy::too_many_arguments)]
    pub fn range(
        check: &str,
        case: &str,
        quantity: &str,
        lo: f64,
        hi: f64,
        measured: f64,
        truth: &str,
        dt: f64,
    ) -> Row {
        let mid = 0.5 * (lo + hi);
        Row {
            check: check.into(),
            case: case.into(),
            quantity: quantity.into(),
            expected: mid,
            measured,
            error: (measured - mid).abs(),
            tolerance: 0.5 * (hi - lo),
            kind: ErrorKind::Absolute,
            truth: truth.into(),
            dt,
            known: None,
        }
    }

    /// A row that passes when `|measured| <= tolerance` (a drift that should be zero).
    pub fn bound(
        check: &str,
        case: &str,
        quantity: &str,
        measured: f64,
        tolerance: f64,
        truth: &str,
        dt: f64,
    ) -> Row {
        Row {
            check: check.into(),
            case: case.into(),
            quantity: quantity.into(),
            expected: 0.0,
            measured,
            error: measured.abs(),
            tolerance,
            kind: ErrorKind::Absolute,
            truth: truth.into(),
            dt,
            known: None,
        }
    }
}

/// What a check hands back: its rows and its plot.
pub struct Outcome {
    /// The compared quantities.
    pub rows: Vec<Row>,
    /// `(file name, SVG text)`.
    pub plots: Vec<(String, String)>,
}

/// The options of `clatter validate`.
#[derive(clap::Args, Debug)]
#[command(
    mut_arg("threads", |a| a.help("Worker threads (default: all cores)")),
    mut_arg("backend", |a| a.help("Which pipeline steps the worlds: gpu, cpu, or auto (the GPU when a hardware adapter is found, else the CPU, saying which and why)")),
    mut_arg("quiet", |a| a.help("Print only the table, the verdict and errors (no progress on stderr)")),
)]
pub struct ValidateArgs {
    /// `--threads`, and which pipeline steps the worlds.
    #[command(flatten)]
    pub pipeline: Pipeline,
    /// Write validation.json and one SVG plot per check into DIR (created if needed).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Fewer cases, shorter runs, fewer bodies (under a minute on two cores).
    #[arg(long)]
    pub quick: bool,
    /// Run only the checks whose name contains one of these (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "NAME")]
    pub only: Vec<String>,
    /// `--quiet` (nothing on stderr but errors) and the progress lines' interval (`None`:
    /// the plain per-check lines; see [`crate::log`]).
    #[command(flatten)]
    pub progress: Progress,
}

/// What every check needs: the suite's size and the backend that steps its worlds.
pub struct Ctx {
    /// Fewer cases, shorter runs, fewer bodies.
    pub quick: bool,
    gpu: Option<Arc<GpuContext>>,
    quiet: bool,
    log: Option<Arc<SuiteLog>>,
    /// The MPI ranks the suite runs on (`None`: one process): the checks of
    /// [`ranks::ON_RANKS`] step their worlds decomposed over them ([`Ctx::spread`]).
    ranks: Option<Rc<dyn Comm>>,
}

/// A world and the pipeline that steps it.
pub struct Sim {
    /// The world, up to date after every [`Sim::step`].
    pub world: World,
    stepper: Stepper,
    log: Option<Arc<SuiteLog>>,
}

impl Sim {
    /// `n` steps, the bodies read back after them.
    pub fn step(&mut self, n: u64) -> anyhow::Result<()> {
        self.stepper
            .step(&mut self.world, n, Readback::Bodies)
            .context("stepping a validation world")?;
        if let Some(l) = &self.log {
            l.tick();
        }
        Ok(())
    }

    /// Hands a changed world (e.g. a kicked body) to the pipeline: the contact list and its
    /// springs are brought up to date from the pipeline first, then the whole world is
    /// restarted from the host's copy.
    pub fn restart_with(&mut self, change: impl FnOnce(&mut World)) -> anyhow::Result<()> {
        self.stepper
            .sync(&mut self.world)
            .context("reading a validation world back")?;
        change(&mut self.world);
        self.stepper
            .restart(&self.world)
            .context("restarting a validation world")?;
        Ok(())
    }

    /// Steps covering `seconds` of simulated time.
    pub fn run_for(&mut self, seconds: f64) -> anyhow::Result<()> {
        let n = (seconds / self.world.dt as f64).ceil().max(0.0) as u64;
        self.step(n)
    }
}

impl Ctx {
    /// A world ready to step on the chosen backend (one process: on MPI ranks only the
    /// checks of [`ranks::ON_RANKS`] run, through [`Ctx::spread`]).
    pub fn sim(&self, world: World) -> anyhow::Result<Sim> {
        if self.ranks.is_some() {
            anyhow::bail!("this check does not run on MPI ranks");
        }
        let stepper = match &self.gpu {
            None => Stepper::Cpu,
            Some(ctx) => {
                clatter_backend::choose(
                    clatter_backend::BackendChoice::Gpu,
                    &world,
                    Device::Shared(ctx.clone()),
                )
                .map_err(|e| anyhow::anyhow!(e.describe(crate::backend::GPU_OPTION)))?
                .stepper
            }
        };
        Ok(Sim {
            world,
            stepper,
            log: self.log.clone(),
        })
    }

    /// A progress line on stderr (none with `--quiet`).
    pub fn progress(&self, what: &str) {
        if !self.quiet {
            eprintln!("  ... {what}");
        }
    }
}

type CheckFn = fn(&Ctx) -> anyhow::Result<Outcome>;

/// The suite, in the order it runs.
fn checks() -> Vec<(&'static str, CheckFn)> {
    vec![
        ("chung-ooi-1", chung_ooi::normal::test1),
        ("chung-ooi-2", chung_ooi::normal::test2),
        ("chung-ooi-3", chung_ooi::normal::test3),
        ("chung-ooi-4", chung_ooi::published::test4),
        ("chung-ooi-5", chung_ooi::published::test5),
        ("chung-ooi-6", chung_ooi::published::test6),
        ("chung-ooi-7", chung_ooi::published::test7),
        ("chung-ooi-8", chung_ooi::published::test8),
        (
            "hertz-plane-alumina-iron",
            chung_ooi::normal::hertz_plane_alumina_iron,
        ),
        (
            "restitution-glass-10mm",
            chung_ooi::normal::restitution_glass_10mm,
        ),
        (
            "oblique-alumina-on-alloy",
            chung_ooi::legacy::oblique_alumina_on_alloy,
        ),
        (
            "oblique-alumina-vt-sweep",
            chung_ooi::legacy::oblique_alumina_vt_sweep,
        ),
        (
            "spin-alumina-on-alloy",
            chung_ooi::legacy::spin_alumina_on_alloy,
        ),
        ("spin-pair-sliding", chung_ooi::legacy::spin_pair_sliding),
        (
            "oblique-unequal-spheres",
            chung_ooi::legacy::oblique_unequal_spheres,
        ),
        (restitution::NAME, restitution::check),
        (mindlin::NAME, mindlin::check),
        ("mfix-dem01", mfix::dem01),
        ("mfix-dem02", mfix::dem02),
        ("mfix-dem03", mfix_stack_roll::dem03),
        ("mfix-dem04", mfix_stack_roll::dem04),
        (sphere_floor::FREE_FALL, sphere_floor::free_fall),
        (sphere_floor::BOUNCE_HEIGHTS, sphere_floor::bounce_heights),
        (
            sphere_floor::TWO_SPHERE_STACK,
            sphere_floor::two_sphere_stack,
        ),
        (sphere_floor::SLIP_TO_ROLL, sphere_floor::slip_to_roll),
        ("energy-gas", conservation::energy_gas),
        ("momentum-periodic", conservation::momentum_periodic),
        ("symmetric-top", conservation::symmetric_top),
        (pile::NAME, pile::check),
    ]
}

/// The GPU the suite runs on for `--backend`: none for `cpu`; for `auto`, a hardware
/// adapter if there is one (saying why not otherwise, unless `quiet`).
fn validation_gpu(backend: Backend, quiet: bool) -> anyhow::Result<Option<Arc<GpuContext>>> {
    Ok(match backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(Arc::new(
            GpuContext::new().context("--backend gpu: no GPU adapter")?,
        )),
        Backend::Auto => match GpuContext::new() {
            Ok(ctx) if !ctx.is_software() => Some(Arc::new(ctx)),
            Ok(ctx) => {
                if !quiet {
                    eprintln!(
                        "backend: cpu (auto: the only GPU adapter, {}, is a software rasteriser; --backend gpu uses it anyway)",
                        ctx.adapter_name()
                    );
                }
                None
            }
            Err(e) => {
                if !quiet {
                    eprintln!("backend: cpu (auto: {e})");
                }
                None
            }
        },
    })
}

/// Runs the suite on one process; `Ok(true)` when every row passes.
pub fn validate(args: ValidateArgs) -> anyhow::Result<bool> {
    validate_on(args, None)
}

/// Runs the suite, on one process (`ranks` `None`) or on MPI ranks (collective: the checks
/// of [`ranks::ON_RANKS`] only, their worlds decomposed over the ranks; every rank finds
/// the same rows, bitwise one process's, and rank 0 prints them and writes the files; an
/// error on any rank stops all, said once by rank 0); `Ok(true)` when every row passes.
pub fn validate_on(args: ValidateArgs, ranks: Option<Rc<dyn Comm>>) -> anyhow::Result<bool> {
    let started = Instant::now();
    let lead = ranks.as_ref().is_none_or(|c| c.rank() == 0);
    let quiet = args.progress.quiet || !lead;
    let gpu = match &ranks {
        None => validation_gpu(args.pipeline.backend, quiet)?,
        Some(comm) if args.pipeline.backend == Backend::Gpu => {
            return crate::cluster::agree(
                &**comm,
                Err(anyhow::anyhow!(
                    "--backend gpu: `clatter validate` on several MPI ranks uses the CPU pipeline (docs/parallel.md)"
                )),
            );
        }
        Some(_) => None,
    };
    let backend = match (&gpu, &ranks) {
        (Some(ctx), _) => format!("gpu ({})", ctx.adapter_name()),
        (None, Some(comm)) => format!("cpu on {} MPI ranks", comm.size()),
        (None, None) => "cpu".to_string(),
    };
    if !quiet {
        eprintln!(
            "clatter validate: backend {backend}, {} suite",
            if args.quick { "quick" } else { "full" }
        );
    }
    let names: Vec<&str> = checks().iter().map(|(n, _)| *n).collect();
    let chosen =
        |name: &str| args.only.is_empty() || args.only.iter().any(|o| name.contains(o.as_str()));
    let ctx = Ctx {
        quick: args.quick,
        gpu,
        quiet,
        log: args.progress.lines().filter(|_| lead).map(|every| {
            Arc::new(SuiteLog::new(
                every,
                names.iter().filter(|&&n| chosen(n)).count(),
            ))
        }),
        ranks,
    };
    ctx.agree(suite_refused(&args, &names, &ctx))?;
    if let Some(dir) = args.out.as_ref().filter(|_| lead) {
        let made =
            std::fs::create_dir_all(dir).with_context(|| format!("create {}", dir.display()));
        ctx.agree(made)?;
    } else {
        ctx.agree(Ok(()))?;
    }
    let mut rows: Vec<Row> = Vec::new();
    let mut timings = Vec::new();
    for (name, check) in checks() {
        if !chosen(name) {
            continue;
        }
        let t0 = Instant::now();
        match &ctx.log {
            Some(l) => l.begin(name),
            None if !quiet => eprintln!("{name} ..."),
            None => {}
        }
        let outcome = ctx.agree(check(&ctx).with_context(|| format!("check {name}")))?;
        let secs = t0.elapsed().as_secs_f64();
        let failed = outcome.rows.iter().filter(|r| r.fails()).count();
        let differ = outcome.rows.iter().filter(|r| r.differs()).count();
        match &ctx.log {
            Some(l) => l.end(outcome.rows.len(), failed, differ),
            None if !quiet => eprintln!(
                "{name}: {}, {failed} failed{} ({secs:.1} s)",
                counted(outcome.rows.len(), "row"),
                if differ > 0 {
                    format!(", {differ} differ from the published data (documented)")
                } else {
                    String::new()
                }
            ),
            None => {}
        }
        timings.push((name, secs));
        let plots = match args.out.as_ref().filter(|_| lead) {
            Some(dir) => write_plots(dir, &outcome.plots),
            None => Ok(()),
        };
        ctx.agree(plots)?;
        rows.extend(outcome.rows);
    }
    let passed = !rows.iter().any(Row::fails);
    if lead {
        let verdict = Verdict {
            rows: &rows,
            timings: &timings,
            backend: &backend,
            ranks: ctx.ranks.as_ref().map(|c| c.size()),
            total: started.elapsed().as_secs_f64(),
        };
        ctx.agree(verdict.report(&args))?;
    } else {
        ctx.agree(Ok(()))?;
    }
    Ok(passed)
}

/// Why the suite asked for cannot run: an `--only` name that names no check, or checks
/// that do not run on MPI ranks when it runs on ranks.
fn suite_refused(args: &ValidateArgs, names: &[&str], ctx: &Ctx) -> anyhow::Result<()> {
    // An empty name (`--only a,` or `--only ""`) is in every name: it would run the whole
    // suite where one check was asked for.
    if args.only.iter().any(|o| o.trim().is_empty()) {
        anyhow::bail!(
            "--only: an empty check name (a trailing comma?); the checks are {}",
            names.join(", ")
        );
    }
    if let Some(o) = args
        .only
        .iter()
        .find(|o| !names.iter().any(|n| n.contains(o.as_str())))
    {
        anyhow::bail!(
            "--only {o}: no check's name contains it; the checks are {}",
            names.join(", ")
        );
    }
    if let Some(comm) = &ctx.ranks {
        let chosen: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| args.only.is_empty() || args.only.iter().any(|o| n.contains(o.as_str())))
            .collect();
        if let Some(why) = ranks::refused(&chosen, comm.size()) {
            anyhow::bail!(why);
        }
    }
    Ok(())
}

/// Writes a check's plots into `dir`.
fn write_plots(dir: &std::path::Path, plots: &[(String, String)]) -> anyhow::Result<()> {
    for (file, svg) in plots {
        let mut f = AtomicFile::create(&dir.join(file))?;
        f.writer().write_all(svg.as_bytes())?;
        f.commit()?;
    }
    Ok(())
}

/// The suite's outcome, for the table, `validation.json` and the verdict line.
struct Verdict<'a> {
    rows: &'a [Row],
    timings: &'a [(&'static str, f64)],
    backend: &'a str,
    /// The MPI ranks it ran on (`None`: one process).
    ranks: Option<usize>,
    /// Seconds the suite took.
    total: f64,
}

impl Verdict<'_> {
    /// Prints the table and the verdict, and writes `validation.json` with `--out`.
    fn report(&self, args: &ValidateArgs) -> anyhow::Result<()> {
        let rows = self.rows;
        print!("{}", table(rows));
        let failed: Vec<&Row> = rows.iter().filter(|r| r.fails()).collect();
        let differ: Vec<&Row> = rows.iter().filter(|r| r.differs()).collect();
        if let Some(dir) = &args.out {
            let mut json = serde_json::json!({
                "clatter_version": env!("CARGO_PKG_VERSION"),
                "backend": self.backend,
                "suite": if args.quick { "quick" } else { "full" },
                "passed": failed.is_empty(),
                "rows_total": rows.len(),
                "rows_failed": failed.len(),
                "rows_known_differences": differ.len(),
                "checks": self.timings.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
                "rows": rows.iter().map(|r| serde_json::json!({
                    "check": r.check,
                    "case": r.case,
                    "quantity": r.quantity,
                    "expected": r.expected,
                    "measured": r.measured,
                    "error": r.error,
                    "error_kind": r.kind.name(),
                    "tolerance": r.tolerance,
                    "pass": r.pass(),
                    "known_difference": r.known,
                    "truth": r.truth,
                    "dt": r.dt,
                })).collect::<Vec<_>>(),
            });
            if let Some(n) = self.ranks {
                json["ranks"] = n.into();
            }
            let mut f = AtomicFile::create(&dir.join("validation.json"))?;
            writeln!(f.writer(), "{}", serde_json::to_string_pretty(&json)?)?;
            f.commit()?;
        }
        let total = self.total;
        if failed.is_empty() {
            println!(
                "validation passed: {} in {} ({total:.1} s){}",
                counted(rows.len(), "row"),
                counted(self.timings.len(), "check"),
                differences(&differ)
            );
        } else {
            let mut checks: Vec<&str> = failed.iter().map(|r| r.check.as_str()).collect();
            checks.dedup();
            println!(
                "validation FAILED: {} of {} failed, in {} ({total:.1} s){}",
                failed.len(),
                counted(rows.len(), "row"),
                checks.join(", "),
                differences(&differ)
            );
        }
        Ok(())
    }
}

/// The verdict's note on the rows that differ from published data as documented, or "".
fn differences(differ: &[&Row]) -> String {
    if differ.is_empty() {
        return String::new();
    }
    let mut checks: Vec<&str> = differ.iter().map(|r| r.check.as_str()).collect();
    checks.dedup();
    format!(
        "; {} of them differ from the published data where clatter's law is documented to differ ({}: docs/validation.md, \"Known differences\")",
        differ.len(),
        checks.join(", ")
    )
}

/// `n` and the noun, plural unless `n` is 1: "1 row", "3 rows".
fn counted(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// The table: one line per row, columns aligned.
pub fn table(rows: &[Row]) -> String {
    let header = [
        "check",
        "case",
        "quantity",
        "expected",
        "measured",
        "error",
        "tolerance",
        "result",
    ];
    let cells: Vec<[String; 8]> = rows
        .iter()
        .map(|r| {
            [
                r.check.clone(),
                r.case.clone(),
                r.quantity.clone(),
                format!("{:.5e}", r.expected),
                format!("{:.5e}", r.measured),
                format!("{:.2e}", r.error),
                format!(
                    "{:.1e}{}",
                    r.tolerance,
                    match r.kind {
                        ErrorKind::Relative => " rel",
                        ErrorKind::Normalised => " norm",
                        ErrorKind::Absolute => " abs",
                    }
                ),
                match (r.pass(), r.known) {
                    (true, _) => "pass",
                    (false, Some(_)) => "DIFFERS",
                    (false, None) => "FAIL",
                }
                .to_string(),
            ]
        })
        .collect();
    let mut width = header.map(str::len);
    for c in &cells {
        for (w, s) in width.iter_mut().zip(c) {
            *w = (*w).max(s.len());
        }
    }
    let mut s = String::new();
    let line = |s: &mut String, c: &[&str]| {
        let mut l = String::new();
        for (k, (w, x)) in width.iter().zip(c).enumerate() {
            if k > 0 {
                l.push_str("  ");
            }
            if (3..7).contains(&k) {
                let _ = write!(l, "{x:>w$}");
            } else {
                let _ = write!(l, "{x:<w$}");
            }
        }
        s.push_str(l.trim_end());
        s.push('\n');
    };
    line(&mut s, &header);
    for c in &cells {
        let refs: Vec<&str> = c.iter().map(String::as_str).collect();
        line(&mut s, &refs);
    }
    s
}
