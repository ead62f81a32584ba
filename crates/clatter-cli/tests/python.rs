//! The Python package's test suite (python/tests, pytest), run by `cargo test`: builds and
//! installs the package with pip (maturin through pip's build isolation) into a virtual
//! environment under target/tmp, then runs pytest with this build's `clatter` binary for the
//! comparisons with the command line.
//!
//! Needs python3 with pip and venv; numpy, pytest, matplotlib and meshio are installed into
//! the environment from PyPI (kept between runs, like the extension's build directory
//! `target/tmp/python-build`, so a second run only re-links what changed). Without python3 the
//! test says so and passes, except with `CI` set, where it fails.

use std::path::{Path, PathBuf};
use std::process::Command;

fn in_ci() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty())
}

/// Runs `cmd`, panicking with what it printed when it fails.
fn run(what: &str, cmd: &mut Command) {
    eprintln!("python tests: {what}");
    let status = cmd
        .status()
        .unwrap_or_else(|e| panic!("{what}: cannot start {:?}: {e}", cmd.get_program()));
    assert!(status.success(), "{what} failed ({status})");
}

#[test]
fn python_package_tests() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let root = root.canonicalize().expect("repository root");
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let usable = Command::new(&python)
        .args(["-c", "import venv, ensurepip"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !usable {
        let msg = format!(
            "`{python}` with the venv and ensurepip modules is needed to build and test the Python package (Debian: apt-get install python3-venv)"
        );
        if in_ci() {
            panic!("{msg}; CI is set, so this fails instead of skipping");
        }
        eprintln!("skipped: {msg}");
        return;
    }
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let venv = tmp.join("python-venv");
    let py = venv.join("bin").join("python");
    if !py.exists() {
        run(
            "create the virtual environment",
            Command::new(&python).args(["-m", "venv"]).arg(&venv),
        );
    }
    let pip = |args: &[&str]| {
        let mut c = Command::new(&py);
        c.args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
        ])
        .args(args)
        .current_dir(&root);
        c
    };
    run(
        "pip install numpy pytest matplotlib meshio",
        &mut pip(&["numpy", "pytest", "matplotlib", "meshio"]),
    );
    run(
        "pip install ./python (builds the extension with maturin)",
        pip(&["--force-reinstall", "--no-deps", "./python"])
            .env("CARGO_TARGET_DIR", tmp.join("python-build")),
    );
    // From python/tests, so that the source tree's python/clatter does not shadow the
    // installed package.
    run(
        "pytest python/tests",
        Command::new(&py)
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "."])
            .current_dir(root.join("python").join("tests"))
            .env("CLATTER_BIN", env!("CARGO_BIN_EXE_clatter"))
            .env("MPLBACKEND", "Agg"),
    );
}
