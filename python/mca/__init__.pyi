# Type stubs of the mca module (python/src/*.cpp): what an editor completes and documents.
import os
from typing import Any, Callable, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

Vec3 = Tuple[float, float, float]
Vec3Like = Union[Sequence[float], npt.NDArray[np.float64]]
PathLike = Union[str, "os.PathLike[str]"]

class Error(Exception):
    """An error the mca command would report: the message names the file, the key, the bad value and the fix.
    A value of the wrong type for a key or an argument raises it too (a number, a whole number, a str, or
    True/False: `output.vtk = 2` is refused, not taken as True)."""

class Material:
    """A [[material]] of docs/scene-format.md (SI units)."""
    name: str
    youngs_modulus: float
    poisson_ratio: float
    density: float
    tensile_strength: float
    compressive_strength: float
    fracture_strain: float
    friction: float
    restitution: float
    rolling_friction: float
    twisting_friction: float
    damping_time: float
    strengthening: str
    """"none", "exponential" or "quadratic" (paper eq. 7)."""
    strengthening_alpha: float
    fracture_energy: float
    """G_f [J/m^2] of the links' softening, in [0, 1e6]; 0: the instant break."""
    weibull_modulus: float
    """Weibull modulus of the links' own strengths, 0 (no spread) or in [1, 100]."""
    def __init__(self, **keys: Any) -> None:
        """Concrete's values changed by the keys given; an unknown key raises mca.Error."""
    @staticmethod
    def builtin(name: str) -> Material:
        """A copy of a built-in material: concrete, glass, ceramic, granite, steel."""

class Heterogeneity:
    """[heterogeneity] or [object.heterogeneity]: the strength classes."""
    preset: str
    """"none", "low", "medium" or "high" (sets shares); "custom" once shares are assigned."""
    shares: Tuple[float, float, float, float]
    class_factors: Tuple[float, float, float, float]
    grain_size: float
    def __init__(self, **keys: Any) -> None: ...

class Region:
    """An [[object.region]]: a material for the automata inside it."""
    shape: str
    center: Vec3
    size: Vec3
    radius: float
    mesh: str
    material: str
    def __init__(self, **keys: Any) -> None: ...

class Object:
    """An [[object]]: box, sphere, cylinder or mesh, filled with automata."""
    name: str
    shape: str
    size: Vec3
    radius: float
    height: float
    mesh: str
    scale: float
    fit_size: float
    fill: str
    shell_thickness: float
    position: Vec3
    rotation: Vec3
    velocity: Vec3
    material: str
    regions: list[Region]
    heterogeneity: Optional[Heterogeneity]
    def __init__(self, **keys: Any) -> None: ...
    def add_region(self, **keys: Any) -> Region:
        """Appends a Region with the keys given and returns it."""

class Projectile:
    """A [[projectile]]: a rigid ball."""
    name: str
    radius: float
    material: str
    density: float
    position: Vec3
    velocity: Vec3
    angular_velocity: Vec3
    kinematic: bool
    rolling_friction: float
    twisting_friction: float
    def __init__(self, **keys: Any) -> None: ...

class Grip:
    """A [[grip]]: the automata in the box [min, max] move at a fixed velocity."""
    name: str
    min: Vec3
    max: Vec3
    velocity: Vec3
    def __init__(self, **keys: Any) -> None: ...

class Load:
    """A [[load]]: a constant force on each automaton in the box [min, max]."""
    name: str
    min: Vec3
    max: Vec3
    force: Vec3
    def __init__(self, **keys: Any) -> None: ...

class Ground:
    """[ground]: a rigid plane normal to the up axis."""
    enabled: bool
    height: float
    friction: float
    restitution: float
    rolling_friction: float
    twisting_friction: float
    def __init__(self, **keys: Any) -> None: ...

class Solver:
    """[solver]: the lattice and the integration."""
    spacing: float
    target_automata: int
    safety: float
    time_step: float
    mass_scaling: float
    gravity: Vec3
    link_damping: float
    local_damping: float
    stress_coefficient: float
    lattice: str
    """"random" (the default: a site at a random point of each cell, linked to its Voronoi neighbours) or "cubic" (the paper's lattice)."""
    backend: str
    """Where the step runs: "auto" (the default: an NVIDIA GPU where there is one, else the CPU; the environment variable MCA_BACKEND changes what it stands for), "cpu", "cuda" (an NVIDIA GPU) or "cuda-emulation" (the CUDA backend's algorithm on one core, for tests)."""
    lattice_jitter: float
    """Sites moved by up to this share of d along each axis, in [0, 0.3]; 0: the cubic lattice."""
    link_bending: float
    """The random lattice's links' bending springs, a share of a beam of their section: 0 (none), or in [0.01, 1]; 0.1 (the default) is calibrated."""
    skin: float
    seed: int
    max_memory_gb: float
    def __init__(self, **keys: Any) -> None: ...

