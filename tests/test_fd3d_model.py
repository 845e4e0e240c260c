"""The 3-D fictitious-domain model's run (`--model fd3d`, fem_bounce.models.fd3d.model): its patch mesh, the mesh
that moves with the sphere, the flow carried to a new mesh, the fall of case 3 against the axisymmetric fd model,
two ranks against one.  A kill and a restart across a new mesh: test_restart.py's "fd3d" case.  The flow's own
checks (exact solutions, rigid modes, the half box): test_fd3d_flow.py.

Toy sizes: 4 cells/D (a half box of ~13k unknowns), a few seconds a run.
"""
from __future__ import annotations


import numpy as np
import pytest
from dolfinx import fem, la
from mpi4py import MPI

from fem_bounce import output, scene
from fem_bounce.models.fd3d.flow import taylor_hood_space
from fem_bounce.models.fd3d.mesh import BoxSpec, create_box_mesh
from fem_bounce.models.fd3d.transfer import interpolate_states
from fem_bounce.run import simulate
from fem_bounce.scene import SceneError

TINY = {"numerics.fd3d.cells_per_diameter": 4, "run.end_time": 0.012}


def run(tmp, model="fd3d", comm=MPI.COMM_WORLD, **overrides):
    settings = {**TINY, **overrides} if model == "fd3d" else overrides
    if model == "fd3d" and settings.get("numerics.fd3d.mesh", "moving") == "moving":
        settings.setdefault("numerics.fd3d.surface_refinement", 1)  # the toy's surface unrefined
    return simulate(scene.load("li2011-case3", settings), model, comm, tmp, force=True, progress=False, plots=False)


# -- the mesh and the transfer ------------------------------------------------------------------------------
def test_the_patch_is_fine_wherever_the_sphere_may_lie_in_it():
    """BoxSpec.travel: the surface size on the surface of every sphere whose centre lies within `travel` of the
    patch's centre along z, growing with the distance beyond; the gap rule keeps its cells under the lowest."""
    spec = BoxSpec(half_width=4.0, height=6.0, center=(0.0, 0.0, 2.0), radius=0.5, surface_size=0.1,
                   coarse_size=1.0, grading=0.3, travel=0.4, gap_cells=2.0, mirrored=True)
    angles = np.linspace(0.0, np.pi, 7)
    for shift in (-0.4, -0.1, 0.0, 0.25, 0.4):
        x, z = 0.5 * np.sin(angles), 2.0 + shift + 0.5 * np.cos(angles)
        assert spec.size_at(x, 0.0 * x, z) == pytest.approx(0.1, rel=1e-12)
    assert spec.size_at(0.0, 0.0, 2.0 + 0.4 + 0.5 + 0.2) == pytest.approx(0.1 + 0.3 * 0.2)
    # under the lowest sphere (its lowest point 1.1 above the wall) at most 1.1 / 2 across
    assert spec.size_at(0.0, 0.0, 0.5) <= 1.1 / 2.0
    assert spec.key() != BoxSpec(**{**spec.__dict__, "travel": 0.3}).key()
    with pytest.raises(ValueError, match="travel must lie in"):
        BoxSpec(**{**spec.__dict__, "travel": 1.5})  # the lowest sphere would cut the wall


