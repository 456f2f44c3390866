"""The Blender add-on in a real Blender (the `bpy` module), headless: run by tests/blender.rs
with PORTCULLIS_BIN set to the binary under test and a scratch folder as the first argument.

Builds two rooms through a doorway, tags them through the add-on's operators, exports through
the add-on, and reads the written file's extension; exports with `filepath=` as a script does
and finds the operator in File > Export; breaks the level and selects the object a diagnostic
names; imports the debug glTF into its collection and counts its objects. With a
second argument, also renders the level with its cells and portals to that PNG (the add-on's
README screenshot)."""
import json
import struct
import sys
from pathlib import Path

import bpy
import addon_utils  # noqa: E402 (bpy puts it on the path)

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "blender"))
scratch = Path(sys.argv[1])
screenshot = Path(sys.argv[2]) if len(sys.argv) > 2 else None


def glb_json(path):
    data = Path(path).read_bytes()
    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n])


def mesh_object(name, quads):
    """An object whose mesh is the given quads (Blender coordinates, Z up)."""
    verts, faces = [], []
    for q in quads:
        faces.append([len(verts) + k for k in range(4)])
        verts.extend(q)
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def room(name, x0, x1, door_x):
    """Inward floor, ceiling and walls of a 4 x 4 x 3 room; the wall at door_x has a 1 x 2.2 door
    (y 1.5..2.5)."""
    h = 3.0
    q = [
        [(x0, 0, 0), (x0, 4, 0), (x1, 4, 0), (x1, 0, 0)],  # floor, faces up
        [(x0, 0, h), (x1, 0, h), (x1, 4, h), (x0, 4, h)],  # ceiling, faces down
        [(x0, 0, 0), (x1, 0, 0), (x1, 0, h), (x0, 0, h)],  # y = 0, faces +y
        [(x0, 4, 0), (x0, 4, h), (x1, 4, h), (x1, 4, 0)],  # y = 4, faces -y
    ]
    for x, into in ((x0, 1), (x1, -1)):
        parts = [((0, 4), (0, h))] if x != door_x else [
            ((0, 1.5), (0, h)), ((2.5, 4), (0, h)), ((1.5, 2.5), (2.2, h))]
        for (ya, yb), (za, zb) in parts:
            quad = [(x, ya, za), (x, yb, za), (x, yb, zb), (x, ya, zb)]
            q.append(quad if into == 1 else quad[::-1])
    return mesh_object(name, q)


def select_only(*objs):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    bpy.context.view_layer.objects.active = objs[0]


bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("portcullis_blender", default_set=True, handle_error=None)
assert "portcullis_blender" in bpy.context.preferences.addons, "the add-on did not enable"
bpy.context.preferences.addons["portcullis_blender"].preferences.binary = \
    __import__("os").environ["PORTCULLIS_BIN"]

kitchen = room("Kitchen", 0.0, 4.0, 4.0)
lounge = room("Lounge", 4.0, 8.0, 4.0)
door = mesh_object("Door", [[(4.0, 1.5, 0.0), (4.0, 2.5, 0.0), (4.0, 2.5, 2.2), (4.0, 1.5, 2.2)]])

state = bpy.context.scene.portcullis
select_only(kitchen)
bpy.ops.portcullis.tag(kind="ROOM", value="kitchen")
select_only(lounge)
bpy.ops.portcullis.tag(kind="ROOM", value="lounge")
select_only(door)
bpy.ops.portcullis.tag(kind="PORTAL")
assert kitchen["room"] == "kitchen" and door["portal"] is True

# Godot's name suffixes instead, and back: the tags round-trip through the object's name.
state.mode = "NAMES"
bpy.ops.portcullis.tag(kind="PORTAL", value="lounge")
assert door.name == "lounge*Door-portal" and "portal" not in door.keys(), door.name
bpy.ops.portcullis.untag()
assert door.name == "Door", door.name
state.mode = "EXTRAS"
bpy.ops.portcullis.tag(kind="PORTAL")

