"""clatter: rigid convex polyhedra and spheres colliding (Discrete Element Method), from Python.

The simulation runs in Rust (the same pipelines as the ``clatter`` command line: the
multi-threaded CPU pipeline, or wgpu compute shaders on a GPU); the state comes back as numpy
arrays.

>>> import clatter
>>> scene = (clatter.Scene(duration=0.5)
...          .material("steel", density=7800, stiffness=1e6, restitution=0.8)
...          .shape("ball", sphere=0.01)
...          .wall(point=[0, 0, 0], normal=[0, 0, 1], material="steel")
...          .body("ball", "steel", position=[0, 0, 0.1]))
>>> sim = clatter.Simulation(scene, backend="cpu")
>>> sim.step(100)
>>> sim.positions.shape
(1, 3)

- :class:`Scene`: a scene from a TOML file (:meth:`Scene.from_file`), from TOML text
  (:meth:`Scene.from_toml`), one of the embedded example scenes (:meth:`Scene.example`) or
  built in code with the scene file's tables and keys
  (``material``, ``shape``, ``wall``, ``container``, ``body``, ``group``; docs/scene-format.md).
- :class:`Simulation`: steps a scene; positions, orientations, velocities and angular
  velocities as numpy arrays; contacts, energies, VTK frames and checkpoints.
- :func:`query`: distance, contact and time of impact of two shapes, for one pose pair or for
  arrays of them.

Errors raise :class:`SceneError` (with ``file``, ``line``, ``column``, ``field``, ``message``),
:class:`CheckpointError`, :class:`SimulationError`, :class:`BackendError` or
:class:`QueryError`, with the messages of the command line.
"""

from __future__ import annotations

import json
import math
import numbers
import os
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _clatter
from ._clatter import (
    DEFAULT_SCENE,
    EXAMPLE_SCENES,
    GPU_SUPPORT,
    MATERIAL_COEFFICIENTS,
    BackendError,
    CheckpointError,
    ParsedScene,
    QueryError,
    SceneError,
    Simulation,
    SimulationError,
    __version__,
)

__all__ = [
    "Scene",
    "Simulation",
    "query",
    "SceneError",
    "CheckpointError",
    "SimulationError",
    "BackendError",
    "QueryError",
    "ParsedScene",
    "GPU_SUPPORT",
    "DEFAULT_SCENE",
    "EXAMPLE_SCENES",
    "MATERIAL_COEFFICIENTS",
    "__version__",
]

PathLike = Union[str, "os.PathLike[str]"]
Vec3 = Union[Sequence[float], np.ndarray]


# --- TOML writing (only what scene files use: numbers, strings, booleans, arrays, tables) ---


def _toml_value(v: Any, where: str) -> str:
    if isinstance(v, bool) or isinstance(v, np.bool_):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        x = float(v)
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, Mapping):
        items = ", ".join(
            f"{_toml_key(k)} = {_toml_value(x, f'{where}.{k}')}" for k, x in v.items() if x is not None
        )
        return "{ " + items + " }" if items else "{}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x, f"{where}[{i}]") for i, x in enumerate(v)) + "]"
    raise TypeError(f"{where}: cannot write a {type(v).__name__} into a scene (expected a number, string, bool, list or dict)")


def _toml_key(k: Any) -> str:
    k = str(k)
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k)


def _table(header: str, fields: Mapping[str, Any]) -> str:
    lines = [header]
    for k, v in fields.items():
        if v is not None:
            lines.append(f"{_toml_key(k)} = {_toml_value(v, k)}")
    return "\n".join(lines) + "\n"


# The material coefficients (``restitution``, ``friction``, ``rolling_friction``, ...), from the
# Rust table: ``Scene.material`` takes each as a keyword and documents it from there.
_COEFFICIENT_NAMES: Tuple[str, ...] = tuple(str(c["name"]) for c in MATERIAL_COEFFICIENTS)


def _coefficient_docs(indent: str) -> str:
    lines = []
    for c in MATERIAL_COEFFICIENTS:
        unit = f" {c['unit']}" if c["unit"] else ""
        lines.append(f"- ``{c['name']}``{unit}, {c['range']}, default {c['default']:g}: {c['doc']}")
    return ("\n" + indent).join(lines)


