"""mca: fracture of heterogeneous materials with movable cellular automata, from Python.

A scene (``Scene``: the keys of docs/scene-format.md) is built into a model and stepped by
``Simulation``, the engine of the ``mca`` command; the state comes back as numpy arrays, frames and
checkpoints are written as the command writes them, and ``render`` draws with its renderer.

    import mca
    scene = mca.Scene.default()               # scenes/wall_ball.toml
    scene.projectiles[0].velocity = (0, 80, 0)
    sim = mca.Simulation(scene, threads=2)
    sim.advance_to(0.01)
    print(sim.fragments()["mass"][:5], sim.state_hash())
    mca.render(sim, "wall.png", colour="damage")

Every error the command reports (a bad scene, a bad checkpoint, an unstable run) is raised as
``mca.Error`` with the command's message.
"""

from ._mca import (  # noqa: F401  (the C++ half: python/src/)
    Camera,
    Error,
    Ground,
    Heterogeneity,
    Load,
    Grip,
    Material,
    Object,
    Output,
    Projectile,
    Region,
    Scene,
    Simulation,
    Solver,
    render,
)

Error.__doc__ = (
    "An error the mca command would report (a bad scene, mesh, checkpoint or option; an unstable run): "
    "the message names the file, the key, the bad value and the fix."
)



def _scene_from_toml(text, source):
    """What pickle calls to read a Scene back (Scene.__reduce__): Scene.from_toml(text, source)."""
    return Scene.from_toml(text, source)


__all__ = [
    "Camera",
    "Error",
    "Grip",
    "Ground",
    "Heterogeneity",
    "Load",
    "Material",
    "Object",
    "Output",
    "Projectile",
    "Region",
    "Scene",
    "Simulation",
    "Solver",
    "render",
]
