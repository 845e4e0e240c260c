"""Settings a run reads nowhere, refused: each model's numerics table against the modes of its model.

A setting that does nothing in the mode a scene puts its model in (the fixed fd mesh's surface_refinement, the
one-shot penalty's forcing_number under the implicit constraint, the adaptive steps' bounds with fixed steps, ...)
is refused when it is set to anything but its default, in one line naming the setting, why it does nothing here
and what to set instead, before anything is written: each model's scene check calls `refuse_unread`.  A setting at
its default is never refused, so every default run is as it was.

RULES is the whole table (docs/settings.md lists it under each model's settings).  The refusals written before it
stay where they were (`refused_by`: models/fd/moving.py FIXED_MESH_ONLY and numerics.fd.hold_delta under the
near-wall correction, models/fd/model.py the fixed mesh's hold_delta and penalty_strength with the one-shot penalty;
fd3d's own in models/fd3d/model.py); `refuse_unread` makes the rest.  `unread` names the settings a scene's run reads
nowhere (a study that scales several settings together scales only those read: studies.common.Ladder)."""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Callable

from ..bodies import scene_bodies
from ..motion import is_held, is_stream
from ..scene import SceneError


# settings of the fixed fd mesh that the moving one does not read: its patches, its wall box and the band's edge
# (refused by models/fd/moving.py)
FIXED_MESH_ONLY = ("patch", "patch_margin", "wall_cells_per_diameter", "wall_layer", "wall_radius", "radius_offset")


def correction_holds_every_contact(scene) -> bool:
    """Whether the near-wall correction holds the flow at every contact that can close (the wall's, when there is one,
    and every neighbouring pair's), each at its delta_sl gap (integrator.hold_gaps): a moving mesh's own hold,
    numerics.fd.hold_delta or numerics.ale.hold_delta, where the contact model has none, is then read nowhere."""
    return scene.near_wall_law == "correction" and all(body.free for body in scene_bodies(scene))


def _every_sphere_held(scene) -> bool:
    return all(body.held for body in scene_bodies(scene))


def _fd_fixed_mesh(scene, fd) -> bool:
    return not fd.moving


def _fd_steady(scene, fd) -> bool:
    return fd.steady_stokes


def _fd_fixed_steps(scene, fd) -> bool:
    return not fd.steady_stokes and not fd.resolved("adaptive_step")


def _fd_without_wall_box(scene, fd) -> bool:
    """The fixed mesh makes no wall box (fd/domain.py domain_for): none asked, one no finer than the path, or a
    stream (no wall at z = 0)."""
    diameter = scene.sphere.diameter
    finer = fd.wall_cells_per_diameter > 0 and diameter / fd.wall_cells_per_diameter < diameter / fd.cells_per_diameter
    return not fd.moving and (is_stream(scene) or not finer)


def _fd_fixed_steps_instead(scene) -> str:
    fd = scene.numerics.fd
    if fd.constraint == "implicit" and fd.time_order < 3:
        return "unset it, or set numerics.fd.adaptive_step = true"
    return ("unset it (adaptive steps need numerics.fd.constraint = \"implicit\" and time_order 1 or 2; "
            f"this run has \"{fd.constraint}\" at time_order {fd.time_order})")


def _fd_fixed_mesh_instead(scene) -> str:
    if scene.numerics.fd.steady_stokes:
        return "unset it (steady_stokes solves on the fixed mesh)"
    return "unset it, or set numerics.fd.mesh = \"moving\""


def _ale_steady(scene, ale) -> bool:
    return _every_sphere_held(scene) and ale.fixed_solver == "steady"


_CONTAINER = ("is read nowhere with a container: it sizes the unbounded domain, and this scene's container "
              "(container.radius, container.height) bounds it: unset it")
_HELD_HOLD = ("has no effect here: every sphere is held (motion.mode and each sphere's mode \"fixed\"), and the mesh "
              "holds a sphere at hold_delta only as it moves toward a contact (a held sphere stays at its gap, nearer "
              "than the hold too): unset it")
_HOLD = ("has no effect here: the near-wall correction (contact.near_wall, resolved \"correction\") holds each sphere "
         "at the contact model's gap contact.delta_sl D (delta_sl 2a* for a pair) instead: unset it, and set "
         "contact.delta_sl to move the hold (or contact.near_wall = \"blend\" for the mesh to hold at hold_delta)")