class Output:
    """[output]: the duration, frames and files of a run."""
    duration: float
    frame_rate: float
    links: bool
    vtk: bool
    checkpoint_every: int
    surface: bool
    surface_format: str
    fragments: bool
    fragment_min_automata: int
    def __init__(self, **keys: Any) -> None: ...

class Camera:
    """[camera]: the renderer's camera; None keys are automatic."""
    position: Optional[Vec3]
    target: Optional[Vec3]
    fov: float
    def __init__(self, **keys: Any) -> None: ...

class Scene:
    """A scene: the keys of docs/scene-format.md."""
    name: str
    source: str  # what messages call it: the file it came from, to which they add " (as changed from Python)" once changed
    materials: list[Material]
    objects: list[Object]
    projectiles: list[Projectile]
    grips: list[Grip]
    loads: list[Load]
    heterogeneity: Heterogeneity
    solver: Solver
    output: Output
    ground: Ground
    camera: Camera
    def __init__(self, name: str = "scene") -> None:
        """An empty scene (no objects) with every default."""
    @staticmethod
    def load(path: PathLike) -> Scene:
        """Reads a scene file (TOML); raises mca.Error with file:line:column and the key."""
    @staticmethod
    def from_toml(text: str, source: str = "<string>") -> Scene:
        """Parses TOML text; `source` names it in messages."""
    @staticmethod
    def default() -> Scene:
        """The built-in default scene (scenes/wall_ball.toml)."""
    def add_object(self, **keys: Any) -> Object:
        """Appends an Object (named "object", "object1", ... unless named) and returns it."""
    def add_projectile(self, **keys: Any) -> Projectile:
        """Appends a Projectile (named "ball", "ball1", ... unless named) and returns it."""
    def add_grip(self, **keys: Any) -> Grip: ...
    def add_load(self, **keys: Any) -> Load: ...
    def add_material(self, name: str, base: Optional[str] = None, **keys: Any) -> Material:
        """Appends a material: a copy of `base` (an earlier scene material or a built-in) with the keys given."""
    def validate(self) -> None:
        """Checks the scene with the command's code; raises mca.Error naming the key, the value and the fix."""
    def to_toml(self) -> str:
        """The complete scene as TOML (every key); from_toml reads it back to the same scene."""
    def save(self, path: PathLike) -> None:
        """Writes to_toml() to a file."""
    def copy(self) -> Scene:
        """A deep copy."""
    def __copy__(self) -> Scene:
        """A deep copy (copy.copy)."""
    def __deepcopy__(self, memo: dict[int, object]) -> Scene:
        """A deep copy (copy.deepcopy)."""
    def __reduce__(self) -> tuple[object, tuple[str, str]]:
        """For pickle: Scene.from_toml of its TOML and its source, tried first (mca.Error here for a scene it
        would refuse: validate()'s checks, a mesh not found)."""
    def __eq__(self, other: object) -> bool: ...

