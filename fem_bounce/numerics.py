"""Numerical settings per model: the `[numerics.<model>]` tables of a scene.

Only numbers live here (no solver code), so a scene can be loaded and checked
without importing dolfinx.  Lengths given "per diameter" scale with the sphere.
"""
from __future__ import annotations

from dataclasses import dataclass, field


def _setting(default, lo, hi, unit=""):
    return field(default=default, metadata={"range": (lo, hi, False, False), "unit": unit})


@dataclass(frozen=True)
class OdeNumerics:
    rtol: float = _setting(1e-5, 1e-12, 1e-2)
    atol: float = _setting(1e-8, 1e-16, 1e-3)  # on gap [m], velocity [m/s] and history states
    history_modes_per_decade: int = _setting(3, 1, 10)
    output_interval: float = _setting(0.0, 0.0, 1.0, "s")  # trajectory rows; 0: every step
    # a resolved flow's force through its fluid step (its part not from the accelerations, FluidForce.explicit):
    # "linear" from the step before's value at the step's start to the step's own at its end, the trapezoidal rule,
    # second order in the step (the step after a contact holds its own); "end" the end's value held through the step,
    # the rectangle rule, first order, the default until 2026-12-08 (validation.md section 12, "The flow's force
    # through a step")
    flow_force: str = field(default="linear", metadata={"choices": ("linear", "end")})


