"""What a model refuses or warns about in the scene it is given: a resolution below what it resolves, a sphere, a
pair or a mesh its domain cannot hold, settings it ignores, the serial model under mpiexec.  A refusal is one line,
exit 2, nothing written."""
import subprocess
import sys

import pytest

from helpers import ODE, assert_one_line, refused, refused_same_listing, run_cli


# -- resolution -------------------------------------------------------------------------------------------------------


def test_ib_too_coarse_for_its_kernel_says_so(tmp_path, monkeypatch, capsys):
    """At 2 cells/D the ib model said the sphere left a region that its own numbers placed it inside."""
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "ib", "--quiet",
                            "--set", "numerics.ib.cells_per_diameter=2")
    assert status == 2
    assert_one_line(lines, "error: numerics.ib: at 2 cells/D the delta kernel reaches 0.75 D",
                    "raise numerics.ib.cells_per_diameter")
    assert list(tmp_path.iterdir()) == []


def test_fd_below_what_it_resolves_warns(tmp_path, capsys):
    """fd at 2 cells/D ran without a word (V_i -13 %, apex -22 % against 12 cells/D)."""
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "fd", "--quiet", "--set",
                            "numerics.fd.cells_per_diameter=2", "--set", "run.end_time=0.002",
                            "--out", str(tmp_path / "run"))
    assert status == 0
    assert_one_line(lines, "warning: numerics.fd.cells_per_diameter = 2 puts 0.4 fine cells across the delta_sl gap")


# -- what the domain holds --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", ["ale", "fd"])
def test_a_sphere_wider_than_the_domain_is_refused(model, tmp_path, monkeypatch, capsys):
    """second_sphere.diameter = 1000: a ValueError with ale, a std::bad_alloc abort with fd."""
    refused(capsys, tmp_path, monkeypatch, "run", "pair-settling-wall", "--model", model, "--quiet", "--out", "r",
            "--set", "second_sphere.diameter=1000",
            message=f"second_sphere.diameter = 1000 m does not fit in the {model} model's domain")


@pytest.mark.parametrize("model", ["ale", "fd"])
def test_a_mesh_beyond_memory_is_refused(model, tmp_path, monkeypatch, capsys):
    """container.radius = height = 100 m: the ale model meshed the whole container (2.6e8 triangles) ignoring
    SIGTERM."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--model", model, "--quiet", "--out", "r",
            "--set", "container.radius=100", "--set", "container.height=100",
            message=f"numerics.{model}: its mesh of this scene would have ~2.6e+08 triangles")


def test_pair_refused_by_fd_writes_nothing(tmp_path, monkeypatch, capsys):
    """The refusal came after the marker, scene.toml, a header-only trajectory and a 64 kB reserve."""
    refused_same_listing(
        capsys, tmp_path, monkeypatch, "run", "yang-hunt2006-pair", "--model", "fd", "--quiet", "--out", "r",
        "--set", "numerics.fd.cells_per_diameter=6", "--set", "numerics.fd.constraint=penalty",
        "--set", "numerics.fd.mesh=fixed", message="spheres' indicators overlap")


# -- settings a model ignores -----------------------------------------------------------------------------------------


def test_the_ode_model_says_it_ignores_the_container(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "r", "--set", "run.bounces=1",
                            "--set", "container.radius=0.02", "--set", "container.height=0.1")
    assert status == 0
    assert_one_line([line for line in lines if "warning" in line], "ignores [container]")


@pytest.mark.parametrize("case", ["pause with ale", "cavitation true", "serial warning under mpiexec"])
def test_settings_say_what_they_do(case, tmp_path, monkeypatch, capsys, mpiexec):
    """history_across_contact = "pause" had no effect with ale, silently; cavitation_pressure = true said "must be
    a string" though numbers are allowed; under mpiexec the "serial model" warning came before a refusal."""
    if case == "pause with ale":
        status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "ale", "--quiet", "--out",
                                str(tmp_path / "r"), "--set", "contact.history_across_contact=pause",
                                "--set", "run.end_time=0.005", "--set", "numerics.ale.cells_per_diameter=4")
        assert status == 0
        assert_one_line(lines, 'warning: contact.history_across_contact = "pause" has no effect with the ale model')
    elif case == "cavitation true":
        refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set",
                "contact.cavitation_pressure=true", message="contact.cavitation_pressure = True must be 'auto', "
                "'liquid', 'off' or a number in [-1e+08, 0] Pa")
    else:
        (tmp_path / "notes").mkdir()
        (tmp_path / "notes" / "keep.txt").write_text("keep")
        ended = subprocess.run([mpiexec, "-n", "2", sys.executable, "-m", "fem_bounce", "run", "li2011-case3", *ODE,
                                "--out", "notes", "--force"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert ended.returncode == 2
        assert_one_line(ended.stderr.splitlines(), "error: notes is not a fem-bounce run directory")