@pytest.mark.mpi
def test_the_moving_mesh_carries_the_ball_rigidly_and_keeps_the_box():
    """MeshMotion3D: the ball of the rigid radius moves with the sphere (the indicator's points inside it by the
    sphere's shift, so phi keeps its values), the box's faces stay, the symmetry plane keeps its vertices, and the
    tetrahedra stay valid for a shift of half a radius toward the wall; on any number of ranks."""
    from fem_bounce.models.fd3d.indicator import SphereIndicator
    from fem_bounce.models.fd3d.motion import MeshMotion3D

    spec = BoxSpec(half_width=3.0, height=5.0, center=(0.0, 0.0, 1.5), radius=0.5, surface_size=0.25,
                   coarse_size=1.0, grading=0.4, gap_cells=2.0, mirrored=True)
    mesh, _, facet_tags = create_box_mesh(MPI.COMM_WORLD, spec, cache=False)
    motion = MeshMotion3D(mesh, facet_tags, spec.center, rigid_radius=0.75)
    sphere = SphereIndicator(mesh, 0.5, 0.2, spec.center)
    before, points = sphere.phi.x.array.copy(), sphere._points.copy()
    shift = np.array([0.0, 0.0, -0.25])
    motion.move_to(np.add(spec.center, shift))
    x, X = mesh.geometry.x, motion.reference
    inside = np.linalg.norm(X - spec.center, axis=1) <= 0.75
    assert np.allclose(x[inside] - X[inside], shift, atol=1e-12)
    on_box = (np.abs(X[:, 2]) < 1e-12) | (np.abs(X[:, 2] - 5.0) < 1e-12) | (np.abs(np.abs(X[:, 0]) - 3.0) < 1e-12)
    assert np.allclose(x[on_box], X[on_box], atol=1e-14)
    assert np.allclose(x[:, 1], X[:, 1], atol=1e-14)
    assert motion.quality(shift) > 0.05
    sphere.tabulate()
    sphere.place(np.add(spec.center, shift))
    assert np.allclose(sphere.phi.x.array, before, atol=1e-12)
    assert MPI.COMM_WORLD.allreduce(int((before > 0).any())) > 0  # some rank holds the ball's points
    moved = sphere._points - points
    assert np.allclose(moved[np.linalg.norm(points - spec.center, axis=2) < 0.5], shift, atol=1e-12)


@pytest.mark.mpi
def test_states_the_space_holds_are_carried_to_another_mesh_to_round_off():
    """interpolate_states between two patches' meshes of one box: two levels, each a quadratic velocity and a linear
    pressure, come across exactly with one search for both, on any number of ranks (the points are located across
    them)."""
    comm = MPI.COMM_WORLD

    def mesh_at(z):
        spec = BoxSpec(half_width=3.0, height=5.0, center=(0.0, 0.0, z), radius=0.5, surface_size=0.3,
                       coarse_size=1.0, grading=0.4, mirrored=True, travel=0.3)
        return create_box_mesh(comm, spec, cache=False)[0]

    def state(W, scale):
        w = fem.Function(W)
        w.sub(0).interpolate(lambda x: scale * np.array([x[0] * x[2], x[1] ** 2 - x[2], 1.0 + x[0] * x[1]]))
        w.sub(1).interpolate(lambda x: 2.0 * x[0] - scale * x[2] + 0.5)
        return w

    before, after = taylor_hood_space(mesh_at(1.5)), taylor_hood_space(mesh_at(2.1))
    targets = [fem.Function(after), fem.Function(after)]
    interpolate_states([state(before, 1.0), state(before, -3.0)], targets, padding=1e-8)
    for target, scale in zip(targets, (1.0, -3.0)):
        error = np.abs(target.x.array - state(after, scale).x.array).max(initial=0.0)
        assert comm.allreduce(error, op=MPI.MAX) < 1e-11