@dataclass(frozen=True)
class FdNumerics:
    """The fictitious-domain model (fem_bounce.models.fd).  Sizes are per sphere diameter D; what each default
    buys and costs is measured in docs/validation.md section 12 and docs/performance.md."""

    # fine triangle size D / this along the spheres' paths (and on their surfaces, surface_refinement times finer,
    # on the moving mesh); the fixed mesh needs several times more for the same rebound
    cells_per_diameter: float = _setting(8.0, 2.0, 400.0)
    coarse_cells_per_diameter: float = _setting(1.0, 0.02, 400.0)  # largest triangles, far away
    # size growth per unit distance from the fine region; unset: the mesh's own, 0.2 on the moving mesh (its fine
    # surface carries the accuracy), 0.1 on the fixed one (the band's neighbourhood does)
    grading: float | None = field(default=None, metadata={"range": (0.01, 2.0, False, False), "unit": ""})
    refined_radius: float = _setting(1.0, 0.5, 100.0)  # the fine region r <= this * D (the wake needs the width)
    # fixed mesh: the fine region only around each sphere, z within patch_margin D of its surface (down to the wall
    # once it is that near), moved with a new mesh when a sphere's centre strays half the margin from the patch's
    # (models/fd/model.py); false, or every sphere held: along the whole path
    patch: bool = True
    patch_margin: float = _setting(0.75, 0.1, 20.0)
    # "moving": the mesh follows the spheres as the ale model's does (models/fd/moving.py), each sphere's surface a
    # curve of the mesh and its inside meshed and held by the implicit constraint, remade when a triangle's quality
    # would fall below min_quality; the fixed mesh's settings (patch, patch_margin, radius_offset, the wall box) are
    # refused with it (models/fd/moving.py FIXED_MESH_ONLY).  "fixed": one mesh the spheres move through (patches or
    # the whole path); the one-shot penalty and steady_stokes run on it only
    mesh: str = field(default="moving", metadata={"choices": ("moving", "fixed")})
    # moving mesh, as numerics.ale's: the surface's triangles this many times finer than the path's (the error
    # lives in the surface's triangles, the rebound more than the impact); remeshing below min_quality; a remeshed
    # gap keeps min_gap_cells triangles across; the mesh stops following a moving sphere at the gap hold_delta D (only
    # where the near-wall correction does not hold it at delta_sl D: set with the correction holding every contact,
    # with every sphere held, or on the fixed mesh, it is refused)
    surface_refinement: float = _setting(5.0, 1.0, 16.0)
    min_quality: float = _setting(0.3, 0.01, 0.9)
    min_gap_cells: float = _setting(2.0, 0.5, 100.0)
    hold_delta: float = _setting(0.02, 0.0, 0.5)
    wake_length: float = _setting(2.0, 0.0, 100.0)  # fine region beyond the sphere, downstream, in D
    far_field: float = _setting(10.0, 2.0, 200.0)  # unbounded domain: radius and headroom, in D
    # fixed mesh: the gap under the sphere's path, triangles D / wall_cells_per_diameter (0: no wall box) in
    # r <= wall_radius D, z <= wall_layer D, where the squeeze flow lives
    wall_cells_per_diameter: float = _setting(0.0, 0.0, 800.0)
    wall_layer: float = _setting(0.25, 0.01, 5.0)
    wall_radius: float = _setting(0.6, 0.05, 10.0)
    # the Courant number at the peak fluid speed, 1.5 U at a sphere's equator: dt <= peak_cfl * fine size / (1.5
    # speed scale) (numerics.ale.cfl and numerics.ib.cfl are at the speed scale U); unset: the constraint's own, 0.2
    # for "penalty" (its convection is explicit, and this is its stability bound), for "implicit" an accuracy choice
    # (no step bound): 0.8 on the moving mesh, 0.4 on the fixed one, whose band needs the finer step.  "penalty"
    # refuses a step that could close more than a contact's gap (its steps are never shortened:
    # flow_model.safe_fixed_step names the largest peak_cfl)
    peak_cfl: float | None = field(default=None, metadata={"range": (0.01, 50.0, False, False), "unit": ""})
    # adaptive_step: each step between min_step_factor and max_step_factor times the peak_cfl step, as short as the
    # approach to a contact (a step closes at most gap_fraction of the gap at the sphere's speed) and the changes of
    # the sphere's velocity ask (flow_model.StepLimits); unset: the constraint's own, true for "implicit" (it
    # assembles every step anyway) at time_order 1 or 2, false for "penalty" (it keeps its factors: one step length).
    # Whatever the floor and from rest, a step closes at most twice gap_fraction of the gap with the sphere's
    # speed and net weight (flow_model.Approach): at most 0.5, so that no step reaches the contact; fixed steps
    # (false, "implicit") are shortened only where they could close more than the gap (for one sphere never at the
    # default peak_cfl)
    adaptive_step: bool | None = None
    min_step_factor: float = _setting(0.05, 0.001, 1.0)
    max_step_factor: float = _setting(2.0, 1.0, 50.0)
    gap_fraction: float = _setting(0.5, 0.001, 0.5)
    forcing_number: float = _setting(0.025, 0.001, 10.0)  # penalty only: dt <= this * fine size^2 / nu (rigid interior)
    # "implicit": the friction rho c_B phi (u - U) in the step's matrix, with convection implicit, factorised every
    # step (models/fd/penalised.py): no step bound from either, the interior rigid through a collision.
    # "penalty": the one-shot forcing rho c phi (U - u~), c = 3 / (2 dt), on a matrix factorised once, rigid only
    # under forcing_number; its effective surface moves with dt, so radius_offset places it at its default step
    constraint: str = field(default="implicit", metadata={"choices": ("implicit", "penalty")})
    # implicit: c_B over the viscous, convective and step rates; the penalisation's error falls as strength^-1/2
    # (Angot, Bruneau & Fabrie 1999), so the default is large.  Below 100 it no longer holds the sphere (case 3 at
    # 4 cells/D, moving mesh: V_i +2.2 % at 100, +3.9 % and e +14 % at 20, the run gaining energy and diverging at
    # 10 and below; +0.6 % at 1e3, 0.08 % at 1e4); "penalty" does not read it (its forcing_number sets its rigidity)
    penalty_strength: float = _setting(1e5, 100.0, 1e8)
    time_order: int = _setting(2, 1, 3)  # BDF/extrapolation order of the flow
    # "direct": MUMPS LU, factorised once; "fieldsplit": GMRES with a Schur field split and algebraic multigrid
    # (BoomerAMG, or GAMG where PETSc has no hypre; options prefix fd_flow_fieldsplit_), for large meshes on many
    # ranks (docs/performance.md)
    solver: str = field(default="direct", metadata={"choices": ("direct", "fieldsplit")})
    interface_width: float = _setting(2.0, 0.25, 10.0)  # band inside the surface where phi falls to 0, in fine cells
    # the indicator's outer edge at a + this * fine size; unset: the constraint's own, 0.5 for "penalty" (its
    # effective surface half a cell inside the edge at its default step), 0 for "implicit" (the edge holds)
    radius_offset: float | None = field(default=None, metadata={"range": (-3.0, 3.0, False, False), "unit": ""})

    def resolved(self, name: str) -> float:
        """A setting's value, the constraint's (the mesh's) own when it is unset (peak_cfl, radius_offset,
        adaptive_step; grading)."""
        value = getattr(self, name)
        if value is not None:
            return value
        penalty = self.constraint == "penalty"
        return {"peak_cfl": 0.2 if penalty else (0.8 if self.moving else 0.4), "radius_offset": 0.5 if penalty else 0.0,
                "adaptive_step": not penalty and self.time_order < 3,
                "grading": 0.2 if self.moving else 0.1}[name]

    @property
    def moving(self) -> bool:
        """The model runs on the moving mesh: mesh = "moving", unless steady_stokes (solved on the fixed one)."""
        return self.mesh == "moving" and not self.steady_stokes

    output_every: int = _setting(0, 0, 10**9)  # XDMF fields every N steps; 0: none
    checkpoint_every: int = _setting(200, 0, 10**9)  # 0: no checkpoints
    steady_stokes: bool = False  # held sphere at Re -> 0: solve for the step's steady state, no marching
    # "implicit": the sphere integrator gets F* and the numerical added mass (stable for light spheres);
    # "explicit": F at the extrapolated velocity only, the classical lagged coupling (for comparison; the classical
    # scheme holds it through each step: numerics.ode.flow_force = "end")
    coupling: str = field(default="implicit", metadata={"choices": ("implicit", "explicit")})


