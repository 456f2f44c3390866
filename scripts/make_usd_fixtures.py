#!/usr/bin/env python3
"""Writes the USD test fixtures in tests/fixtures/usd/ with Pixar's usd-core.

Run with the project's venv from the repository root:
    .venv/bin/python scripts/make_usd_fixtures.py
The files are checked in (so the tests need no Python of their own); rerun after changing this
script. The level: a row of three 4 x 3 x 4 m rooms with a door in each side wall. Each room
owns its walls (LPortal style), so neighbouring rooms meet in two coplanar door walls.

    rooms_y_m.usda       Y-up, metres, geometry authored under each room
    rooms_y_m.usdc/.usdz the same level in the binary format and as a package
    rooms_z_cm.usda      the same level Z-up in centimetres, rooms placed by xformOps
    rooms_instanced.usda one room prototype, three instanceable references
    rooms_flat.usda      the instanced level with every room written out (its flattened twin)
    portal_light.usda    a room with a UsdLuxPortalLight named like a portal
    point_instancer.usda a room with crates placed by a PointInstancer (one instance invisible)
    tags_and_hidden.usda tags in customData and custom attributes, a hidden and a guide prim,
                         an n-gon floor with a hole face, a leftHanded wall
    broken.usda          a syntax error
    missing_reference.usda  a room referencing a file that does not exist
    bad_meshes.usda      meshes whose arrays do not fit together, a NaN point, a 2-corner face
"""
import os
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdUtils, Vt

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "fixtures", "usd")

W, H, D = 4.0, 3.0, 4.0          # room size x, y (up), z
DOOR_Z, DOOR_W, DOOR_H = 1.5, 1.0, 2.0


def room_faces():
    """(name, polygons) of one room in Y-up metres, origin at its -x, floor, -z corner."""
    floor = [(0, 0, 0), (0, 0, D), (W, 0, D), (W, 0, 0)]
    back = [(0, 0, 0), (W, 0, 0), (W, H, 0), (0, H, 0)]
    front = [(0, 0, D), (0, H, D), (W, H, D), (W, 0, D)]

    def side(x):
        # a wall in the plane x with a door notch cut from the floor: a concave 8-gon
        pts = [(0, 0), (0, DOOR_Z), (DOOR_H, DOOR_Z), (DOOR_H, DOOR_Z + DOOR_W),
               (0, DOOR_Z + DOOR_W), (0, D), (H, D), (H, 0)]
        poly = [(x, y, z) for y, z in pts]
        return poly if x > 0 else list(reversed(poly))

    return [("floor", [floor]), ("walls", [back, front]), ("door_west", [side(0.0)]),
            ("door_east", [side(W)])]


def write_mesh(stage, path, polys, xf=lambda p: p):
    mesh = UsdGeom.Mesh.Define(stage, path)
    pts, counts, idx = [], [], []
    for poly in polys:
        counts.append(len(poly))
        for p in poly:
            idx.append(len(pts))
            pts.append(Gf.Vec3f(*xf(p)))
    mesh.CreatePointsAttr(Vt.Vec3fArray(pts))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray(counts))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(idx))
    mesh.CreateSubdivisionSchemeAttr("none")
    return mesh


def new_stage(name, up="Y", mpu=1.0):
    path = os.path.join(OUT, name)
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, mpu)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    return stage


def rooms_y_m():
    stage = new_stage("rooms_y_m.usda")
    for i, r in enumerate("abc"):
        UsdGeom.Xform.Define(stage, f"/World/room_{r}")
        for name, polys in room_faces():
            write_mesh(stage, f"/World/room_{r}/{name}", polys,
                       lambda p, i=i: (p[0] + i * W, p[1], p[2]))
    stage.Save()


def rooms_z_cm():
    """Y-up (x, y, z) metres -> Z-up (x, -z, y) centimetres; rooms moved by a translate op."""
    stage = new_stage("rooms_z_cm.usda", up="Z", mpu=0.01)
    for i, r in enumerate("abc"):
        room = UsdGeom.Xform.Define(stage, f"/World/room_{r}")
        room.AddTranslateOp().Set(Gf.Vec3d(i * W * 100.0, 0.0, 0.0))
        for name, polys in room_faces():
            write_mesh(stage, f"/World/room_{r}/{name}", polys,
                       lambda p: (p[0] * 100.0, -p[2] * 100.0, p[1] * 100.0))
    stage.Save()