@pytest.mark.mpi
def test_the_field_split_projection_gives_the_factorised_one():
    """fem.transfer.DivergenceFreeProjection's field split (the fd3d model's new meshes) against MUMPS on a toy half
    box: the same velocity to 1e-6 of its size, and discretely divergence-free (the weak divergence of the projected
    field 1e-6 of the interpolated one's)."""
    import ufl
    from dolfinx import mesh as dmesh

    from fem_bounce.fem.geometry import Cartesian
    from fem_bounce.fem.transfer import DivergenceFreeProjection

    comm = MPI.COMM_WORLD
    spec = BoxSpec(half_width=3.0, height=5.0, center=(0.0, 0.0, 1.5), radius=0.5, surface_size=0.3, coarse_size=1.0,
                   grading=0.4, mirrored=True, travel=0.3)
    mesh = create_box_mesh(comm, spec, cache=False)[0]
    W = taylor_hood_space(mesh)
    V, _ = W.sub(0).collapse()
    facets = dmesh.locate_entities_boundary(mesh, 2, lambda x: np.isclose(x[2], 0.0))
    wall = fem.locate_dofs_topological((W.sub(0), V), 2, facets)
    bcs = [fem.dirichletbc(fem.Function(V), wall, W.sub(0))]
    geometry = Cartesian(mesh, mirrored=True)
    q = ufl.TestFunctions(W)[1]

    def divergence(w):  # |(q, div u)| over the pressure's test functions, summed over the ranks
        b = fem.assemble_vector(fem.form(ufl.div(ufl.split(w)[0]) * q * ufl.dx))
        b.scatter_reverse(la.InsertMode.add)
        return la.norm(b)

    given = fem.Function(W)
    given.sub(0).interpolate(lambda x: np.array([np.sin(x[0]) * x[2], x[1] * x[2], np.cos(x[0] + x[2]) * x[2]]))
    projected = []
    for solver in ("direct", "fieldsplit"):
        w = given.copy()
        projection = DivergenceFreeProjection(W, bcs, prefix=f"test_projection_{solver}_", solver=solver,
                                              geometry=geometry)
        projection.project(w)
        projection.destroy()
        projected.append(w)
        assert divergence(w) < 1e-6 * divergence(given)
    size = comm.allreduce(np.abs(projected[0].x.array).max(initial=0.0), op=MPI.MAX)
    difference = comm.allreduce(np.abs(projected[0].x.array - projected[1].x.array).max(initial=0.0), op=MPI.MAX)
    assert difference < 1e-6 * size


# -- the model ----------------------------------------------------------------------------------------------
def test_what_the_head_on_model_does_not_run_is_refused_before_anything_is_written():
    from fem_bounce.models.fd3d.model import FictitiousDomain3DModel

    with pytest.raises(SceneError, match="the fd3d model runs one sphere"):
        FictitiousDomain3DModel(scene.load("yang-hunt2006-pair"), MPI.COMM_SELF)
    with pytest.raises(SceneError, match="runs a free sphere"):
        FictitiousDomain3DModel(scene.load("li2011-case3", {"motion.mode": "fixed", "motion.velocity": -0.1}),
                                MPI.COMM_SELF)
    # a setting the chosen mesh reads nowhere
    with pytest.raises(SceneError, match="surface_refinement refines the moving mesh only"):
        FictitiousDomain3DModel(scene.load("li2011-case3", {"numerics.fd3d.mesh": "fixed",
                                                            "numerics.fd3d.surface_refinement": 2}), MPI.COMM_SELF)
    with pytest.raises(SceneError, match="interface_width shapes the fixed mesh's band only"):
        FictitiousDomain3DModel(scene.load("li2011-case3", {"numerics.fd3d.interface_width": 3}), MPI.COMM_SELF)
    # fixed steps are never shortened: one that could jump the contact's gap is refused, a shorter one runs
    with pytest.raises(SceneError, match="numerics.fd3d.peak_cfl up to"):
        FictitiousDomain3DModel(scene.load("li2011-case3", {"numerics.fd3d.adaptive_step": False,
                                                            "numerics.fd3d.peak_cfl": 5}), MPI.COMM_SELF)
    FictitiousDomain3DModel(scene.load("li2011-case3", {"numerics.fd3d.adaptive_step": False}), MPI.COMM_SELF)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:numerics.fd.cells_per_diameter = 4 puts")  # the 2-D model's warning at 4 cells/D