@dataclass(frozen=True)
class Unread:
    """Settings of a model's table (`names`) that a run in one mode of the model reads nowhere: `mode` says which (as
    the settings reference lists it), `applies(scene, table)` whether the scene's run is in it; `reason` (a string,
    or a function of the scene) completes "numerics.MODEL.NAME = VALUE ..." with why and what to set instead."""

    names: tuple[str, ...]
    mode: str
    applies: Callable
    reason: str | Callable = ""
    refused_by: str = ""  # where a refusal written before these rules lives (refuse_unread leaves it to that one)


RULES: dict[str, tuple[Unread, ...]] = {
    "fd": (
        Unread(FIXED_MESH_ONLY, "the moving mesh", lambda scene, fd: fd.moving,
               refused_by="models/fd/moving.py FIXED_MESH_ONLY"),
        Unread(("hold_delta",), "the moving mesh, the near-wall correction holding every contact",
               lambda scene, fd: fd.moving and correction_holds_every_contact(scene),
               refused_by="models/fd/moving.py"),
        Unread(("hold_delta",), "the fixed mesh", _fd_fixed_mesh, refused_by="models/fd/model.py"),
        Unread(("hold_delta",), "every sphere held, on the moving mesh",
               lambda scene, fd: fd.moving and _every_sphere_held(scene), _HELD_HOLD),
        Unread(("penalty_strength",), 'constraint = "penalty"', lambda scene, fd: fd.constraint == "penalty",
               refused_by="models/fd/model.py"),
        Unread(("adaptive_step", "min_step_factor", "max_step_factor", "gap_fraction", "coupling"),
               "steady_stokes = true", _fd_steady,
               "is read nowhere with numerics.fd.steady_stokes = true: the held spheres' steady state is solved in one "
               "go, without steps or the integrator's coupling: unset it, or set steady_stokes = false"),
        Unread(("time_order", "solver"), 'steady_stokes = true with constraint = "implicit"',
               lambda scene, fd: fd.steady_stokes and fd.constraint == "implicit",
               "is read nowhere with numerics.fd.steady_stokes = true and constraint = \"implicit\": the steady state "
               "is one direct solve of the Stokes operator with the friction, no time derivative: unset it"),
        Unread(("surface_refinement", "min_quality", "min_gap_cells"), 'the fixed mesh (mesh = "fixed", or '
               "steady_stokes)", _fd_fixed_mesh,
               lambda scene: "has no effect on the fixed mesh: it shapes the moving mesh only (the spheres' surface "
               "triangles, when a new mesh is made, the triangles across a new mesh's gap), and the fixed mesh is "
               "fine at cells_per_diameter wherever its patches or the path lie (wall_cells_per_diameter: in the "
               f"gap): {_fd_fixed_mesh_instead(scene)}"),
        Unread(("patch",), "every sphere held, on the fixed mesh",
               lambda scene, fd: not fd.moving and _every_sphere_held(scene),
               "has no effect here: every sphere is held, and the fixed mesh refines the box around where they are "
               "whether or not patches follow them: unset it"),
        Unread(("patch_margin",), "the fixed mesh without patches (patch = false, or every sphere held)",
               lambda scene, fd: not fd.moving and (not fd.patch or _every_sphere_held(scene)),
               "has no effect here: it sizes the patches that follow moving spheres, and this run refines the whole "
               "path (numerics.fd.patch = false, or every sphere held): unset it, or set numerics.fd.patch = true"),
        Unread(("wall_cells_per_diameter", "wall_layer", "wall_radius"), "the fixed mesh without a wall box "
               "(wall_cells_per_diameter no finer than cells_per_diameter, or a stream)", _fd_without_wall_box,
               lambda scene: "has no effect here: the fixed mesh makes its wall box (triangles D / "
               "wall_cells_per_diameter in r <= wall_radius D, z <= wall_layer D) only when wall_cells_per_diameter "
               f"exceeds cells_per_diameter ({scene.numerics.fd.cells_per_diameter:g}) and the scene has a wall at "
               "z = 0 (not a stream): unset it, or set numerics.fd.wall_cells_per_diameter above cells_per_diameter"),
        Unread(("min_step_factor", "max_step_factor", "gap_fraction"), "fixed steps (adaptive_step false, set or "
               'resolved: constraint = "penalty", time_order 3)', _fd_fixed_steps,
               lambda scene: "has no effect here: it bounds the adaptive steps, and this run's steps are fixed (the "
               "peak_cfl step; shortened only where a step could close a whole gap): "
               f"{_fd_fixed_steps_instead(scene)}"),
        Unread(("forcing_number",), 'constraint = "implicit"', lambda scene, fd: fd.constraint == "implicit",
               "has no effect with numerics.fd.constraint = \"implicit\": it bounds the one-shot penalty's step "
               "(dt <= forcing_number h^2 / nu, its rigidity), and the implicit constraint holds the sphere by its "
               "friction (penalty_strength) at any step: unset it, and set numerics.fd.penalty_strength, or "
               "numerics.fd.constraint = \"penalty\" with mesh = \"fixed\""),
        Unread(("solver",), "the moving mesh", lambda scene, fd: fd.moving,
               "has no effect on the moving mesh: its step's matrix changes every step and is factorised directly "
               "(MUMPS) every step; the field split solves the fixed mesh's: unset it, or set numerics.fd.mesh = "
               "\"fixed\""),
        Unread(("far_field",), "a container", lambda scene, fd: not scene.container.unbounded, _CONTAINER),
    ),
    "ale": (
        Unread(("cfl", "time_order", "adaptive_step", "min_step_factor", "max_step_factor", "min_quality",
                "factorisation", "factorisation_cost", "reuse_iterations", "krylov_rtol"),
               'every sphere held and fixed_solver = "steady"', _ale_steady,
               "is read nowhere here: every sphere is held and numerics.ale.fixed_solver = \"steady\" solves their "
               "steady state in one go (no steps, no new mesh, one direct solve): unset it, or set "
               "numerics.ale.fixed_solver = \"march\""),
        Unread(("min_step_factor", "max_step_factor"), "fixed steps (adaptive_step = false)",
               lambda scene, ale: not ale.adaptive_step,
               "has no effect here: it bounds the adaptive steps, and numerics.ale.adaptive_step = false takes the cfl "
               "step throughout: unset it, or set numerics.ale.adaptive_step = true"),
        Unread(("factorisation_cost", "reuse_iterations", "krylov_rtol"), 'factorisation = "every-step"',
               lambda scene, ale: ale.factorisation == "every-step",
               "has no effect with numerics.ale.factorisation = \"every-step\": it sets when reused factors are "
               "renewed and how far their GMRES solves, and every step is factorised: unset it, or set "
               "numerics.ale.factorisation = \"reuse\""),
        Unread(("fixed_solver",), "a sphere not held", lambda scene, ale: not _every_sphere_held(scene),
               "has no effect here: it says how held spheres are solved (every sphere held: motion.mode and "
               "second_sphere.mode \"fixed\"), and this scene's free or prescribed sphere marches: unset it"),
        Unread(("hold_delta",), "the near-wall correction holding every contact",
               lambda scene, ale: correction_holds_every_contact(scene), _HOLD),
        Unread(("hold_delta",), "every sphere held", lambda scene, ale: _every_sphere_held(scene), _HELD_HOLD),
        Unread(("far_field",), "a container", lambda scene, ale: not scene.container.unbounded, _CONTAINER),
    ),
    "ib": (
        Unread(("far_field",), "a container", lambda scene, ib: not scene.container.unbounded, _CONTAINER),
        Unread(("wall_exclusion",), "a stream", lambda scene, ib: is_stream(scene),
               "has no effect in a stream: it releases the points near the wall, and a sphere held in a stream has "
               "none (z = 0 is the inflow): unset it"),
        Unread(("coupling",), "a held sphere", lambda scene, ib: is_held(scene),
               "has no effect on a held sphere: its velocity is imposed (motion.mode = \"fixed\"), so the flow's "
               "response to it is never coupled: unset it"),
    ),
}