# An occupant (a monster, an item): the `occupant` custom property, or the `-occupant` suffix;
# clearing restores the object. (Removed after: the level below is the two rooms and the door.)
guard = bpy.data.objects.new("Guard", None)
bpy.context.scene.collection.objects.link(guard)
select_only(guard)
bpy.ops.portcullis.tag(kind="OCCUPANT")
assert guard["occupant"] is True and guard.name == "Guard", (guard.name, guard.keys())
bpy.ops.portcullis.untag()
assert "occupant" not in guard.keys(), guard.keys()
state.mode = "NAMES"
bpy.ops.portcullis.tag(kind="OCCUPANT")
assert guard.name == "Guard-occupant" and "occupant" not in guard.keys(), guard.name
bpy.ops.portcullis.untag()
assert guard.name == "Guard", guard.name
state.mode = "EXTRAS"
bpy.data.objects.remove(guard)

state.filepath = str(scratch / "level.glb")
assert bpy.ops.portcullis.export() == {"FINISHED"}, state.status
doc = glb_json(state.output)
ext = doc["extensions"]["PORTCULLIS_portals"]
assert len(ext["cells"]) == 2, ext["cells"]
pair = [p for p in ext["portals"] if len(p["cells"]) == 2 and set(p["cells"]) == {0, 1}]
assert len(pair) == 2, ext["portals"]
assert state.exit_code == 0, state.status
assert sorted(f.label for f in state.found if f.kind == "room") == ["kitchen", "lounge"]
print(f"exported: {len(ext['cells'])} cells, {len(pair)} portals in the doorway; {state.status}")

# Debug glTF: cells, portals and leaks in a collection of their own, replaced on each run.
assert bpy.ops.portcullis.import_debug() == {"FINISHED"}
coll = bpy.data.collections["portcullis debug"]
want = sum(1 for n in glb_json(state.debug)["nodes"] if "mesh" in n)
count = len([o for o in coll.objects if o.type == "MESH"])
assert count == want and count >= 4, (count, want)
assert coll.hide_render and all(o.hide_render for o in coll.objects)
assert bpy.ops.portcullis.import_debug() == {"FINISHED"}
assert len([o for o in bpy.data.collections["portcullis debug"].objects
            if o.type == "MESH"]) == want, "the second import replaced the first"
print(f"debug collection: {count} objects")

# The viewer's page, opened in the browser (here: the URL the add-on would open, recorded).
import webbrowser
opened = []
webbrowser.open = opened.append
assert bpy.ops.portcullis.view() == {"FINISHED"}
page = Path(opened[0].removeprefix("file://"))
assert page.exists() and "<html" in page.read_text()[:2000].lower(), opened
print(f"viewer page: {page.name}")