@pytest.mark.parametrize("mesh", ["fixed", "moving"])
def test_case3_falls_as_the_axisymmetric_fd_model_does(tmp_path, mesh):
    """Case 3's first 12 ms at 4 cells/D: the 3-D half box against the axisymmetric fd model on the same kind of mesh
    (the same implicit penalty at the same resolution; the moving meshes with the sphere's surface a surface of the
    mesh, the 2-D one unrefined there) within 3 % in the speed; the fixed mesh factorises every step, the moving
    one keeps its factors over steps; the field files are written (XDMF, with the moving mesh's displacement)."""
    summary = run(tmp_path / "fd3d", **{"numerics.fd3d.output_every": 2, "numerics.fd3d.mesh": mesh})
    axis = {"numerics.fd.mesh": mesh, "numerics.fd.cells_per_diameter": 4, "run.end_time": 0.012}
    if mesh == "moving":
        axis["numerics.fd.surface_refinement"] = 1.0
    run(tmp_path / "fd", model="fd", **axis)
    a, b = output.read_trajectory(tmp_path / "fd3d"), output.read_trajectory(tmp_path / "fd")
    speed, reference = np.interp(0.01, a["t"], a["velocity"]), np.interp(0.01, b["t"], b["velocity"])
    assert reference < -0.05
    assert speed == pytest.approx(reference, rel=0.03)
    report = summary["fd3d"]
    assert summary["status"] == "completed" and report["remeshes"] == 0
    if mesh == "fixed":
        assert report["factorisations"] == summary["steps"] and summary["sizes"]["unknowns"] > 5000
    else:
        assert report["factorisations"] < summary["steps"] / 2 and report["krylov_iterations"] > 0
    assert 0.0 < report["added_mass_over_displaced"] < 3.0
    assert (tmp_path / "fd3d" / "fields-000.xdmf").is_file() and (tmp_path / "fd3d" / "fields-000.h5").is_file()


@pytest.mark.slow
def test_the_whole_box_falls_as_the_half_box_and_measures_the_flow_across_the_plane(tmp_path):
    """numerics.fd3d.box = "whole": the same fall as the half box's (its mesh is not the half box's mirrored, so to
    within 1 %), and the flow's force across the plane of incidence and torque about the axes in it, which the half box
    holds at zero, measured: present (the mesh is not symmetric), and what they would have given the sphere, small
    against its speed."""
    half = run(tmp_path / "half")
    whole = run(tmp_path / "whole", **{"numerics.fd3d.box": "whole"})
    a, b = output.read_trajectory(tmp_path / "half"), output.read_trajectory(tmp_path / "whole")
    assert np.interp(0.01, b["t"], b["velocity"]) == pytest.approx(np.interp(0.01, a["t"], a["velocity"]), rel=0.01)
    assert whole["sizes"]["unknowns"] > 1.4 * half["sizes"]["unknowns"] and "out_of_plane" not in half["fd3d"]
    across = whole["fd3d"]["out_of_plane"]
    assert across["peak_force_n"] > 0.0 and across["peak_torque_n_m"] > 0.0
    speed = abs(b["velocity"][-1])
    assert 0.0 < across["velocity_across_m_s"] < 1e-2 * speed
    assert 0.0 < across["spin_across_1_s"] * 0.0127 / 2 < 1e-2 * speed  # a spin's surface speed


@pytest.mark.parametrize("adaptive", [True, False])
def test_a_run_ends_at_its_end_time(tmp_path, adaptive):
    """The last step, adaptive or fixed, is shortened to end at run.end_time (through the variable-step BDF2)."""
    end = 0.0095
    summary = run(tmp_path, **{"numerics.fd3d.adaptive_step": adaptive, "run.end_time": end})
    trajectory = output.read_trajectory(tmp_path)
    assert summary["status"] == "completed" and summary["steps"] > 3
    assert trajectory["t"][-1] == pytest.approx(end, rel=1e-9)


@pytest.mark.slow
def test_an_oblique_impact_slides_spins_and_closes_its_energy_account(tmp_path):
    """Case 3's sphere launched at the wall 30 degrees off the normal without gravity (tests/test_oblique.py's
    scene) at 4 cells/D: the flow's force along the wall and its torque enter the sphere's equations with their
    added mass, the mesh follows the sphere along the wall, the contact's friction slows the contact point and spins
    the sphere up in the rolling sense, and the audits of the momentum and of the energy along the wall close."""
    from test_oblique import case3_oblique

    settings = {"numerics.fd3d.cells_per_diameter": 4, "numerics.fd3d.surface_refinement": 1}
    summary = simulate(case3_oblique(30.0).replace(**settings), "fd3d", MPI.COMM_WORLD, tmp_path, force=True,
                       progress=False, plots=False)
    assert summary["status"] == "completed" and summary["fd3d"]["remeshes"] >= 1
    contact = summary["oblique_impacts"][0]["contact"]
    assert 0.0 < contact["psi_out"] < contact["psi_in"]
    assert contact["spin_out"] > contact["spin_in"] and contact["spin_out"] > 0.0
    # it slides throughout (psi_in above 7/2 mu (1 + e_n)): the Coulomb friction 0.02 and the liquid's share, which
    # may take a little of it back (the added mass's reaction pushes a sphere the friction slows)
    assert 0.9 * 0.02 < contact["effective_friction"] < 0.03
    assert 0.8 < summary["fd3d"]["tangential_added_mass_over_displaced"] / summary["fd3d"][
        "added_mass_over_displaced"] < 1.25  # parallel and normal at a gap of 0.4 D: both near 1/2 and the wall's
    losses = summary["impacts"][0]["losses"]
    assert "tangential" in losses, losses.get("tangential_skipped")
    trajectory = output.read_trajectory(tmp_path)
    assert trajectory["x"][-1] > 0.5 * 0.39 * np.sin(np.radians(30.0)) * trajectory["t"][-1]


