"""Every fact about a model that code outside the model needs, in one place.

    from fem_bounce.models.registry import MODELS
    MODELS["fd"].restarts                 # True: it writes checkpoints and continues with --restart
    MODELS["ib"].label(32)                # "ib, 32 cells/D"

The run module, the command line, the study cache, the studies and the figures read these; a model's
own numerics stay in its package.  Pure data: importing it needs neither dolfinx nor gmsh.  Adding a
model means writing its FlowModel (fem_bounce.flow_model) and one entry here.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .. import scene as scenes


@dataclass(frozen=True)
class ModelInfo:
    name: str  # the --model value
    module: str  # where its FlowModel class lives (imported on demand)
    class_name: str
    liquid: str  # what resolves the liquid, for tables
    resolved: bool  # f_sim comes from a flow solver (else f_thr everywhere)
    resolution_key: str  # the scene key of its resolution knob (studies refine it)
    resolution_unit: str  # how a resolution reads in labels: "cells/D", or "" for a tolerance
    ladder: tuple  # the studies' resolutions, coarse to fine
    time_step_key: str | None = None  # its CFL number
    scaled_with_time_step: tuple = ()  # other step limits a time-step study scales alike
    # (key, value) pairs a study's reference run adds, as near_wall.py's reference has them: the ale model's steps
    # shortened through each collision (its default keeps one step length, which spans the 50 us contact: case 3's
    # apex 2.4 % high) and its surface three times finer (its default's D / 16, coarser than the fd default's
    # D / 40, puts the apex 3 % high; docs/validation.md section 1)
    reference_settings: tuple = ()
    checkpoint_every_key: str | None = None  # writes checkpoints (and so restarts) when set
    checkpoint_files: tuple = ()  # the data files every whole checkpoint holds
    serial: bool = False  # a serial computation: under mpiexec rank 0 runs it alone (run._serial_on_root)
    min_cells_across_blend_gap: float | None = None  # fewer and the force near the wall is off by > 5 %
    fields_key: str | None = None  # the setting that writes field snapshots every N steps
    trajectory_interval_key: str | None = None  # thins the trajectory rows to one per interval [s]
    colour: str = "k"  # the same in every chart
    sources: tuple = ()  # package paths whose code decides its numbers (the study cache's key)
    max_spheres: int = 1  # the most spheres on the axis it runs (scene.second_sphere, further_spheres)
    oblique: bool = False  # it runs a sphere moving along the wall or spinning (Scene.oblique): off the axis
    stepper: str = "coupled"  # how time advances (fem_bounce.steppers.STEPPERS); a held steady model: "steady"
    max_initial_gap: float | None = None  # [diameters] the highest release it meshes (None: no limit)
    containers: bool = True  # it runs a sphere in a cylindrical container (scene.container), not only unbounded
    three_d: bool = False  # it solves the flow in three dimensions (the others on the axis, or none)
    chooser: str | None = None  # a function of the module that picks the class for a scene (else class_name)

    @property
    def restarts(self) -> bool:
        return self.checkpoint_every_key is not None

    def setting(self, scene, key: str):
        value = scene
        for part in key.split("."):
            value = getattr(value, part)
        return value

    def cadences(self, scene) -> tuple[int, int]:
        """(field snapshots, checkpoints): every how many steps the scene asks for them (0: never)."""
        fields = self.setting(scene, self.fields_key) if self.fields_key else 0
        checkpoints = self.setting(scene, self.checkpoint_every_key) if self.checkpoint_every_key else 0
        return fields, checkpoints

    def unstable_hint(self, scene) -> str:
        """What to change when this model's coupled step gained energy it cannot have."""
        coupling = getattr(getattr(scene.numerics, self.name), "coupling", "implicit")
        if not self.resolved:
            return f"tighten {self.resolution_key}"
        if coupling == "explicit":
            return f"numerics.{self.name}.coupling = \"explicit\" fails here: use \"implicit\""
        return f"use a smaller {self.time_step_key}"

    def breakdown_cause(self, scene) -> str:
        """Why a coupled step broke down with an arithmetic error, and what to change."""
        if not self.time_step_key:  # the ode model's steps adapt: the inputs are the cause
            return "the scene's numbers are beyond what the force formulas can represent"
        hint = (f"for a light sphere use numerics.{self.name}.coupling = \"implicit\"; otherwise "
                if hasattr(getattr(scene.numerics, self.name), "coupling") else "")
        return f"unstable ({hint}lower {self.time_step_key})"

    def scene_warnings(self, scene) -> list[str]:
        """What this model does not do well for the scene: an unbounded liquid's forces in a container, too
        few cells across the blend gap, a history setting its flow overrides."""
        found = []
        if self.resolved and scene.near_wall_law != "blend" and scene.contact.history_across_contact == "pause":
            found.append(f'contact.history_across_contact = "pause" has no effect with the {self.name} model: its '
                         "resolved flow carries the history force (the setting applies to the theory force: the ode "
                         'model, or contact.near_wall = "blend")')
        if not self.resolved and not scene.container.unbounded:
            found.append(f"the {self.name} model's forces are those of an unbounded liquid: it ignores [container] "
                         f"(radius {scene.container.radius:g} m, height {scene.container.height:g} m); a resolved "
                         "model (fd, ib, ale) meshes the container")
        if self.min_cells_across_blend_gap is not None:
            cells = self.resolution(scene)
            across, needed = cells * scene.contact.delta_sl, self.min_cells_across_blend_gap
            if across < needed:
                found.append(f"numerics.{self.name}.cells_per_diameter = {cells:g} puts {across:.2g} fine cells "
                             f"across the delta_sl gap ({scene.contact.delta_sl:g} D); below {needed:g} the "
                             f"{self.name} model's force near the wall is off by more than 5 % (stability study): "
                             "expect impact speed and apex errors of 10 % or more; use at least "
                             f"{needed / scene.contact.delta_sl:g} cells/D")
        return found

    def resolution(self, scene) -> float:
        return self.setting(scene, self.resolution_key)

    def default_resolution(self) -> float:
        """The resolution a scene gets when it does not set one."""
        section, name = self.resolution_key.split(".")[1:]
        numerics = scenes.Numerics()
        return {f.name: f.default for f in dataclasses.fields(getattr(numerics, section))}[name]

    def label(self, resolution: float) -> str:
        """'fd, 24 cells/D' (the cost label of tables and figures)."""
        if self.resolution_unit:
            return f"{self.name}, {resolution:g} {self.resolution_unit}"
        return f"{self.name}, {self.resolution_key.rsplit('.', 1)[-1]} {resolution:g}"


