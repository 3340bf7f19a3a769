"""The scene: what a script has created so far, and the commands that change it (`engine.commands`).

The engine in layers: pure contact laws (`contact_laws`) and their description as data (`models`) -> the kernel
builder (`kernels`, templates filled per combination) -> the particle state, wall set and neighbor list
(`state`, `walls`, `neighbor`) -> commands (`commands`), the run loop (`runner`), guards (`guards`),
quantities (`quantities`), modifiers (`modifiers`), output (`output`, `writers`) and restart files
(`restart`).
"""
from __future__ import annotations

import numpy as np

from . import blowup, commands, modifiers, superquadrics
from . import threads as thread_pool
from . import state as particle_state
from .log import Log
from .mesh import empty_mesh_list
from .neighbor import empty_list
from .output import Output

#: the critical time step is re-checked with the current velocities every this many steps (LIGGGHTS' fix
#: check/timestep/gran re-checks every N steps too: the Hertz time falls as particles speed up)
TIMESTEP_CHECK_EVERY = 1000


class Simulation:
    """One scene. Types are numbered from 1 in scripts and from 0 inside arrays (``ptype = type - 1``)."""

    def __init__(self, log: Log, threads: int | None = None):
        self.log = log
        self.threads = min(threads, thread_pool.pool_size()) if threads else thread_pool.pool_size()
        self.lo = self.hi = None  # domain, m
        self.periodic = np.zeros(3, dtype=np.bool_)
        self.skin = 0.001  # m, the LIGGGHTS SI default
        self.dt = None
        self.step = 0
        self.time = 0.0
        self.materials: dict[int, tuple] = {}  # type -> (Young's modulus Pa, Poisson ratio, density kg/m^3)
        self.interactions: dict[tuple, dict] = {}  # (type a <= type b) -> restitution, friction, ...
        self.model: dict | None = None  # the contact model's submodels and options
        self.walls: list[dict] = []  # in the order of engine.walls.SHAPES: planes, cylinders, meshes
        self.regions: dict[str, dict] = {}  # name -> region (engine.regions), from create region
        self.plane_point = np.zeros((0, 3))  # m, a point of each plane; moves with the plane's velocity
        self.mesh_triangles: dict[str, np.ndarray] = {}  # mesh wall name -> placed triangles (m, 3, 3), m
        self.mesh_angle = np.zeros(0)  # rad, each mesh's rotation so far
        self.mesh_shift = np.zeros((0, 3))  # m, each mesh's translation so far
        self.mesh_travel = np.zeros(1)  # m, how far meshes may have moved since the last neighbor rebuild
        self.wall_force = np.zeros((0, 3))  # N, on each wall at the last step
        self.wall_torque = np.zeros((0, 3))  # N m, on each wall about the origin at the last step
        self.state = particle_state.empty()
        self.nbr = empty_list()
        self.mesh_nbr = empty_mesh_list()  # particle-triangle contacts (engine/mesh.py)
        self.next_id = 1
        self.clump_templates: dict = {}  # name -> engine.clumps.Template
        self.bodies = None  # engine.clumps.Bodies once a scene has clumps
        self.superquadrics = None  # engine.superquadrics.Superquadrics once a scene has superquadrics
        self.modifiers: dict[str, modifiers.Modifier] = {}
        self.active: list[str] = []  # fixed modifiers, in the order they were fixed
        self.modifier_state: dict[str, dict] = {}  # modifier name -> counters read from a restart file
        self.output = Output()
        self.timestep_fraction = 0.2
        self.timestep_strict = False
        self.timestep_every = TIMESTEP_CHECK_EVERY
        # the blow-up limits (engine/blowup.py): largest overlap / smaller radius, dt / critical time step
        self.blowup_overlap, self.blowup_timestep = blowup.default_limits()
        # forces must be evaluated before the next step: only changes of the particle set or their velocities
        # do this; a model change (walls, gravity, materials) acts from the next step's force evaluation, so
        # a restart continues bitwise whatever the continuation script declares
        self.dirty = True
        self.lost_total = 0
        self.timing = dict(pair=0.0, neigh=0.0, comm=0.0, modify=0.0, output=0.0, other=0.0, total=0.0,
                           cpu=0.0, compile=0.0, steps=0, particles=0, particle_steps=0, threads=self.threads)

    def execute(self, cmd: dict, index: int, script: str):
        """One command of a script (index from 1)."""
        commands.execute(self, cmd, index, script)

    @property
    def n(self) -> int:
        """Number of particles."""
        return particle_state.count(self.state)

    def active_modifiers(self) -> list:
        return [self.modifiers[name] for name in self.active]

    def gravity_vector(self) -> np.ndarray:
        """m/s^2: the sum of the active gravity modifiers."""
        return modifiers.gravity_vector(self.active_modifiers())

    def total_line(self) -> str:
        """The log's last line after a successful script."""
        return (f"total: {self.timing['steps']} steps, {self.n + superquadrics.count(self)} particles, "
                f"{self.lost_total} lost, "
                f"{self.log.warnings} warning(s)")

    def close(self):
        self.output.close()
        for mod in self.modifiers.values():
            mod.close()

    def timing_record(self) -> dict:
        t = dict(self.timing)
        t["other"] = max(0.0, t["total"] - t["pair"] - t["neigh"] - t["comm"] - t["modify"] - t["output"])
        t["particle_steps_per_second"] = t["particle_steps"] / t["total"] if t["total"] > 0 else 0.0
        return t
