"""Layers that only look down (docs/architecture.md, "The layers"): every module of fem_bounce has a layer, and
each of its imports of the package, at module level or inside a function, goes to its own layer or a lower
one, with no circle.  The imports are read from the source (ast), so an import deferred into a function
counts as much as one at the top: a deferred import that hides a circle is still a circle.

A new module needs a line in LAYERS: decide where it sits before it can import anything."""
from __future__ import annotations

import ast
from pathlib import Path

import fem_bounce

PACKAGE = Path(fem_bounce.__file__).parent

# The layers, lowest first; a module may import its own layer and those below it.
FOUNDATIONS, SCENE, BODIES, PHYSICS, INTEGRATOR, FLOW, OUTPUTS, FEM, MODELS, RUN, STUDIES, API, CLI = range(13)
LAYER_NAMES = ("foundations", "scene", "bodies", "physics", "integrator", "flow", "outputs", "fem", "models", "run",
               "studies", "api", "cli")

LAYERS = {
    # what everything reads: errors, data, the version, the material scales the scene's checks need
    "fem_bounce._version": FOUNDATIONS,
    "fem_bounce.errors": FOUNDATIONS,
    "fem_bounce.numerics": FOUNDATIONS,
    "fem_bounce.reference": FOUNDATIONS,
    "fem_bounce.materials": FOUNDATIONS,
    # the scene imports none of the physics that reads it
    "fem_bounce.scene": SCENE,
    "fem_bounce.uncertain": SCENE,  # uncertain settings: ranges checked against the scene's metadata
    "fem_bounce.motion": BODIES,
    "fem_bounce.bodies": BODIES,
    "fem_bounce.kinematics": BODIES,
    # the liquid's theory, the contact law, the film collision
    "fem_bounce.theory": PHYSICS,
    "fem_bounce.pair_theory": PHYSICS,
    "fem_bounce.ehd": PHYSICS,
    "fem_bounce.cavitation": PHYSICS,
    "fem_bounce.contact": PHYSICS,
    "fem_bounce.pair_contact": PHYSICS,
    "fem_bounce.wall_tangential": PHYSICS,
    "fem_bounce.wall_lift": PHYSICS,
    "fem_bounce.tangential_contact": PHYSICS,
    "fem_bounce.oblique": PHYSICS,
    "fem_bounce.pair_oblique": PHYSICS,
    # the bodies' equations of motion and their bounce records
    "fem_bounce.bounces": INTEGRATOR,
    "fem_bounce.equations": INTEGRATOR,
    "fem_bounce.integrator": INTEGRATOR,
    # the interface every model implements, and how time advances through it
    "fem_bounce.flow_model": FLOW,
    "fem_bounce.steppers": FLOW,
    # the run directory, its readers and figures, the libraries' log, the progress line
    "fem_bounce.output": OUTPUTS,
    "fem_bounce.cachedir": OUTPUTS,
    "fem_bounce.library_log": OUTPUTS,
    "fem_bounce.progress": OUTPUTS,
    "fem_bounce.plots": OUTPUTS,
    "fem_bounce.losses": OUTPUTS,
    "fem_bounce.fields": OUTPUTS,
    # the finite-element toolkit the resolved models share
    "fem_bounce.fem": FEM,
    "fem_bounce.fem.compat": FEM,
    "fem_bounce.fem.domain": FEM,
    "fem_bounce.fem.field_writer": FEM,
    "fem_bounce.fem.functions": FEM,
    "fem_bounce.fem.geometry": FEM,
    "fem_bounce.fem.mesh": FEM,
    "fem_bounce.fem.mesh_motion": FEM,
    "fem_bounce.fem.matrix": FEM,
    "fem_bounce.fem.solver": FEM,
    "fem_bounce.fem.taylor_hood": FEM,
    "fem_bounce.fem.transfer": FEM,
    "fem_bounce.fem.vertex_fields": FEM,
    # the registry and the models
    "fem_bounce.models": MODELS,
    "fem_bounce.models.registry": MODELS,
    "fem_bounce.models.ode": MODELS,
    "fem_bounce.models.moving_mesh": MODELS,
    "fem_bounce.models.fd": MODELS,
    "fem_bounce.models.fd.coupling": MODELS,
    "fem_bounce.models.fd.domain": MODELS,
    "fem_bounce.models.fd.fluid": MODELS,
    "fem_bounce.models.fd.immersed": MODELS,
    "fem_bounce.models.fd.model": MODELS,
    "fem_bounce.models.fd.moving": MODELS,
    "fem_bounce.models.fd.penalised": MODELS,
    "fem_bounce.models.fd.steady": MODELS,
    "fem_bounce.models.fd3d": MODELS,
    "fem_bounce.models.fd3d.flow": MODELS,
    "fem_bounce.models.fd3d.indicator": MODELS,
    "fem_bounce.models.fd3d.mesh": MODELS,
    "fem_bounce.models.fd3d.model": MODELS,
    "fem_bounce.models.fd3d.motion": MODELS,
    "fem_bounce.models.fd3d.response": MODELS,
    "fem_bounce.models.fd3d.transfer": MODELS,
    "fem_bounce.models.ib": MODELS,
    "fem_bounce.models.ib.body": MODELS,
    "fem_bounce.models.ib.delta": MODELS,
    "fem_bounce.models.ib.domain": MODELS,
    "fem_bounce.models.ib.grid": MODELS,
    "fem_bounce.models.ib.model": MODELS,
    "fem_bounce.models.ib.operators": MODELS,
    "fem_bounce.models.ib.snapshots": MODELS,
    "fem_bounce.models.ib.solver": MODELS,
    "fem_bounce.models.ale": MODELS,
    "fem_bounce.models.ale.domain": MODELS,
    "fem_bounce.models.ale.flow": MODELS,
    "fem_bounce.models.ale.model": MODELS,
    "fem_bounce.models.unread": MODELS,  # the settings each model's modes read nowhere, refused
    # the settings reference, generated from the scene's metadata and the models' refusals (models.unread)
    "fem_bounce.settings_reference": MODELS,
    # one run: the controller, run_logged, restart_target
    "fem_bounce.run": RUN,
    # many runs: the cache of finished runs, the workers, the studies
    "fem_bounce.cache": STUDIES,
    "fem_bounce.mpi_pool": STUDIES,
    "fem_bounce.studies": STUDIES,
    "fem_bounce.studies.band": STUDIES,
    "fem_bounce.studies.common": STUDIES,
    "fem_bounce.studies.compare": STUDIES,
    "fem_bounce.studies.convergence": STUDIES,
    "fem_bounce.studies.figures": STUDIES,
    "fem_bounce.studies.oblique": STUDIES,
    "fem_bounce.studies.restitution": STUDIES,
    "fem_bounce.studies.restitution_planning": STUDIES,
    "fem_bounce.studies.runner": STUDIES,
    "fem_bounce.studies.speed_accuracy": STUDIES,
    "fem_bounce.studies.stability": STUDIES,
    "fem_bounce.studies.validation": STUDIES,
    # the Python API, and the package's face that re-exports it
    "fem_bounce.api": API,
    "fem_bounce": API,
    # the command line
    "fem_bounce.cli": CLI,
    "fem_bounce.__main__": CLI,
}