class Scene:
    """A scene: materials, shapes, walls, bodies and groups, and how long to run.

    Build one in code with the scene file's tables and keys (docs/scene-format.md); every
    method adds one table and returns the scene, so calls chain::

        scene = (clatter.Scene(duration=1.0)
                 .material("glass", density=2500, stiffness=1e5, restitution=0.9, friction=0.3)
                 .shape("bead", sphere=0.005)
                 .container(min=[0, 0, 0], max=[0.1, 0.1, 0.2], material="glass", top=False)
                 .group("bead", "glass", lattice=dict(min=[0.01] * 3, max=[0.09, 0.09, 0.15], spacing=0.012)))

    or read one with :meth:`from_file` / :meth:`from_toml` (and add to it the same way).
    The scene is checked when it is used (:class:`Simulation`, :meth:`validate`); errors
    raise :class:`SceneError` naming the field (``material[0].density``) and the line of
    :meth:`to_toml`'s text.

    Args:
        duration: simulated seconds (``[simulation].duration``), or
        steps: a number of steps (``[simulation].steps``);
        dt: time step, s (default: 1/50 of the shortest contact duration);
        gravity: m/s^2 (default ``[0, 0, -9.81]``);
        skin: Verlet skin, m (default: a fraction of the largest body).
    """

    def __init__(
        self,
        *,
        duration: Optional[float] = None,
        steps: Optional[int] = None,
        dt: Optional[float] = None,
        gravity: Optional[Vec3] = None,
        skin: Optional[float] = None,
    ) -> None:
        self._base: Optional[str] = None
        self._source = "<scene built in Python>"
        self._parts: List[str] = []
        # The ``[simulation]`` table's fields and its place in ``_parts``: one table, however
        # many calls set its keys (a second ``[simulation]`` is a TOML duplicate key).
        self._sim: Dict[str, Any] = {}
        self._sim_part: Optional[int] = None
        self._parsed_cache: Optional[ParsedScene] = None
        sim = dict(duration=duration, steps=steps, dt=dt, gravity=gravity, skin=skin)
        if any(v is not None for v in sim.values()):
            self.simulation(**sim)

    # --- reading ---

    @classmethod
    def from_file(cls, path: PathLike) -> "Scene":
        """Reads and validates a scene file (raises :class:`SceneError` as ``clatter run FILE`` reports it)."""
        parsed = ParsedScene.from_file(os.fspath(path))
        return cls._from_parsed(parsed)

    @classmethod
    def from_toml(cls, text: str, source: str = "<string>") -> "Scene":
        """Parses and validates scene text; ``source`` names it in error messages."""
        return cls._from_parsed(ParsedScene.from_toml(text, source))

    @classmethod
    def default(cls) -> "Scene":
        """The scene ``clatter run`` runs without a scene file (mixed polyhedra poured into a box)."""
        return cls.from_toml(DEFAULT_SCENE, "<default scene>")

    @classmethod
    def example(cls, name: str) -> "Scene":
        """One of the repository's example scenes (``scenes/NAME.toml`` without mesh files),
        embedded in the package so that it loads from any directory: ``Scene.example("dice-box")``.
        :data:`EXAMPLE_SCENES` lists the names; an unknown name raises ``ValueError`` listing them."""
        return cls._from_parsed(ParsedScene.example(name))

    @classmethod
    def _from_parsed(cls, parsed: ParsedScene) -> "Scene":
        scene = cls()
        scene._base = parsed.text
        scene._source = parsed.source
        scene._parsed_cache = parsed
        return scene

    # --- building: one method per table of the scene format ---

    def _has_table(self, header: str, base_only: bool = False) -> bool:
        """Whether the scene's text (the file's, and the tables added unless ``base_only``)
        has a table ``header`` (a single table such as ``[container]``)."""
        texts = [self._base or ""] + ([] if base_only else self._parts)
        return any(line.strip().startswith(header) for t in texts for line in t.splitlines())

    def _add(self, header: str, fields: Mapping[str, Any]) -> "Scene":
        self._parts.append(_table(header, fields))
        self._parsed_cache = None
        return self

    def simulation(
        self,
        *,
        duration: Optional[float] = None,
        steps: Optional[int] = None,
        dt: Optional[float] = None,
        gravity: Optional[Vec3] = None,
        skin: Optional[float] = None,
        periodic: Optional[Mapping[str, Any]] = None,
    ) -> "Scene":
        """``[simulation]``: ``duration`` (s) or ``steps``, and optionally ``dt``, ``gravity``,
        ``skin`` and ``periodic`` (``{"min": [..], "max": [..], "axes": "xy"}``).

        Calls add to the one table: ``Scene(duration=1).simulation(periodic=...)`` sets both
        keys (a key given again replaces its value; ``duration`` replaces ``steps`` and the
        other way round). A scene read from a file keeps its file's table: this raises
        ``ValueError`` there."""
        if self._has_table("[simulation]", base_only=True):
            raise ValueError(
                f"{self._source} has its own [simulation] table: change it in the scene text "
                "(Scene.from_toml) instead of adding a second one"
            )
        given = dict(
            duration=duration, steps=steps, dt=dt, gravity=gravity, skin=skin, periodic=periodic
        )
        given = {k: v for k, v in given.items() if v is not None}
        if "duration" in given:
            self._sim.pop("steps", None)
        if "steps" in given:
            self._sim.pop("duration", None)
        self._sim.update(given)
        table = _table("[simulation]", self._sim)
        if self._sim_part is None:
            self._sim_part = len(self._parts)
            self._parts.append(table)
        else:
            self._parts[self._sim_part] = table
        self._parsed_cache = None
        return self

    def material(
        self,
        name: str,
        density: float,
        *,
        stiffness: Optional[float] = None,
        model: Optional[str] = None,
        youngs_modulus: Optional[float] = None,
        poisson_ratio: Optional[float] = None,
        cohesion: Optional[Mapping[str, Any]] = None,
        **coefficients: Optional[float],
    ) -> "Scene":
        """``[[material]]``: density (kg/m^3); the linear model's ``stiffness`` (N/m), or
        ``model="hertz"`` with ``youngs_modulus`` (Pa) and ``poisson_ratio``; ``cohesion``
        (``{"model": "dmt", "surface_energy": gamma}``); and the material coefficients as
        keywords (those of the scene file; a coefficient left out takes its default):

        {coefficients}
        """
        unknown = [k for k in coefficients if k not in _COEFFICIENT_NAMES]
        if unknown:
            raise TypeError(
                f"Scene.material() got an unexpected keyword argument {unknown[0]!r} "
                f"(material coefficients: {', '.join(_COEFFICIENT_NAMES)})"
            )
        return self._add(
            "[[material]]",
            dict(
                name=name,
                density=density,
                model=model,
                stiffness=stiffness,
                youngs_modulus=youngs_modulus,
                poisson_ratio=poisson_ratio,
                **{k: coefficients.get(k) for k in _COEFFICIENT_NAMES},
                cohesion=cohesion,
            ),
        )

    if material.__doc__ is not None:  # None under python -OO
        material.__doc__ = material.__doc__.replace("{coefficients}", _coefficient_docs(" " * 8))

    def shape(
        self,
        name: str,
        *,
        sphere: Union[float, Mapping[str, Any], None] = None,
        box: Union[Vec3, Mapping[str, Any], None] = None,
        polyhedron: Optional[Mapping[str, Any]] = None,
        convex: Union[Sequence[Vec3], np.ndarray, Mapping[str, Any], None] = None,
    ) -> "Scene":
        """``[[shape]]`` with exactly one of: ``sphere`` (a radius, or ``{"radius": r}``),
        ``box`` (half extents ``[hx, hy, hz]``, or ``{"half_extents": ...}``), ``polyhedron``
        (``{"kind": "tetrahedron"|"cube"|"octahedron"|"dodecahedron"|"icosahedron", "radius": r}``)
        or ``convex`` (points (K, 3), or ``{"points": ...}``: their convex hull)."""
        return self._add("[[shape]]", dict(name=name, **shape_spec(sphere=sphere, box=box, polyhedron=polyhedron, convex=convex, strict=False)))

    def wall(self, point: Vec3, normal: Vec3, material: str) -> "Scene":
        """``[[wall]]``: an infinite plane through ``point``; ``normal`` points into the free side."""
        return self._add("[[wall]]", dict(point=point, normal=normal, material=material))

    def container(self, min: Vec3, max: Vec3, material: str, top: bool = True) -> "Scene":
        """``[container]``: an axis-aligned box of walls from ``min`` to ``max`` (``top=False``: open at the top).
        A scene has one container: a second raises ``ValueError``."""
        if self._has_table("[container]"):
            raise ValueError(f"{self._source} already has a [container] (a scene has one; add walls with .wall())")
        return self._add("[container]", dict(min=min, max=max, material=material, top=top))

    def body(
        self,
        shape: str,
        material: str,
        position: Vec3,
        *,
        velocity: Optional[Vec3] = None,
        angular_velocity: Optional[Vec3] = None,
        orientation: Optional[Sequence[float]] = None,
    ) -> "Scene":
        """``[[body]]``: one body; ``position`` is its centre of mass, ``orientation`` a
        quaternion ``[w, x, y, z]`` rotating the shape as authored, ``angular_velocity`` in the
        world frame (rad/s)."""
        return self._add(
            "[[body]]",
            dict(
                shape=shape,
                material=material,
                position=position,
                velocity=velocity,
                angular_velocity=angular_velocity,
                orientation=orientation,
            ),
        )

    def bodies(
        self,
        shape: str,
        material: str,
        positions: Union[np.ndarray, Sequence[Vec3]],
        *,
        velocities: Union[np.ndarray, Sequence[Vec3], None] = None,
    ) -> "Scene":
        """Many ``[[body]]`` entries at once: one per row of ``positions`` (K, 3), with
        ``velocities`` (K, 3) if given; other shapes raise ``ValueError``."""
        positions = np.asarray(positions, dtype=float)
        if positions.ndim == 1 and positions.shape == (3,):
            positions = positions.reshape(1, 3)
        if positions.ndim != 2 or positions.shape[1] != 3:
            raise ValueError(f"positions must have shape (K, 3), got {positions.shape}")
        vel = None
        if velocities is not None:
            vel = np.asarray(velocities, dtype=float)
            if vel.shape != positions.shape:
                raise ValueError(
                    f"velocities must have the shape of positions {positions.shape}, got {vel.shape}"
                )
        for k, p in enumerate(positions):
            self.body(shape, material, p, velocity=None if vel is None else vel[k])
        return self

    def group(
        self,
        shape: str,
        material: str,
        *,
        lattice: Optional[Mapping[str, Any]] = None,
        random: Optional[Mapping[str, Any]] = None,
        random_orientation: Optional[bool] = None,
        velocity: Optional[Vec3] = None,
        angular_velocity: Optional[Vec3] = None,
        seed: Optional[int] = None,
    ) -> "Scene":
        """``[[group]]``: many bodies of one shape, on a ``lattice`` (``{"min", "max",
        "spacing"}``) or at ``random`` places without overlap (``{"min", "max", "count",
        "seed"}``), optionally randomly oriented."""
        return self._add(
            "[[group]]",
            dict(
                shape=shape,
                material=material,
                lattice=lattice,
                random=random,
                random_orientation=random_orientation,
                velocity=velocity,
                angular_velocity=angular_velocity,
                seed=seed,
            ),
        )

    # --- using ---

    def to_toml(self) -> str:
        """The scene as scene-file text (``clatter run`` reads it the same way)."""
        base = self._base if self._base is not None else ""
        if base and self._parts and not base.endswith("\n"):
            base += "\n"
        return base + ("\n" if base and self._parts else "") + "\n".join(self._parts)

    @property
    def source(self) -> str:
        """The name errors and outputs give the scene (its file name, or ``<scene built in Python>``)."""
        return self._source

    def _parsed(self) -> ParsedScene:
        if self._parsed_cache is None:
            self._parsed_cache = ParsedScene.from_toml(self.to_toml(), self._source)
        return self._parsed_cache

    def validate(self) -> "Scene":
        """Checks the scene now (raises :class:`SceneError`); returns it."""
        self._parsed()
        return self

    def save(self, path: PathLike) -> None:
        """Writes :meth:`to_toml` to ``path`` (for ``clatter run path``)."""
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.to_toml())

    @property
    def n_bodies(self) -> int:
        """Number of bodies the scene creates."""
        return self._parsed().n_bodies

    @property
    def n_walls(self) -> int:
        """Number of wall planes (a container counts 5 or 6)."""
        return self._parsed().n_walls

    @property
    def steps(self) -> int:
        """How many steps the scene runs for (``steps``, or ``duration / dt``)."""
        return self._parsed().steps

    @property
    def duration(self) -> Optional[float]:
        """``[simulation].duration`` in seconds, or None when the scene gives ``steps``."""
        return self._parsed().duration

    @property
    def warnings(self) -> List[str]:
        """Legal but probably unintended things (overlapping lattice, bodies outside the container)."""
        return self._parsed().warnings

    def __repr__(self) -> str:
        return f"<clatter.Scene {self._source}: {len(self._parts)} tables added>"