if screenshot:
    coll = bpy.data.collections["portcullis debug"]
    coll.hide_render = False
    for o in coll.objects:
        o.hide_render = False
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    bpy.context.scene.collection.objects.link(cam)
    from mathutils import Vector
    cam.location = (1.0, -8.0, 10.0)
    cam.rotation_euler = (Vector((4.0, 2.0, 0.5)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 4.0
    bpy.context.scene.collection.objects.link(sun)
    sun.rotation_euler = (0.5, 0.3, 0.4)
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("World")
    scene.world.color = (0.35, 0.35, 0.38)
    scene.camera = cam
    addon_utils.enable("cycles", default_set=True, handle_error=None)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.render.resolution_x, scene.render.resolution_y = 800, 450
    scene.render.filepath = str(screenshot)
    bpy.ops.render.render(write_still=True)
    print(f"rendered {screenshot}")

# As Blender's exporters: a script passes `filepath` (the panel's path stays as it is, and the
# next export without one goes there again); File > Export lists the operator, whose file
# browser opens on the panel's path; disabling the add-on takes the menu entry away.
chosen = scratch / "chosen" / "by_script.glb"
assert bpy.ops.portcullis.export(filepath=str(chosen)) == {"FINISHED"}, state.status
assert chosen.exists() and state.exported == str(chosen), state.exported
assert Path(state.output) == chosen.with_name("by_script.portals.glb"), state.output
chosen_cells = len(glb_json(state.output)["extensions"]["PORTCULLIS_portals"]["cells"])
assert chosen_cells == 2, chosen_cells
assert state.filepath == str(scratch / "level.glb"), state.filepath
import types
menu_entries = []
for draw in bpy.types.TOPBAR_MT_file_export._dyn_ui_initialize():
    if draw.__module__.startswith("portcullis_blender"):
        layout = types.SimpleNamespace(operator=lambda idname, **kw: menu_entries.append(idname))
        draw(types.SimpleNamespace(layout=layout), bpy.context)
assert menu_entries == ["portcullis.export"], menu_entries
import portcullis_blender
browsed = []
fake_op = types.SimpleNamespace(filepath="", filename_ext=".glb")
fake_context = types.SimpleNamespace(
    scene=bpy.context.scene, blend_data=bpy.data,
    window_manager=types.SimpleNamespace(fileselect_add=browsed.append))
assert portcullis_blender.PORTCULLIS_OT_export.invoke(fake_op, fake_context, None) == {"RUNNING_MODAL"}
assert browsed == [fake_op] and fake_op.filepath == str(scratch / "level.glb"), fake_op.filepath
print(f"export(filepath=...): {chosen_cells} cells in chosen/{chosen.name}; "
      f"in File > Export as {menu_entries[0]}")

# Break it: the doorway's portal moved onto the lounge's end wall, where it covers no opening.
door.location.x = 4.0
door.location.x += 3.999
assert bpy.ops.portcullis.export() == {"FINISHED"}, state.status
assert Path(state.exported) == scratch / "level.glb", state.exported
exported = [n.get("name") for n in glb_json(state.exported)["nodes"]]
assert sorted(exported) == ["Door", "Kitchen", "Lounge"], exported
named = [i for i, d in enumerate(state.diagnostics) if d.object_name == "Door"]
assert named, [(d.code, d.node) for d in state.diagnostics]
codes = {state.diagnostics[i].code for i in named}
select_only(kitchen)
assert bpy.ops.portcullis.select(index=named[0]) == {"FINISHED"}
assert bpy.context.view_layer.objects.active == door and door.select_get()
assert not kitchen.select_get()
severities = [d.severity for d in state.diagnostics]
assert severities == sorted(severities, key=["error", "warning", "info"].index), severities
print(f"broken: {sorted(codes)} on `Door`, selected by the add-on; {state.status}")

# With the preference on, the glTF exporter's own export is converted too (its post-export hook).
prefs = bpy.context.preferences.addons["portcullis_blender"].preferences
prefs.convert_on_export = True
hooked = scratch / "hooked.glb"
bpy.ops.export_scene.gltf(filepath=str(hooked), export_format="GLB", export_extras=True)
assert Path(state.output) == scratch / "hooked.portals.glb" and Path(state.output).exists(), (state.output, state.status)
assert state.exported == str(hooked)
assert sorted(n.get("name") for n in glb_json(hooked)["nodes"]) == ["Door", "Kitchen", "Lounge"]
assert "portcullis debug" in [c.name for c in bpy.context.scene.collection.children]
prefs.convert_on_export = False
print("the exporter's hook converted hooked.glb")

# The tool's own failure (exit 2) is reported as such, not as the level's errors.
state.filepath = str(scratch / "missing" / "level.glb")
bpy.context.preferences.addons["portcullis_blender"].preferences.binary = str(scratch / "nope")
import os
os.environ.pop("PORTCULLIS_BIN", None)
os.environ["PATH"] = str(scratch)
assert bpy.ops.portcullis.export() == {"CANCELLED"}
assert state.exit_code == 2 and "not found" in state.status, state.status

addon_utils.disable("portcullis_blender", default_set=True)
assert not [f for f in bpy.types.TOPBAR_MT_file_export._dyn_ui_initialize()
            if f.__module__.startswith("portcullis_blender")], "File > Export kept the entry"
print("all add-on checks passed")