# The shared core every model's numbers depend on (the cache hashes these with each model's sources).
CORE_SOURCES = ("scene.py", "materials.py", "theory.py", "contact.py", "bodies.py", "integrator.py", "bounces.py",
                "motion.py", "flow_model.py", "steppers.py", "run.py", "errors.py", "output.py", "models/__init__.py",
                "pair_contact.py", "pair_theory.py", "equations.py", "kinematics.py", "oblique.py",
                "wall_tangential.py", "tangential_contact.py", "cavitation.py", "ehd.py")
MANY = 1000  # the ode model's sphere count has no limit of its own
# The resolved models mesh the sphere's whole path from its release; beyond this gap (in diameters) the mesh
# grows without telling anything new: a sphere reaches its terminal speed within ~10-20 D of its release.
RESOLVED_MAX_GAP = 100.0

MODELS: dict[str, ModelInfo] = {
    "ode": ModelInfo(
        name="ode", module="fem_bounce.models.ode", class_name="OdeModel",
        liquid="nothing: the near-wall theory force f_thr everywhere", resolved=False,
        resolution_key="numerics.ode.rtol", resolution_unit="", ladder=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7),
        serial=True, trajectory_interval_key="numerics.ode.output_interval", colour="C0",
        sources=("models/ode.py",), max_spheres=MANY, stepper="ode", oblique=True),
    "fd": ModelInfo(
        name="fd", module="fem_bounce.models.fd", class_name="FictitiousDomainModel", chooser="model_class",
        liquid="axisymmetric Taylor-Hood Navier-Stokes (FEniCSx), diffuse-interface sphere", resolved=True,
        resolution_key="numerics.fd.cells_per_diameter", resolution_unit="cells/D",
        ladder=(8.0, 12.0, 16.0, 24.0, 32.0), time_step_key="numerics.fd.peak_cfl",
        scaled_with_time_step=("numerics.fd.forcing_number",), checkpoint_every_key="numerics.fd.checkpoint_every",
        checkpoint_files=("flow.npz",), min_cells_across_blend_gap=1.0, fields_key="numerics.fd.output_every",
        colour="C1", sources=("models/fd", "models/moving_mesh.py", "fem"), max_spheres=MANY,
        max_initial_gap=RESOLVED_MAX_GAP),
    "ib": ModelInfo(
        name="ib", module="fem_bounce.models.ib", class_name="ImmersedBoundaryModel",
        liquid="the paper's IB projection method on a staggered grid", resolved=True,
        resolution_key="numerics.ib.cells_per_diameter", resolution_unit="cells/D",
        ladder=(16.0, 24.0, 32.0, 48.0, 64.0), time_step_key="numerics.ib.cfl",
        checkpoint_every_key="numerics.ib.checkpoint_every", checkpoint_files=("flow.npz",), serial=True,
        min_cells_across_blend_gap=2.0, fields_key="numerics.ib.output_every", colour="C2",
        sources=("models/ib",), max_initial_gap=RESOLVED_MAX_GAP),
    "ale": ModelInfo(
        name="ale", module="fem_bounce.models.ale", class_name="AleModel",
        liquid="moving mesh with the sphere as a hole: the accuracy reference", resolved=True,
        resolution_key="numerics.ale.cells_per_diameter", resolution_unit="cells/D",
        ladder=(8.0, 12.0, 16.0, 24.0, 32.0), time_step_key="numerics.ale.cfl",
        reference_settings=(("numerics.ale.adaptive_step", True), ("numerics.ale.max_step_factor", 1.0),
                            ("numerics.ale.min_step_factor", 0.05), ("numerics.ale.surface_refinement", 3.0)),
        checkpoint_every_key="numerics.ale.checkpoint_every", checkpoint_files=("flow.npz",),
        fields_key="numerics.ale.output_every", colour="C3", max_spheres=8,  # one mesh tag per hole (fem.mesh)
        sources=("models/ale", "models/moving_mesh.py", "fem"), max_initial_gap=RESOLVED_MAX_GAP),
    "fd3d": ModelInfo(
        name="fd3d", module="fem_bounce.models.fd3d.model", class_name="FictitiousDomain3DModel",
        liquid="3-D Taylor-Hood Navier-Stokes on tetrahedra (half box), the sphere's cells held by a penalty on a "
               "mesh that moves with it, head-on or oblique",
        # with the default surface three times finer: 64k unknowns at 6 cells/D, about 100k at 8
        resolved=True, resolution_key="numerics.fd3d.cells_per_diameter", resolution_unit="cells/D",
        ladder=(4.0, 6.0, 8.0), time_step_key="numerics.fd3d.peak_cfl",
        checkpoint_every_key="numerics.fd3d.checkpoint_every", checkpoint_files=("flow.npz",),
        fields_key="numerics.fd3d.output_every", colour="C4",
        sources=("models/fd3d", "models/fd", "fem"), max_initial_gap=RESOLVED_MAX_GAP, oblique=True, three_d=True,
        containers=False),
}

