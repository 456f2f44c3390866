"""portcullis for Blender: tag rooms and portals, export glTF, convert and check it with the
`portcullis` command line, and see the result (diagnostics that select their object, the debug
glTF of cells and portals, the offline viewer) without leaving Blender."""

bl_info = {
    "name": "portcullis",
    "author": "portcullis developers",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "3D Viewport > Sidebar > portcullis; File > Export",
    "description": "Cells and portals for game levels: tag, export, check and see",
    "category": "Import-Export",
}

import tempfile
import webbrowser
from contextlib import contextmanager
from pathlib import Path

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, IntProperty,
                       StringProperty)
from bpy_extras.io_utils import ExportHelper

from . import cli, tagging

DEBUG_COLLECTION = "portcullis debug"
# Set while the add-on's own export runs: the exporter's hook then leaves converting to it.
_EXPORTING = False


def prefs(context):
    addon = context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def binary(context):
    p = prefs(context)
    return cli.find_binary(p.binary if p else "")


class PortcullisPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    binary: StringProperty(name="portcullis binary", subtype="FILE_PATH",
                           description="Empty: $PORTCULLIS_BIN, else `portcullis` on PATH")
    convert_on_export: BoolProperty(
        name="Convert on every glTF export",
        description="Run portcullis convert on each file the glTF exporter writes")

    def draw(self, context):
        self.layout.prop(self, "binary")
        self.layout.prop(self, "convert_on_export")


class PortcullisDiagnostic(bpy.types.PropertyGroup):
    severity: StringProperty()
    code: StringProperty()
    message: StringProperty()
    hint: StringProperty()
    node: StringProperty()
    object_name: StringProperty()


class PortcullisFound(bpy.types.PropertyGroup):
    kind: StringProperty()
    label: StringProperty()


class PortcullisState(bpy.types.PropertyGroup):
    mode: EnumProperty(name="Write tags as", items=[
        ("EXTRAS", "Custom properties", "Exported as glTF node extras"),
        ("NAMES", "Name suffixes",
         "Godot's -room, -portal, -bound, -detail, -ignore; -occupant")])
    value: StringProperty(name="Room / target",
                          description="A room's name, a portal's target room, a footprint's room")
    filepath: StringProperty(name="glTF file", subtype="FILE_PATH",
                             description="Where the export goes (empty: a temporary folder)")
    preset: StringProperty(name="Preset", description="--tags PRESET (empty: the default)")
    sealed: BoolProperty(name="Sealed", description="Report openings to the exterior as leaks")
    status: StringProperty()
    exit_code: IntProperty(default=-1)
    output: StringProperty()
    debug: StringProperty()
    exported: StringProperty()
    diagnostics: CollectionProperty(type=PortcullisDiagnostic)
    found: CollectionProperty(type=PortcullisFound)
    active: IntProperty()


class PORTCULLIS_OT_tag(bpy.types.Operator):
    """Tag the selected objects"""
    bl_idname = "portcullis.tag"
    bl_label = "Tag"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(items=tagging.KINDS)
    value: StringProperty()

    def execute(self, context):
        state = context.scene.portcullis
        objs = list(context.selected_objects)
        if not objs:
            self.report({"WARNING"}, "select the objects to tag")
            return {"CANCELLED"}
        for obj in objs:
            tagging.tag(obj, self.kind, state.mode, self.value or state.value)
        return {"FINISHED"}


class PORTCULLIS_OT_untag(bpy.types.Operator):
    """Remove portcullis tags from the selected objects"""
    bl_idname = "portcullis.untag"
    bl_label = "Clear tags"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        for obj in context.selected_objects:
            tagging.clear(obj)
        return {"FINISHED"}


@contextmanager
def without_debug(scene):
    """The scene without the debug collection, for an export: it is the tool's picture of the
    level, never part of it. (The exporter takes a scene's objects whatever the view layer
    excludes, so the collection is unlinked meanwhile, kept by a fake user.)"""
    coll = bpy.data.collections.get(DEBUG_COLLECTION)
    linked = coll is not None and scene.collection.children.get(coll.name) is not None
    if linked:
        coll.use_fake_user = True
        scene.collection.children.unlink(coll)
    try:
        yield
    finally:
        if linked:
            scene.collection.children.link(coll)


