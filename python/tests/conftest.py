"""Shared fixtures: the `clatter` binary for the command-line comparisons, and small scenes."""

import os
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _in_ci() -> bool:
    return bool(os.environ.get("CI"))


def require(condition: bool, why: str) -> None:
    """Skips when `condition` is false, or fails under CI (where everything must run)."""
    if not condition:
        if _in_ci():
            pytest.fail(f"{why} (CI is set, so this fails instead of skipping)")
        pytest.skip(why)


@pytest.fixture(scope="session")
def clatter_bin() -> str:
    """The `clatter` command line: $CLATTER_BIN (set by the cargo test that runs this suite),
    else target/release/clatter, else `clatter` on the PATH."""
    candidates = [os.environ.get("CLATTER_BIN")]
    target = os.environ.get("CARGO_TARGET_DIR") or str(ROOT / "target")
    candidates.append(os.path.join(target, "release", "clatter"))
    candidates.append(shutil.which("clatter"))
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    require(False, "the clatter binary was not found (build it with `cargo build --release -p clatter-cli` or set CLATTER_BIN)")
    return ""


# A pile of spheres and polyhedra (cubes, tetrahedra) in an open box: body-body and body-wall
# contacts with face clipping from the first steps.
PILE = """
[simulation]
steps = 400
dt = 2.0e-5

[[material]]
name = "plastic"
density = 1200.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.4

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

[[shape]]
name = "cube"
polyhedron = { kind = "cube", radius = 0.006 }

[[shape]]
name = "tetra"
polyhedron = { kind = "tetrahedron", radius = 0.007 }

[container]
min = [0.0, 0.0, 0.0]
max = [0.05, 0.05, 0.1]
material = "plastic"
top = false

[[group]]
shape = "ball"
material = "plastic"
lattice = { min = [0.01, 0.01, 0.0049], max = [0.04, 0.04, 0.0049], spacing = 0.0099 }

[[group]]
shape = "cube"
material = "plastic"
lattice = { min = [0.012, 0.012, 0.016], max = [0.036, 0.036, 0.016], spacing = 0.012 }
random_orientation = true
velocity = [0.05, -0.02, -0.3]

[[group]]
shape = "tetra"
material = "plastic"
lattice = { min = [0.012, 0.012, 0.032], max = [0.036, 0.036, 0.032], spacing = 0.016 }
random_orientation = true
angular_velocity = [3.0, 1.0, -2.0]
"""


@pytest.fixture
def pile_file(tmp_path: Path) -> Path:
    p = tmp_path / "pile.toml"
    p.write_text(PILE)
    return p