class Simulation:
    """A run of a scene. State arrays are copies; strength_class, masses and object_ids are read-only
    views of the model. Every array stays valid after the Simulation is gone.

    One Simulation is used from one Python thread at a time: while advance runs in one thread, advance or
    a read of the state from another raises mca.Error at once (it does not wait)."""
    def __init__(self, scene: Union[Scene, PathLike], threads: int = 0, backend: Optional[str] = None) -> None:
        """Builds the model (threads 0: all cores); raises mca.Error for a scene that cannot be built."""
    @staticmethod
    def resume(path: PathLike, threads: int = 0, backend: Optional[str] = None) -> Simulation:
        """Continues from a checkpoint file, or a run folder's newest checkpoint."""
    def advance(self, steps: int, progress: Optional[Callable[[int, int], Any]] = None) -> None:
        """Advances `steps` steps on a stepping thread, without the GIL. Ctrl-C raises KeyboardInterrupt
        within about 0.05 s while the slice in flight (up to about 2 s) ends in the background; whatever uses
        the simulation next waits for it. progress(done, total) after each slice, while the next slice runs:
        it cannot read the simulation (sim.step, arrays: mca.Error), so use done and total; progress must be
        callable or None (checked before any step), and an exception it raises ends the advance after the
        slice in flight (a whole step) and is raised. mca.Error when the run becomes unstable, and when a step
        cannot be done (a GPU whose memory is full): the simulation then steps and is read no more; a state
        saved before (checkpoint, Simulation.resume) continues, with backend="cpu"."""
    def advance_to(self, time: float, progress: Optional[Callable[[int, int], Any]] = None) -> None:
        """Advances to the step nearest `time` [s]; nothing when that has passed (a negative time: mca.Error)."""
    @property
    def step(self) -> int: ...
    @property
    def time(self) -> float: ...
    @property
    def time_step(self) -> float: ...
    @property
    def steps_per_frame(self) -> int: ...
    @property
    def total_steps(self) -> int:
        """The run's steps: the scene's output.duration's; resumed from a checkpoint, its run's (mca run --steps N: N)."""
    @property
    def automata(self) -> int: ...
    @property
    def link_count(self) -> int:
        """Links at the start, intact and broken (len(links()) counts the intact ones)."""
    @property
    def threads(self) -> int:
        """Worker threads: threads=0 gives every core; more than the machine's cores are cut to them."""
    @property
    def backend(self) -> str: ...
    @property
    def scene(self) -> Scene:
        """A copy of the scene as built."""
    def positions(self) -> npt.NDArray[np.float64]:
        """(N, 3) float64 centres [m], a copy."""
    def velocities(self) -> npt.NDArray[np.float64]:
        """(N, 3) float64 [m/s], a copy."""
    def angular_velocities(self) -> npt.NDArray[np.float64]:
        """(N, 3) float64 [rad/s], a copy."""
    def rotations(self) -> npt.NDArray[np.float32]:
        """(N, 4) float32 unit quaternions (w, x, y, z), a copy."""
    def damage(self) -> npt.NDArray[np.float32]:
        """(N,) float32 share of each automaton's links broken (a damaged softening link by its damage), a copy."""
    def fragment_ids(self) -> npt.NDArray[np.int32]:
        """(N,) int32 fragment of each automaton (0 = heaviest), a copy."""
    def strength_class(self) -> npt.NDArray[np.uint8]:
        """(N,) uint8 class 1..4, a read-only view of the model."""
    def masses(self) -> npt.NDArray[np.float32]:
        """(N,) float32 [kg], a read-only view of the model."""
    def object_ids(self) -> npt.NDArray[np.int32]:
        """(N,) int32 scene object index, a read-only view of the model."""
    def links(self) -> npt.NDArray[np.uint32]:
        """(L, 2) uint32 intact links as automaton pairs, a copy."""
    def broken_links(self) -> dict[str, int]:
        """{displacement, stress, total}."""
    def projectiles(self) -> dict[str, Any]:
        """{name: list[str], position, velocity, angular_velocity: (P, 3) float64, radius, mass: (P,) float64}."""
    def energies(self) -> dict[str, float]:
        """summary.json's "energy" plus total [J]."""
    def fragments(self) -> dict[str, npt.NDArray[Any]]:
        """The columns of fragments.csv by name, heaviest first."""
    def state_hash(self) -> str:
        """summary.json's state_hash: 16 hex digits."""
    def write_frame(self, out: PathLike) -> int:
        """Writes the next frame of folder `out` as `mca run --out` does; returns its number. The first frame
        in a folder makes a new run's checks and removes what an earlier run left there. Only one folder is
        written at a time (however it is spelt: "out", "out/", "./out"): giving another folder releases the
        first (once the other has passed its checks: a folder refused leaves the first as it was), and giving
        the first again starts it afresh (frame 0, its earlier frames and stats.csv removed). A Simulation
        resumed from a run folder's newest checkpoint (Simulation.resume(folder)) goes on in that folder, as
        mca resume does: the run's frames on its clock (frame k at step k x steps_per_frame, up to
        total_steps; another step is refused) from the checkpoint's (its own frame is the resumed state:
        written before advancing, it returns that number), what the run wrote past it replaced."""
    def close_output(self, finish: bool = False, progress: Optional[Callable[[int, int], Any]] = None) -> None:
        """Releases the folder of write_frame. finish=True first writes the run's end as mca run does after its
        last frame, from the state of the last frame written: summary.json ("finished"), fragments.csv and,
        with output.fragments, the fragment meshes, made on a thread of their own: progress(written, meshes)
        as they are written; Ctrl-C raises KeyboardInterrupt within the piece being meshed, leaving the
        folder open without summary.json (close_output(finish=True) again writes the end whole)."""
    def checkpoint(self, path: PathLike) -> None:
        """Saves the scene and the whole state (.mcack) to the file `path` (not a folder, not "")."""

def render(
    sim: Simulation,
    path: Optional[PathLike] = None,
    colour: str = "fragment",
    draw: Optional[str] = None,
    size: Tuple[int, int] = (1280, 720),
) -> npt.NDArray[np.uint8]:
    """Draws the state with the command's renderer (EGL, offscreen); writes a PNG to `path` when given
    (a file name ending in .png); returns (height, width, 4) uint8 RGBA."""