def rooms_instanced(flat):
    stage = new_stage("rooms_flat.usda" if flat else "rooms_instanced.usda")
    if not flat:
        # a class: abstract, so never drawn itself, only through the references below
        stage.CreateClassPrim("/RoomPrototype").SetTypeName("Xform")
        for name, polys in room_faces():
            write_mesh(stage, f"/RoomPrototype/{name}", polys)
    for i, r in enumerate("abc"):
        room = UsdGeom.Xform.Define(stage, f"/World/room_{r}")
        room.AddTranslateOp().Set(Gf.Vec3d(i * W, 0.0, 0.0))
        if flat:
            for name, polys in room_faces():
                write_mesh(stage, f"/World/room_{r}/{name}", polys)
        else:
            room.GetPrim().GetReferences().AddInternalReference("/RoomPrototype")
            room.GetPrim().SetInstanceable(True)
    stage.Save()


def portal_light():
    stage = new_stage("portal_light.usda")
    UsdGeom.Xform.Define(stage, "/World/room_a")
    for name, polys in room_faces():
        write_mesh(stage, f"/World/room_a/{name}", polys)
    light = UsdLux.PortalLight.Define(stage, "/World/room_a/portal_window")
    light.AddTranslateOp().Set(Gf.Vec3d(W, 1.0, D / 2))
    stage.Save()


def point_instancer():
    stage = new_stage("point_instancer.usda")
    UsdGeom.Xform.Define(stage, "/World/room_a")
    for name, polys in room_faces():
        write_mesh(stage, f"/World/room_a/{name}", polys)
    inst = UsdGeom.PointInstancer.Define(stage, "/World/room_a/crates")
    inst.AddTranslateOp().Set(Gf.Vec3d(1, 0, 0))
    UsdGeom.Scope.Define(stage, "/World/room_a/crates/Prototypes")
    c = 0.25
    cube = [[(-c, -c, -c), (-c, c, -c), (c, c, -c), (c, -c, -c)],
            [(-c, -c, c), (c, -c, c), (c, c, c), (-c, c, c)],
            [(-c, -c, -c), (c, -c, -c), (c, -c, c), (-c, -c, c)],
            [(-c, c, -c), (-c, c, c), (c, c, c), (c, c, -c)],
            [(-c, -c, -c), (-c, -c, c), (-c, c, c), (-c, c, -c)],
            [(c, -c, -c), (c, c, -c), (c, c, c), (c, -c, c)]]
    crate = write_mesh(stage, "/World/room_a/crates/Prototypes/crate", cube)
    crate.AddTranslateOp().Set(Gf.Vec3d(0, c, 0))
    inst.CreatePrototypesRel().SetTargets([crate.GetPath()])
    inst.CreateProtoIndicesAttr(Vt.IntArray([0, 0, 0]))
    inst.CreatePositionsAttr(Vt.Vec3fArray([(1, 0, 1), (2, 0, 2), (3, 0, 3)]))
    inst.CreateInvisibleIdsAttr(Vt.Int64Array([2]))
    stage.Save()