def run_portcullis(context, exported):
    """Converts, checks and inspects an exported file; the results go to the scene's state."""
    state = context.scene.portcullis
    state.diagnostics.clear()
    state.found.clear()
    state.exported = str(exported)
    try:
        res = cli.convert_and_check(binary(context), exported, state.preset, state.sealed)
    except cli.ToolError as e:
        state.exit_code = 2
        state.status = f"portcullis could not run: {e}"
        return False
    state.exit_code = res.exit_code
    state.output, state.debug = res.output, res.debug
    for d in res.diagnostics:
        item = state.diagnostics.add()
        item.severity, item.code, item.message = d.severity, d.code, d.message
        item.hint, item.node, item.object_name = d.hint, d.node, d.object_name
    for r in res.rooms:
        item = state.found.add()
        item.kind, item.label = "room", r
    for node, src, dst in res.portals:
        item = state.found.add()
        item.kind, item.label = "portal", f"{node.rsplit('/', 1)[-1]}: {src} -> {dst or '?'}"
    errors = sum(d.severity == "error" for d in res.diagnostics)
    warnings = sum(d.severity == "warning" for d in res.diagnostics)
    state.status = (f"{'the level has errors' if res.exit_code == 1 else 'converted'}: "
                    f"{errors} errors, {warnings} warnings, {len(res.rooms)} rooms")
    return True


class PORTCULLIS_OT_export(bpy.types.Operator, ExportHelper):
    """Export the scene as glTF, then convert and check it with portcullis"""
    bl_idname = "portcullis.export"
    bl_label = "Export glTF with portals"

    # Blender's exporters' convention (ExportHelper): `filepath`, which a script passes
    # (`bpy.ops.portcullis.export(filepath=...)`) and File > Export's browser fills. Not
    # remembered between runs: without it, the export goes to the panel's glTF file.
    filepath: StringProperty(name="File Path", subtype="FILE_PATH", maxlen=1024,
                             options={"SKIP_SAVE"})
    filename_ext = ".glb"
    filter_glob: StringProperty(default="*.glb", options={"HIDDEN"})

    def invoke(self, context, event):
        # The file browser opens on the panel's glTF file.
        state = context.scene.portcullis
        if not self.filepath and state.filepath:
            self.filepath = bpy.path.abspath(state.filepath)
        return ExportHelper.invoke(self, context, event)

    def execute(self, context):
        state = context.scene.portcullis
        chosen = self.filepath or state.filepath
        path = Path(bpy.path.abspath(chosen)) if chosen else \
            Path(tempfile.mkdtemp(prefix="portcullis-")) / "level.glb"
        path.parent.mkdir(parents=True, exist_ok=True)
        global _EXPORTING
        _EXPORTING = True
        try:
            with without_debug(context.scene):
                bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB",
                                          export_extras=True, export_yup=True)
        finally:
            _EXPORTING = False
        ok = run_portcullis(context, path)
        self.report({"INFO" if ok and state.exit_code == 0 else "WARNING"}, state.status)
        return {"FINISHED"} if ok else {"CANCELLED"}


def menu_export(self, context):
    """File > Export's entry: the file browser, on the panel's glTF file."""
    self.layout.operator(PORTCULLIS_OT_export.bl_idname,
                         text="glTF with cells and portals (portcullis) (.glb)")


class PORTCULLIS_OT_select(bpy.types.Operator):
    """Select and frame the object a diagnostic names"""
    bl_idname = "portcullis.select"
    bl_label = "Select"

    index: IntProperty()

    def execute(self, context):
        state = context.scene.portcullis
        if not 0 <= self.index < len(state.diagnostics):
            return {"CANCELLED"}
        state.active = self.index
        obj = bpy.data.objects.get(state.diagnostics[self.index].object_name)
        if obj is None:
            self.report({"WARNING"}, "the diagnostic names no object of this scene")
            return {"CANCELLED"}
        for o in context.view_layer.objects:
            o.select_set(False)
        obj.hide_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        area = next((a for a in (context.screen.areas if context.screen else [])
                     if a.type == "VIEW_3D"), None)
        if area:
            region = next(r for r in area.regions if r.type == "WINDOW")
            with context.temp_override(area=area, region=region):
                bpy.ops.view3d.view_selected()
        return {"FINISHED"}