@dataclass(frozen=True)
class IbNumerics:
    """Immersed-boundary model (fem_bounce.models.ib).  Lengths in sphere diameters or fine cells."""

    cells_per_diameter: float = _setting(32.0, 2.0, 400.0)  # fine uniform spacing h = D / this
    # dt = cfl * h / speed scale (the expected impact speed), halved where a step could close more than the gap
    cfl: float = _setting(0.4, 0.01, 2.0)
    max_cfl: float = _setting(1.0, 0.05, 5.0)  # measured CFL above this halves dt (refactorises)
    viscous_cfl: float = _setting(5.0, 0.1, 1e6)  # and dt <= viscous_cfl * h^2 / nu
    far_field: float = _setting(15.0, 1.0, 200.0)  # unbounded: slip boundary this far beyond the fine region
    growth: float = _setting(1.1, 1.0, 1.5)  # cell size ratio outside the fine region
    fine_radius: float = _setting(1.0, 0.55, 50.0)  # uniform cells from the axis out to this radius
    fine_margin: float = _setting(1.0, 0.1, 50.0)  # and this far above and below the sphere's path
    point_spacing: float = _setting(1.0, 0.3, 3.0)  # Lagrangian points on the meridian, in cells
    retraction: float = _setting(0.0, 0.0, 1.0)  # points on radius a - retraction * h (Breugem 2012)
    wall_exclusion: float = _setting(0.5, 0.0, 3.0)  # points nearer the wall than this (cells) are released
    force_tolerance: float = _setting(1e-6, 1e-12, 1e-2)  # rms slip left by CG, relative to the speed scale
    # implicit: the flow's response to the new sphere velocity goes to the integrator (stable for any
    # density ratio); explicit: the flow follows the old velocity (as the paper's RK2; for comparison)
    coupling: str = field(default="implicit", metadata={"choices": ("implicit", "explicit")})
    output_every: int = _setting(0, 0, 10**9)  # XDMF fields every N steps; 0: none
    checkpoint_every: int = _setting(200, 0, 10**9)  # 0: no checkpoints


@dataclass(frozen=True)
class AleNumerics:
    """The boundary-fitted ALE model (fem_bounce.models.ale).  Sizes are per sphere diameter D."""

    cells_per_diameter: float = _setting(8.0, 2.0, 400.0)  # triangle size D / this on the sphere and along its path
    # the sphere's surface triangles this many times finer (the rebound's error lives in them, as on the fd model's
    # moving mesh: the default D / 40 with 8 cells/D along the path, as fd's; docs/validation.md section 12)
    surface_refinement: float = _setting(5.0, 1.0, 16.0)
    coarse_cells_per_diameter: float = _setting(1.0, 0.02, 400.0)  # largest triangles, far away
    grading: float = _setting(0.1, 0.01, 2.0)  # triangle size growth per unit distance from the fine region
    refined_radius: float = _setting(1.0, 0.5, 100.0)  # fine region r <= this * D along the path
    wake_length: float = _setting(2.0, 0.0, 100.0)  # fine region beyond the sphere, downstream, in D
    far_field: float = _setting(10.0, 2.0, 200.0)  # unbounded domain: radius and headroom, in D
    cfl: float = _setting(0.5, 0.01, 20.0)  # dt = cfl * fine size / speed scale (convection is implicit)
    time_order: int = _setting(2, 1, 2)  # BDF order of the flow and the mesh motion
    # adaptive_step: each step between min_step_factor and max_step_factor times the cfl step, as short as the
    # approach to a contact and the changes of the sphere's velocity ask (models/ale/domain.py next_time_step): each
    # collision resolved in time, as the reference's (benchmarks/near_wall.py reference); false: the cfl step
    # throughout, shortened only where it could close more than the gap (flow_model.Approach), which spans the
    # ~50 us contact in one step (docs/validation.md section 12 measures both on case 3)
    adaptive_step: bool = True
    min_step_factor: float = _setting(0.05, 0.001, 1.0)
    max_step_factor: float = _setting(1.0, 1.0, 50.0)
    min_quality: float = _setting(0.3, 0.01, 0.9)  # remesh when a triangle's quality would fall below this
    min_gap_cells: float = _setting(2.0, 0.5, 100.0)  # a remeshed gap has at least this many triangles across
    hold_delta: float = _setting(0.02, 0.0, 0.5)  # the mesh stops following the sphere at this gap / D
    fixed_solver: str = field(default="steady", metadata={"choices": ("steady", "march")})  # held sphere
    # how the step's matrix is solved: "every-step": factorised every step; "reuse": flexible GMRES preconditioned
    # by the factors of an earlier step's matrix, factorised again when that pays (models/ale/flow.py)
    factorisation: str = field(default="reuse", metadata={"choices": ("reuse", "every-step")})
    # reuse: factorise again when a step's GMRES iterations exceed their average since the last factorisation
    # with a factorisation counted as this many iterations (a renewal rule, fem.solver.ReusedFactorOperator),
    # or when one solve needs more than reuse_iterations
    factorisation_cost: float = _setting(20.0, 0.0, 1000.0)  # in back-solves, as measured (docs/performance.md)
    reuse_iterations: int = _setting(30, 1, 100)
    # reuse: GMRES stops at |b - A x| <= this |b| without the Dirichlet rows; tight, because the force on the sphere
    # is a small residual of the stream's terms (docs/performance.md gives what looser values cost in accuracy)
    krylov_rtol: float = _setting(1e-7, 1e-14, 1e-3)
    output_every: int = _setting(0, 0, 10**9)  # XDMF fields every N steps; 0: none
    checkpoint_every: int = _setting(100, 0, 10**9)  # 0: no checkpoints