def package_modules() -> dict[str, Path]:
    """{dotted name: file} of every module of the package (a package by its __init__.py)."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def package_imports(name: str, path: Path, modules: dict[str, Path]) -> list[tuple[str, int]]:
    """(imported module of the package, line) for every import in the file, wherever it stands."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:  # `from . import output` imports a module; `from .scene import Scene` a name
                submodule = f"{source}.{alias.name}"
                found.append((submodule if submodule in modules else source, node.lineno))
    return [(target, line) for target, line in found
            if (target == "fem_bounce" or target.startswith("fem_bounce.")) and target != name]


def import_graph() -> dict[str, list[tuple[str, int]]]:
    modules = package_modules()
    return {name: package_imports(name, path, modules) for name, path in modules.items()}


def test_every_module_has_a_layer():
    modules = set(package_modules())
    assert sorted(modules - set(LAYERS)) == [], "new modules: give each a layer in LAYERS"
    assert sorted(set(LAYERS) - modules) == [], "LAYERS names modules that no longer exist"


def test_imports_only_look_down():
    upward = [f"{name} (layer {LAYER_NAMES[LAYERS[name]]}) imports {target} (layer {LAYER_NAMES[LAYERS[target]]}) "
              f"at line {line}"
              for name, imports in import_graph().items() for target, line in imports
              if name in LAYERS and target in LAYERS and LAYERS[target] > LAYERS[name]]
    assert upward == [], "imports from a lower layer to a higher one:\n" + "\n".join(upward)


def test_no_circle():
    graph = {name: sorted({target for target, _ in imports}) for name, imports in import_graph().items()}
    state: dict[str, str] = {}  # "open" while on the path being followed, "done" once all below it are
    path: list[str] = []

    def visit(name: str) -> list[str] | None:
        state[name] = "open"
        path.append(name)
        for target in graph.get(name, []):
            if state.get(target) == "open":
                return path[path.index(target):] + [target]
            if target not in state and (circle := visit(target)):
                return circle
        path.pop()
        state[name] = "done"
        return None

    for name in sorted(graph):
        if name not in state:
            circle = visit(name)
            assert circle is None, "an import circle: " + " -> ".join(circle)


def test_the_api_does_not_import_the_command_line():
    assert "fem_bounce.cli" not in {target for target, _ in import_graph()["fem_bounce.api"]}