class PORTCULLIS_OT_import_debug(bpy.types.Operator):
    """Import the last run's debug glTF (cells, portals by kind, leaks) into its own
    collection, replacing the previous one, hidden from render"""
    bl_idname = "portcullis.import_debug"
    bl_label = "Show cells and portals"

    def execute(self, context):
        state = context.scene.portcullis
        if not state.debug or not Path(state.debug).exists():
            self.report({"WARNING"}, "export with portals first")
            return {"CANCELLED"}
        old = bpy.data.collections.get(DEBUG_COLLECTION)
        if old:
            for obj in list(old.objects):
                bpy.data.objects.remove(obj, do_unlink=True)
            bpy.data.collections.remove(old)
        coll = bpy.data.collections.new(DEBUG_COLLECTION)
        context.scene.collection.children.link(coll)
        before = set(bpy.data.objects)
        bpy.ops.import_scene.gltf(filepath=state.debug)
        for obj in set(bpy.data.objects) - before:
            for c in list(obj.users_collection):
                c.objects.unlink(obj)
            coll.objects.link(obj)
            obj.hide_render = True
        coll.hide_render = True
        return {"FINISHED"}


class PORTCULLIS_OT_view(bpy.types.Operator):
    """Open portcullis view's page of the last export in the browser"""
    bl_idname = "portcullis.view"
    bl_label = "Open the viewer"

    def execute(self, context):
        state = context.scene.portcullis
        if not state.exported:
            self.report({"WARNING"}, "export with portals first")
            return {"CANCELLED"}
        page = Path(state.exported).with_suffix(".html")
        try:
            cli.view_page(binary(context), state.exported, page, state.preset)
        except cli.ToolError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        webbrowser.open(page.as_uri())
        return {"FINISHED"}


class PORTCULLIS_UL_diagnostics(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_prop, index):
        icons = {"error": "ERROR", "warning": "ERROR", "info": "INFO"}
        row = layout.row()
        row.label(text=f"{item.code}: {item.message}", icon=icons.get(item.severity, "DOT"))
        row.operator("portcullis.select", text="", icon="RESTRICT_SELECT_OFF").index = index


class PORTCULLIS_PT_panel(bpy.types.Panel):
    bl_label = "portcullis"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "portcullis"

    def draw(self, context):
        state = context.scene.portcullis
        col = self.layout.column()
        col.prop(state, "mode")
        col.prop(state, "value")
        grid = col.grid_flow(columns=2, align=True)
        for kind, label, _ in tagging.KINDS:
            grid.operator("portcullis.tag", text=label).kind = kind
        col.operator("portcullis.untag")
        col.separator()
        col.prop(state, "filepath")
        col.prop(state, "preset")
        col.prop(state, "sealed")
        # One click: the panel's button exports to the glTF file above, with no file browser.
        col.operator_context = "EXEC_DEFAULT"
        col.operator("portcullis.export", icon="EXPORT")
        col.operator_context = "INVOKE_DEFAULT"
        if state.status:
            col.label(text=state.status)
        for f in state.found:
            col.label(text=f.label, icon="MESH_CUBE" if f.kind == "room" else "MOD_WIREFRAME")
        col.template_list("PORTCULLIS_UL_diagnostics", "", state, "diagnostics", state, "active")
        if 0 <= state.active < len(state.diagnostics):
            hint = state.diagnostics[state.active].hint
            if hint:
                col.label(text=f"hint: {hint}")
        row = col.row()
        row.operator("portcullis.import_debug", icon="OUTLINER_COLLECTION")
        row.operator("portcullis.view", icon="URL")


class glTF2ExportUserExtension:
    """The glTF exporter's hooks: every glTF export leaves the debug collection out, and with
    the preference on, each is converted and checked."""

    def __init__(self):
        self.outside = None

    def pre_export_hook(self, export_settings):
        self.outside = without_debug(bpy.context.scene)
        self.outside.__enter__()

    def post_export_hook(self, export_settings):
        if self.outside is not None:
            self.outside.__exit__(None, None, None)
            self.outside = None
        context = bpy.context
        p = prefs(context)
        path = export_settings.get("gltf_filepath")
        if p and p.convert_on_export and path and not _EXPORTING:
            run_portcullis(context, path)


CLASSES = (PortcullisPreferences, PortcullisDiagnostic, PortcullisFound, PortcullisState,
           PORTCULLIS_OT_tag, PORTCULLIS_OT_untag, PORTCULLIS_OT_export, PORTCULLIS_OT_select,
           PORTCULLIS_OT_import_debug, PORTCULLIS_OT_view, PORTCULLIS_UL_diagnostics,
           PORTCULLIS_PT_panel)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.portcullis = bpy.props.PointerProperty(type=PortcullisState)
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
    del bpy.types.Scene.portcullis
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