def tags_and_hidden():
    stage = new_stage("tags_and_hidden.usda")
    kitchen = UsdGeom.Xform.Define(stage, "/World/Kitchen").GetPrim()
    kitchen.SetCustomDataByKey("portcullis:room", "kitchen")
    for name, polys in room_faces():
        write_mesh(stage, f"/World/Kitchen/{name}", polys)
    door = write_mesh(stage, "/World/Kitchen/DoorQuad",
                      [[(W, 0, DOOR_Z), (W, 0, DOOR_Z + DOOR_W), (W, DOOR_H, DOOR_Z + DOOR_W),
                        (W, DOOR_H, DOOR_Z)]]).GetPrim()
    door.CreateAttribute("userProperties:portal", Sdf.ValueTypeNames.String,
                         custom=True).Set("lounge")
    door.CreateAttribute("portcullis:one_way", Sdf.ValueTypeNames.Bool, custom=True).Set(True)
    lounge = UsdGeom.Xform.Define(stage, "/World/Lounge").GetPrim()
    lounge.CreateAttribute("room", Sdf.ValueTypeNames.String, custom=True).Set("lounge")
    lounge_xf = UsdGeom.Xformable(lounge)
    lounge_xf.AddTranslateOp().Set(Gf.Vec3d(W, 0, 0))
    for name, polys in room_faces():
        write_mesh(stage, f"/World/Lounge/{name}", polys)
    # An n-gon floor whose second face is a hole, and a left-handed wall.
    extra = write_mesh(stage, "/World/Lounge/rug",
                       [[(1, 0.01, 1), (1, 0.01, 3), (3, 0.01, 3), (3, 0.01, 1)],
                        [(1.5, 0.01, 1.5), (1.5, 0.01, 2.5), (2.5, 0.01, 2.5)]])
    extra.CreateHoleIndicesAttr(Vt.IntArray([1]))
    lh = write_mesh(stage, "/World/Lounge/panel", [[(1, 0, 0.1), (3, 0, 0.1), (3, 2, 0.1),
                                                    (1, 2, 0.1)]])
    lh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    UsdGeom.Xform.Define(stage, "/World/room_hidden").MakeInvisible()
    write_mesh(stage, "/World/room_hidden/floor", room_faces()[0][1])
    guide = UsdGeom.Xform.Define(stage, "/World/room_guide")
    guide.CreatePurposeAttr(UsdGeom.Tokens.guide)
    write_mesh(stage, "/World/room_guide/floor", room_faces()[0][1])
    UsdGeom.Cube.Define(stage, "/World/Lounge/crate")
    stage.Save()


def broken():
    with open(os.path.join(OUT, "broken.usda"), "w") as f:
        f.write('#usda 1.0\n(\n    upAxis = "Y"\n)\n\ndef Xform "World"\n{\n'
                '    def Mesh "floor"\n    {\n        int[] faceVertexCounts = [4\n    }\n}\n')


def missing_reference():
    stage = new_stage("missing_reference.usda")
    room = UsdGeom.Xform.Define(stage, "/World/room_a").GetPrim()
    room.GetReferences().AddReference("./no_such_room.usda")
    stage.Save()


def bad_meshes():
    stage = new_stage("bad_meshes.usda")
    UsdGeom.Xform.Define(stage, "/World/room_a")
    for name, polys in room_faces():
        write_mesh(stage, f"/World/room_a/{name}", polys)
    m = write_mesh(stage, "/World/room_a/out_of_range", [[(0, 0, 0), (1, 0, 0), (1, 1, 0)]])
    m.GetFaceVertexIndicesAttr().Set(Vt.IntArray([0, 1, 7]))
    m = write_mesh(stage, "/World/room_a/short_indices", [[(0, 0, 0), (1, 0, 0), (1, 1, 0)]])
    m.GetFaceVertexCountsAttr().Set(Vt.IntArray([4]))
    m = write_mesh(stage, "/World/room_a/nan_point",
                   [[(0, 0, 0), (1, 0, 0), (1, 1, 0)], [(2, 0, 0), (3, 0, 0), (3, 1, 0)]])
    pts = m.GetPointsAttr().Get()
    pts[0] = Gf.Vec3f(float("nan"), 0, 0)
    m.GetPointsAttr().Set(pts)
    m = write_mesh(stage, "/World/room_a/two_corners", [[(0, 0, 0), (1, 0, 0)],
                                                        [(0, 0, 0), (1, 0, 0), (1, 1, 0)]])
    stage.Save()


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    for f in os.listdir(OUT):
        if f.endswith((".usda", ".usdc", ".usdz")):
            os.remove(os.path.join(OUT, f))
    rooms_y_m()
    Usd.Stage.Open(os.path.join(OUT, "rooms_y_m.usda")).Export(os.path.join(OUT, "rooms_y_m.usdc"))
    UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(os.path.join(OUT, "rooms_y_m.usdc")),
                                  os.path.join(OUT, "rooms_y_m.usdz"))
    rooms_z_cm()
    rooms_instanced(flat=False)
    rooms_instanced(flat=True)
    portal_light()
    point_instancer()
    tags_and_hidden()
    broken()
    missing_reference()
    bad_meshes()
    print("wrote", sorted(os.listdir(OUT)), file=sys.stderr)
