"""Type stubs of the native module `clatter._clatter` (Rust, PyO3). Use it through `clatter`."""

import os
import pathlib
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
GPU_SUPPORT: bool
DEFAULT_SCENE: str
EXAMPLE_SCENES: List[str]
# The material coefficients `Scene.material` takes as keywords, in the table's order: one
# dict each with "name" (str), "default" (float), "range" (str), "unit" (str), "doc" (str).
MATERIAL_COEFFICIENTS: List[Dict[str, Union[str, float]]]

PathLike = Union[str, os.PathLike[str]]
ArrayLike = npt.ArrayLike

class SceneError(ValueError):
    """An invalid scene; str(e) is `clatter run`'s message."""

    file: str
    line: Optional[int]
    column: Optional[int]
    field: Optional[str]
    message: str

class CheckpointError(ValueError): ...
class SimulationError(RuntimeError):
    """A run that blew up: `clatter run`'s report, and its parts."""

    kind: str
    body: int
    step: int
    time: float
    cause: str

class BackendError(RuntimeError): ...
class QueryError(ValueError): ...

class ParsedScene:
    """A validated scene and its TOML text."""

    @staticmethod
    def from_file(path: PathLike) -> ParsedScene: ...
    @staticmethod
    def from_toml(text: str, source: str = "<string>") -> ParsedScene: ...
    @staticmethod
    def example(name: str) -> ParsedScene: ...
    @property
    def text(self) -> str: ...
    @property
    def source(self) -> str: ...
    @property
    def n_bodies(self) -> int: ...
    @property
    def n_walls(self) -> int: ...
    @property
    def materials(self) -> List[str]: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def notes(self) -> List[str]: ...
    @property
    def duration(self) -> Optional[float]: ...
    @property
    def steps(self) -> int: ...

class Simulation:
    """A scene being stepped on the CPU or the GPU; state as numpy arrays (copies)."""

    def __init__(
        self,
        scene: object,
        backend: str = "auto",
        threads: Optional[int] = None,
    ) -> None:
        """`scene`: a clatter.Scene or a path; `backend`: "auto", "cpu" or "gpu";
        `threads`: CPU workers (default all cores; results are identical for any count)."""
    @staticmethod
    def from_checkpoint(
        path: PathLike, backend: str = "auto", threads: Optional[int] = None
    ) -> Simulation: ...
    def step(self, n: int = 1) -> None:
        """Advances n steps with the GIL released; raises SimulationError on a blow-up."""
    @property
    def time(self) -> float: ...
    @property
    def step_count(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def gravity(self) -> npt.NDArray[np.float32]: ...
    @property
    def n_bodies(self) -> int: ...
    def __len__(self) -> int: ...
    @property
    def backend(self) -> str: ...
    @property
    def backend_reason(self) -> str: ...
    @property
    def source(self) -> str: ...
    @property
    def scene_toml(self) -> str: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """(N, 3) centres of mass, m, float64 (positions are kept to 48 bits: 3.6e-13 m at 100 m). Settable."""
    @positions.setter
    def positions(self, value: ArrayLike) -> None: ...
    @property
    def orientations(self) -> npt.NDArray[np.float32]:
        """(N, 4) unit quaternions w, x, y, z in the authored frame."""
    @property
    def velocities(self) -> npt.NDArray[np.float32]:
        """(N, 3) m/s. Settable."""
    @velocities.setter
    def velocities(self, value: ArrayLike) -> None: ...
    @property
    def angular_velocities(self) -> npt.NDArray[np.float32]:
        """(N, 3) rad/s, world frame. Settable."""
    @angular_velocities.setter
    def angular_velocities(self, value: ArrayLike) -> None: ...
    @property
    def masses(self) -> npt.NDArray[np.float32]: ...
    @property
    def removed(self) -> npt.NDArray[np.bool_]:
        """(N,) bool: bodies removed by a sink (their rows are their state when removed)."""
        ...
    @property
    def radii(self) -> npt.NDArray[np.float32]: ...
    @property
    def shape_ids(self) -> npt.NDArray[np.int64]: ...
    @property
    def material_ids(self) -> npt.NDArray[np.int64]: ...
    def kinetic_energy(self) -> float: ...
    def potential_energy(self) -> float: ...
    def momentum(self) -> Tuple[float, float, float]: ...
    def contacts(self) -> Dict[str, np.ndarray]:
        """Touching contacts: body, other (-1 for a wall or mesh), wall (-1 for a body pair or
        mesh), boundary (the [[boundary]] mesh index, -1 otherwise), point (M, 3, float64),
        point_count, normal (M, 3, from body to the other side), depth, force (M, 3, on
        body), normal_force."""
    def write_vtk(self, dir: PathLike, contacts: bool = True) -> List[pathlib.Path]: ...
    def save_checkpoint(self, path: PathLike) -> None: ...

def query_arrays(
    shape_a: str,
    position_a: ArrayLike,
    orientation_a: ArrayLike,
    velocity_a: ArrayLike,
    angular_velocity_a: ArrayLike,
    shape_b: str,
    position_b: ArrayLike,
    orientation_b: ArrayLike,
    velocity_b: ArrayLike,
    angular_velocity_b: ArrayLike,
    queries: Sequence[str],
    toi_horizon: float,
) -> Dict[str, np.ndarray]: ...