@dataclass(frozen=True)
class Fd3dNumerics:
    """The three-dimensional fictitious-domain model (fem_bounce.models.fd3d): one sphere, head-on or oblique, in a
    box of tetrahedra (the half y >= 0 of it by default).  Sizes are per sphere diameter D."""

    # tetrahedra D / this on the sphere's surface (on the fixed mesh wherever the patch lets it lie), and in the gap
    cells_per_diameter: float = _setting(6.0, 2.0, 100.0)
    coarse_cells_per_diameter: float = _setting(0.5, 0.02, 100.0)  # largest tetrahedra, far away
    grading: float = _setting(0.3, 0.05, 2.0)  # size growth per unit distance from the fine shell
    # "moving": the mesh moves with the sphere (models/fd3d/motion.py: the ball and a layer of cells around it
    # rigidly), so the penalty stays on the same cells and the step's factors are kept over many steps; "fixed": the
    # sphere moves through a mesh fine in a patch around it
    mesh: str = field(default="moving", metadata={"choices": ("moving", "fixed")})
    # "half": the half box y >= 0 of a flow symmetric about the plane of incidence y = 0 (half the unknowns);
    # "whole": the whole box, the sphere still moving in that plane, and the flow's force across the plane and its
    # torque about the axes in it reported (summary.json's fd3d.out_of_plane, with the velocity across the plane and
    # the spin they would have given the sphere): the check that the half box's symmetry holds (docs/validation.md
    # section 14)
    box: str = field(default="half", metadata={"choices": ("half", "whole")})
    # moving mesh: the sphere's surface's tetrahedra this many times finer than cells_per_diameter's (the gap below
    # and the rest keep those): the rebound's error lives in the surface's cells
    surface_refinement: float = _setting(3.0, 1.0, 8.0)
    # a new mesh (the flow interpolated and made divergence-free) when the sphere has moved patch_margin / 2 D from
    # where the mesh was made (on the fixed mesh the fine shell covers every place within that; on the moving mesh
    # also when the gap under the sphere has halved or doubled since)
    patch_margin: float = _setting(0.75, 0.1, 20.0)
    gap_cells: float = _setting(2.0, 0.0, 20.0)  # at least this many tetrahedra across the gap under the sphere
    far_field: float = _setting(6.0, 2.0, 100.0)  # the box: half width and headroom above the path's top, in D
    # fixed mesh: the indicator's band inside the surface, in fine cells (the moving mesh holds the ball's cells whole)
    interface_width: float = _setting(2.0, 0.5, 10.0)
    # c_B over the viscous, convective and step rates (numerics.fd.penalty_strength's meaning and floor)
    penalty_strength: float = _setting(1e5, 100.0, 1e8)
    # the Courant number at the peak fluid speed (numerics.fd.peak_cfl's meaning): dt = peak_cfl * fine size / (1.5
    # speed scale)
    peak_cfl: float = _setting(0.4, 0.01, 50.0)
    # each step between min_step_factor and max_step_factor times the peak_cfl step, as short as the approach to the
    # wall and the changes of the sphere's velocity ask (flow_model.StepLimits; numerics.fd's meaning)
    adaptive_step: bool = True
    min_step_factor: float = _setting(0.05, 0.001, 1.0)
    max_step_factor: float = _setting(2.0, 1.0, 50.0)
    gap_fraction: float = _setting(0.5, 0.001, 0.5)
    output_every: int = _setting(0, 0, 10**9)  # XDMF fields every N steps; 0: none
    checkpoint_every: int = _setting(100, 0, 10**9)  # 0: no checkpoints