def test_the_box_follows_a_sphere_sliding_along_the_wall(tmp_path):
    """Each new mesh centres the box on the sphere along the wall: one launched fast along it in the smallest box
    (far_field 2 D, its sides 2 D from the release) slides past where the first box's side was, and the run ends at
    its end time, the flow carried to each new box.  Held near the wall it shears the cells between its rigid layer
    and the wall (at this size they turn inside out after 0.15 D of sliding): a new mesh comes before that.  (At
    1.5 m/s it passed the side with the flow's force held at each step's end value, 26.7 mm; with the force taken
    linearly through this size's 4 ms steps the launch's drag is carried into the second step, and it reached 20.0
    mm: it is launched at 2.5 m/s.)"""
    sliding = scene.load("li2011-case3", {**TINY, "numerics.fd3d.surface_refinement": 1, "numerics.fd3d.far_field": 2,
                                          "tangential_velocity": 2.5, "contact.friction": 0.02, "gravity": 0.0,
                                          "initial_velocity": -0.2, "initial_gap": 0.00475, "run.end_time": 0.025})
    summary = simulate(sliding, "fd3d", MPI.COMM_WORLD, tmp_path, force=True, progress=False, plots=False)
    assert summary["status"] == "completed" and summary["fd3d"]["remeshes"] >= 6
    assert summary["fd3d"]["sheared_remeshes"] >= 1 and summary["fd3d"]["worst_quality_over_made"] >= 0.5
    trajectory = output.read_trajectory(tmp_path)
    assert trajectory["t"][-1] == pytest.approx(0.025, rel=1e-9)
    assert trajectory["x"][-1] > 2.0 * 0.0127  # its centre past the first box's side
    # slowed by the liquid (the launch gives it its added mass's momentum at once), and no new box kicks it: past the
    # launch no step changes it by more than 0.05 m/s (a larger box's run changes it as much)
    along, later = trajectory["tangential_velocity"], trajectory["t"][1:] > 0.008
    assert 0.5 < along[-1] < 1.2 and np.abs(np.diff(along))[later].max() < 0.05


@pytest.mark.slow
@pytest.mark.mpi
def test_two_ranks_give_the_serial_trajectory(shared_tmp):
    """Every rank also runs the same scene alone (COMM_SELF): the trajectories agree to solver precision, across a
    new mesh (a short patch: 0.1 D of travel)."""
    comm = MPI.COMM_WORLD
    short = {"numerics.fd3d.patch_margin": 0.2, "run.end_time": 0.02}
    parallel = run(shared_tmp / "parallel", comm=comm, **short)
    serial = run(shared_tmp / f"serial-{comm.rank}", comm=MPI.COMM_SELF, **short)
    assert parallel["ranks"] == comm.size and serial["ranks"] == 1
    assert parallel["fd3d"]["remeshes"] == serial["fd3d"]["remeshes"] >= 1
    a = output.read_trajectory(shared_tmp / "parallel")
    b = output.read_trajectory(shared_tmp / f"serial-{comm.rank}")
    assert len(a["t"]) == len(b["t"])
    assert np.allclose(a["velocity"], b["velocity"], rtol=1e-7, atol=1e-10)
    assert np.allclose(a["f_sim"], b["f_sim"], rtol=1e-6, atol=1e-9)
