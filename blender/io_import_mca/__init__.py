"""Blender add-on: File > Import > mca run.

Brings the folder an `mca run` wrote into the scene: the automata (or the bound surface) as an animation,
the projectiles, the ground, the camera and the fragment meshes. See the README's "Blender" section.
"""

bl_info = {
    "name": "mca run importer",
    "description": "Import a run folder of the mca fracture simulator (automata.pvd, surface, fragments)",
    "author": "mca",
    "version": (1, 0, 0),
    "blender": (3, 4, 0),
    "location": "File > Import > mca run",
    "category": "Import-Export",
}

import bpy
from bpy.props import IntProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from . import reader


def chosen_path(path):
    """What the file browser chose, as a file system path: the run folder or a file in it (automata.pvd,
    summary.json...); the reader finds the folder and names the path as given when it is not one."""
    return bpy.path.abspath(path) if path else path


class IMPORT_SCENE_OT_mca_run(bpy.types.Operator, ImportHelper):
    """Import the folder of an mca run: open the folder (or pick its automata.pvd) and press Import"""

    bl_idname = "import_scene.mca_run"
    bl_label = "Import mca run"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".pvd"
    filter_glob: StringProperty(default="*.pvd;*.json;*.toml", options={"HIDDEN"})
    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN"})
    max_frames: IntProperty(name="Frames", description="Import at most this many frames (0: all)", default=0,
                            min=0)

    def execute(self, context):
        path = chosen_path(self.filepath or self.directory)
        try:
            reader.check_dependencies()  # numpy and tomllib, before build (which imports numpy)
            from . import build
            result = build.import_run(context, path, max_frames=self.max_frames or None)
        except reader.RunError as e:
            self.report({"ERROR"}, f"mca run: {e}")
            return {"CANCELLED"}
        except ImportError as e:
            self.report({"ERROR"}, f"mca run: the importer needs a module that is missing ({e}); install it "
                                   "(numpy: Debian's python3-numpy) and restart Blender")
            return {"CANCELLED"}
        except Exception as e:  # noqa: BLE001 - a failure nobody foresaw: one line in the report area, no traceback
            self.report({"ERROR"}, f"mca run: importing {path} failed ({type(e).__name__}: {e}); the folder may be "
                                   "damaged: run mca again into an empty folder, and report it if it persists")
            return {"CANCELLED"}
        for w in result.run.warnings:
            self.report({"WARNING"}, f"mca run: {w}")
        self.report({"INFO"}, f"mca run: {result.frames} frame{'' if result.frames == 1 else 's'} of {len(result.run.frames[0]['points'])} automata "
                              f"from {result.run.dir} in {result.seconds:.2f} s")
        return {"FINISHED"}


def menu_import(self, context):
    self.layout.operator(IMPORT_SCENE_OT_mca_run.bl_idname, text="mca run (folder of automata.pvd)")


def register():
    bpy.utils.register_class(IMPORT_SCENE_OT_mca_run)
    bpy.types.TOPBAR_MT_file_import.append(menu_import)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(menu_import)
    bpy.utils.unregister_class(IMPORT_SCENE_OT_mca_run)