def _violations(scene, model: str):
    """(name, rule) of each setting of `model`'s table set away from its default in a mode that reads it nowhere."""
    table = getattr(scene.numerics, model)
    defaults = {f.name: f.default for f in fields(table)}
    for rule in RULES.get(model, ()):
        if rule.refused_by or not rule.applies(scene, table):
            continue
        for name in rule.names:
            if getattr(table, name) != defaults[name]:
                yield name, rule


def unread(scene, model: str) -> set[str]:
    """The settings of `model`'s table that this scene's run reads nowhere (whatever their values)."""
    table = getattr(scene.numerics, model)
    return {name for rule in RULES.get(model, ()) if rule.applies(scene, table) for name in rule.names}


def refuse_unread(scene, model: str) -> None:
    """Refuse (SceneError, one line) the first setting of `model`'s table set away from its default where this
    scene's run reads it nowhere (RULES)."""
    for name, rule in _violations(scene, model):
        value = getattr(getattr(scene.numerics, model), name)
        shown = (str(value).lower() if isinstance(value, bool) else f'"{value}"' if isinstance(value, str)
                 else f"{value:g}")
        reason = rule.reason(scene) if callable(rule.reason) else rule.reason
        raise SceneError(f"numerics.{model}.{name} = {shown} {reason}")
