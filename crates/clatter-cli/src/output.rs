//! Output files: `final.csv`, `trace.csv`, `summary.json` (and, in their own modules, VTK
//! frames, `energy.csv`, checkpoints). Every file is written under a
//! temporary name and renamed into place when complete, so a file with its final name is
//! always whole.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::Context;
use clatter::World;

/// The CSV header of `final.csv` (trace.csv prefixes `step,time,`).
pub const STATE_HEADER: &str = "id,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz";

/// A file being written under `NAME.tmp`, renamed to `NAME` by [`AtomicFile::commit`] and
/// removed if dropped uncommitted.
pub struct AtomicFile {
    tmp: PathBuf,
    path: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Creates `path.tmp` for writing.
    pub fn create(path: &Path) -> anyhow::Result<Self> {
        let mut name = path.file_name().unwrap_or_default().to_os_string();
        name.push(".tmp");
        let tmp = path.with_file_name(name);
        let file =
            File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
        Ok(Self {
            tmp,
            path: path.to_path_buf(),
            writer: Some(BufWriter::with_capacity(1 << 20, file)),
        })
    }

    /// The writer.
    pub fn writer(&mut self) -> &mut BufWriter<File> {
        self.writer.as_mut().expect("writer present until commit")
    }

    /// Flushes, syncs and renames into place.
    pub fn commit(mut self) -> anyhow::Result<()> {
        let writer = self.writer.take().expect("writer present until commit");
        let file = writer
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("cannot write {}", self.tmp.display()))?;
        file.sync_all()
            .with_context(|| format!("cannot sync {}", self.tmp.display()))?;
        std::fs::rename(&self.tmp, &self.path).with_context(|| {
            format!(
                "cannot rename {} to {}",
                self.tmp.display(),
                self.path.display()
            )
        })?;
        // The rename itself is durable only once the directory is synced.
        clatter::checkpoint::sync_dir(&self.path);
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.writer.is_some() {
            self.writer = None;
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes one CSV row per body (`id,x,...,wz`), optionally prefixed by `prefix` (`step,time,`).
/// Bodies removed by a sink have no row (their ids are missing).
pub fn write_state_rows(w: &mut impl Write, world: &World, prefix: &str) -> std::io::Result<()> {
    let mut line = String::with_capacity(256);
    for i in (0..world.len()).filter(|&i| !world.is_removed(i)) {
        use std::fmt::Write as _;
        line.clear();
        let x = world.state.position[i];
        let q = world.user_orientation(i);
        let v = world.state.velocity[i];
        let o = world.state.omega[i];
        let _ = write!(
            line,
            "{prefix}{i},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            x.x, x.y, x.z, q.w, q.x, q.y, q.z, v.x, v.y, v.z, o.x, o.y, o.z
        );
        line.push('\n');
        w.write_all(line.as_bytes())?;
    }
    Ok(())
}

/// Copies the rows of an existing CSV file `src` with header `header` whose first column (the
/// step) is below `before` into `dst`: a resumed run continues the series it was written by.
/// Does nothing when `src` does not exist or has another header.
pub fn carry_rows(
    src: &Path,
    header: &str,
    before: u64,
    dst: &mut impl Write,
) -> anyhow::Result<()> {
    use std::io::BufRead;
    let Ok(file) = File::open(src) else {
        return Ok(());
    };
    let mut lines = std::io::BufReader::new(file).lines();
    if lines.next().transpose()?.as_deref() != Some(header) {
        return Ok(());
    }
    for line in lines {
        let line = line?;
        let step = line.split(',').next().and_then(|s| s.parse::<u64>().ok());
        if step.is_some_and(|s| s < before) {
            dst.write_all(line.as_bytes())?;
            dst.write_all(b"\n")?;
        }
    }
    Ok(())
}

/// The CSV header of `discharge.csv`.
pub const DISCHARGE_HEADER: &str = "step,time,count,mass";

/// `discharge.csv` of a scene with sinks: the bodies removed so far and their mass
/// (cumulative), one row at the first step, at every energy sample step and at the last step.
/// Both columns come from the removed flags ([`clatter::World::discharged`]), so CPU and GPU
/// runs whose trajectories agree write the same rows; a resumed run continues the file.
pub struct DischargeSeries {
    file: AtomicFile,
    last: Option<u64>,
}

impl DischargeSeries {
    /// Creates `path`, keeping the rows of an existing file before step `start`.
    pub fn create(path: &Path, start: u64) -> anyhow::Result<DischargeSeries> {
        let mut file = AtomicFile::create(path)?;
        writeln!(file.writer(), "{DISCHARGE_HEADER}")?;
        if start > 0 {
            carry_rows(path, DISCHARGE_HEADER, start, file.writer())?;
        }
        Ok(DischargeSeries { file, last: None })
    }

    /// Writes the row of the world's current step (once per step).
    pub fn sample(&mut self, world: &World) -> anyhow::Result<()> {
        let d = world.discharged();
        self.record(world.step_count, world.time, d.count, d.mass)
    }

    /// Writes a row computed elsewhere (an MPI run's totals reduced over the ranks,
    /// `clatter::domain::Totals`); a second row of the same step is dropped.
    pub fn record(&mut self, step: u64, time: f64, count: u64, mass: f64) -> anyhow::Result<()> {
        if self.last == Some(step) {
            return Ok(());
        }
        writeln!(self.file.writer(), "{step},{time},{count},{mass}")?;
        self.last = Some(step);
        Ok(())
    }

    /// Renames the file into place.
    pub fn commit(self) -> anyhow::Result<()> {
        self.file.commit()
    }
}