def shape_spec(
    *,
    sphere: Union[float, Mapping[str, Any], None] = None,
    box: Union[Vec3, Mapping[str, Any], None] = None,
    polyhedron: Optional[Mapping[str, Any]] = None,
    convex: Union[Sequence[Vec3], np.ndarray, Mapping[str, Any], None] = None,
    strict: bool = True,
) -> Dict[str, Any]:
    """A shape in the scene file's syntax (``{"sphere": {"radius": r}}`` ...) from the
    shortcuts of :meth:`Scene.shape` (a radius, half extents, a point array)."""
    out: Dict[str, Any] = {}
    if sphere is not None:
        out["sphere"] = sphere if isinstance(sphere, Mapping) else {"radius": sphere}
    if box is not None:
        out["box"] = box if isinstance(box, Mapping) else {"half_extents": box}
    if polyhedron is not None:
        out["polyhedron"] = polyhedron
    if convex is not None:
        out["convex"] = convex if isinstance(convex, Mapping) else {"points": convex}
    if strict and len(out) != 1:
        raise QueryError(f"a shape needs exactly one of `sphere`, `box`, `polyhedron`, `convex` (got {len(out)})")
    return out


def _to_builtin(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, Mapping):
        return {str(k): _to_builtin(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_to_builtin(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def _shape_json(shape: Any, name: str) -> str:
    if isinstance(shape, str):
        return shape
    if not isinstance(shape, Mapping):
        raise QueryError(f"{name} must be a shape dict like {{'sphere': {{'radius': 1.0}}}}, got {type(shape).__name__}")
    return json.dumps(_to_builtin(shape))


_ALL_QUERIES = ("intersects", "distance", "contact", "toi")


def query(
    shape_a: Mapping[str, Any],
    pose_a: Any,
    shape_b: Mapping[str, Any],
    pose_b: Any,
    queries: Union[str, Iterable[str], None] = None,
    *,
    velocity_a: Any = None,
    angular_velocity_a: Any = None,
    velocity_b: Any = None,
    angular_velocity_b: Any = None,
    toi_horizon: float = 1.0,
) -> Dict[str, Any]:
    """Collision queries between two shapes: the answers of ``clatter query`` (docs/queries.md).

    Args:
        shape_a, shape_b: shapes in the scene file's syntax, e.g. ``{"sphere": {"radius": 1}}``,
            ``{"box": {"half_extents": [1, 1, 1]}}``,
            ``{"polyhedron": {"kind": "icosahedron", "radius": 1}}``,
            ``{"convex": {"points": [[...], ...]}}``.
        pose_a, pose_b: a position ``(3,)``, or ``(position, orientation)`` with the
            orientation a quaternion ``(w, x, y, z)`` rotating the shape as authored; the
            position is where the centre of mass goes. Arrays of positions ``(M, 3)`` and
            orientations ``(M, 4)`` give M queries at once (broadcast against each other and
            against the velocities).
        queries: any of ``"intersects"``, ``"distance"``, ``"contact"``, ``"toi"`` (default all).
        velocity_a, angular_velocity_a, velocity_b, angular_velocity_b: the constant motion
            (m/s; rad/s, world frame, about the centre of mass) for ``"toi"``.
        toi_horizon: the time of impact is searched in ``[0, toi_horizon]``.

    Returns:
        A dict with the fields asked for, as numpy arrays with a leading axis of M for
        arrays of poses, or scalars and small arrays for one pose pair:

        - ``intersects`` (bool);
        - ``distance``; ``points`` (2, 3): the closest points on a and on b; ``normal`` (3,)
          from a to b (zero when they overlap);
        - ``depth`` (> 0 overlap, < 0 apart by -depth); ``points``, ``normal``: the contact's
          witness points and normal (they replace the distance's, as in ``clatter query``);
          ``contacts`` (4, 3): the manifold, NaN-padded, with ``contact_count`` points;
        - ``toi``: the first time of contact, NaN when none within the horizon;
          ``toi_points`` (2, 3), ``toi_normal`` (3,); ``toi_converged`` False where the
          search stopped at its iteration cap (a very fast spin grazing the other shape):
          ``toi`` is then the time reached without contact, not an impact.

    Raises:
        QueryError: an invalid shape, pose or option (the message names it).
    """
    if queries is None:
        qs = list(_ALL_QUERIES)
    elif isinstance(queries, str):
        qs = [queries]
    else:
        qs = list(queries)
    pa, oa = _split_pose(pose_a, "pose_a")
    pb, ob = _split_pose(pose_b, "pose_b")
    zero = np.zeros(3)
    arrays = [
        (pa, 3),
        (oa, 4),
        (zero if velocity_a is None else np.asarray(velocity_a, dtype=float), 3),
        (zero if angular_velocity_a is None else np.asarray(angular_velocity_a, dtype=float), 3),
        (pb, 3),
        (ob, 4),
        (zero if velocity_b is None else np.asarray(velocity_b, dtype=float), 3),
        (zero if angular_velocity_b is None else np.asarray(angular_velocity_b, dtype=float), 3),
    ]
    names = ["position_a", "orientation_a", "velocity_a", "angular_velocity_a",
             "position_b", "orientation_b", "velocity_b", "angular_velocity_b"]
    single = all(a.ndim <= 1 for a, _ in arrays)
    rows = 1
    for (a, cols), name in zip(arrays, names):
        if a.ndim > 2 or a.shape[-1:] != (cols,):
            raise QueryError(f"{name} must have shape ({cols},) or (M, {cols}), got {a.shape}")
        if a.ndim == 2 and a.shape[0] != 1:
            if rows not in (1, a.shape[0]):
                raise QueryError(f"{name} has {a.shape[0]} rows, another argument {rows}: they must match (or have one)")
            rows = a.shape[0]
    full = [np.ascontiguousarray(np.broadcast_to(a.reshape(-1, cols), (rows, cols)), dtype=float) for a, cols in arrays]
    out = _clatter.query_arrays(
        _shape_json(shape_a, "shape_a"), *full[:4], _shape_json(shape_b, "shape_b"), *full[4:],
        qs, float(toi_horizon),
    )
    if single:
        res: Dict[str, Any] = {}
        for k, v in out.items():
            x = v[0]
            res[k] = x.item() if np.ndim(x) == 0 else x
        return res
    return dict(out)


def _split_pose(pose: Any, name: str) -> Tuple[np.ndarray, np.ndarray]:
    if isinstance(pose, tuple) and len(pose) == 2:
        p, o = pose
        return np.asarray(p, dtype=float), np.asarray(o, dtype=float)
    p = np.asarray(pose, dtype=float)
    return p, np.array([1.0, 0.0, 0.0, 0.0])