BEST_FIRST = ("ale", "fd", "ib", "ode")  # models.default(): the highest fidelity that imports (not a run's default)
FIDELITY = ("ale", "fd", "ib", "ode")  # which model's finest run serves as a study's reference, first found


@dataclass(frozen=True)
class FrontPick:
    """The models a scene of one kind takes when the run names none, best first (models.choose takes the first
    that can run the scene and imports)."""
    kind: str  # what the scene is, as the printed line says it
    order: tuple  # best first
    why: str  # why the first is first: the measurement behind it (the printed line)


# The packaged picks of `fem-bounce run` and fem_bounce.simulate without a model (docs/usage.md, "Which model a run
# takes").  What the scene is decides the kind (models.scene_kind): off the axis (Scene.oblique), spheres on the axis
# (a pair or more), or one sphere on the axis.  A model is taken only if its entry above runs the scene (oblique,
# max_spheres, max_initial_gap: models.check_scene), so fd3d, first for scenes off the axis, is taken there as soon
# as its entry says oblique=True; head-on scenes never take it (the axisymmetric fd is closer there in 1/25 the time).
FRONT_PICKS: dict[str, FrontPick] = {
    "oblique": FrontPick("a scene off the axis", ("fd3d", "ode"),
                         "the resolved model that runs scenes off the axis"),
    "spheres": FrontPick("spheres on the axis", ("fd", "ale", "ode"),
                         "among the resolved models the best measured accuracy for its time on a pair: "
                         "docs/validation.md section 12"),
    "head-on": FrontPick("one sphere on the axis", ("fd", "ale", "ib", "ode"),
                         "the speed-accuracy front's resolved model for one sphere on the axis: "
                         "docs/performance.md"),
}


def running(spheres: int) -> list[str]:
    """The models that run this many spheres on the axis."""
    return [name for name, info in MODELS.items() if info.max_spheres >= spheres]


def restarting() -> list[str]:
    """The models that write checkpoints and continue with --restart."""
    return [name for name, info in MODELS.items() if info.restarts]
