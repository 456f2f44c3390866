//! OBJ importer: real exported levels, small hand-written files for each rule, malformed input.

use std::path::{Path, PathBuf};

use glam::DVec3;
use portcullis::diag::{Code, Diagnostic, Severity};
use portcullis::geom::aabb::Aabb;
use portcullis::import::{import_bytes, import_path, ImportOptions, Imported};
use portcullis::scene::{Format, NodeId, Scene};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(rel)
}

fn third_party(name: &str) -> Imported {
    let path = fixture(&format!("third_party/{name}"));
    import_path(&path, &ImportOptions::default()).unwrap_or_else(|d| panic!("{name}: {d}"))
}

fn obj_with(src: &str, opts: &ImportOptions) -> Result<Imported, Diagnostic> {
    let dir = tempfile::tempdir().expect("temp dir");
    import_bytes(
        src.as_bytes(),
        Path::new("inline.obj"),
        Format::Obj,
        dir.path(),
        opts,
    )
}

fn obj(src: &str) -> Imported {
    obj_with(src, &ImportOptions::default()).unwrap_or_else(|d| panic!("{d}"))
}

fn find(scene: &Scene, path: &str) -> NodeId {
    scene
        .walk()
        .into_iter()
        .find(|&n| scene.node_path(n) == path)
        .unwrap_or_else(|| {
            let all: Vec<String> = scene.walk().iter().map(|&n| scene.node_path(n)).collect();
            panic!("no node `{path}` in {all:?}")
        })
}

/// Area of a node's triangles, to check that an n-gon was covered exactly.
fn area(scene: &Scene, node: NodeId) -> f64 {
    let m = &scene.meshes[scene.nodes[node].mesh.expect("node has a mesh")];
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            (b - a).cross(c - a).length() / 2.0
        })
        .sum()
}

/// Expected triangles counted independently of the importer: each `f` line with k corners is
/// k - 2 triangles (the fixtures use no line continuations).
fn expected_triangles(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).expect("fixture is text");
    text.lines()
        .filter_map(|l| {
            let mut t = l.split_whitespace();
            (t.next() == Some("f")).then(|| t.count() - 2)
        })
        .sum()
}

fn no_errors(imp: &Imported) {
    let errors: Vec<String> = imp
        .diagnostics
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .map(ToString::to_string)
        .collect();
    assert!(errors.is_empty(), "{errors:?}");
}

// --- third-party levels ---------------------------------------------------------------------

#[test]
fn lportal_tutorial_simple() {
    let imp = third_party("lportal_tutorial_simple.obj");
    no_errors(&imp);
    let s = &imp.scene;
    assert_eq!(s.triangle_count(), 158);
    let wall = find(s, "Root/RoomList/room_kitchen/Wall3");
    let b = Aabb::from_points(&s.world_positions(wall));
    assert_eq!(b.min, DVec3::new(2.8, 0.0, 1.0));
    assert_eq!(b.max, DVec3::new(3.0, 2.0, 3.0));
    assert_eq!(s.nodes[wall].source.line, Some(91));

    let kitchen = find(s, "Root/RoomList/room_kitchen");
    let names: Vec<String> = s.nodes[kitchen]
        .children
        .iter()
        .map(|&c| s.node_label(c))
        .collect();
    assert_eq!(
        names,
        [
            "Floor",
            "Wall0",
            "Wall1",
            "Wall2",
            "Wall3",
            "Wall4",
            "portal_lounge"
        ]
    );
    assert_eq!(s.roots.len(), 1, "one `Root`, reused by every path");
    let portal = find(s, "Root/RoomList/room_kitchen/portal_lounge");
    let mesh = s.nodes[portal].mesh.expect("portal mesh");
    assert_eq!(s.mesh_material_names(mesh), [Some("SpatialMaterial_4")]);
    assert_eq!(s.meshes[mesh].primitives[0].source.line, Some(136));
    // Only the vertices the mesh uses.
    assert_eq!(
        s.meshes[s.nodes[wall].mesh.expect("wall mesh")]
            .positions
            .len(),
        8
    );
}

#[test]
fn lportal_boxrooms() {
    let imp = third_party("lportal_boxrooms.obj");
    no_errors(&imp);
    assert_eq!(imp.scene.triangle_count(), 3352);
}

#[test]
fn panda3d_culling() {
    let imp = third_party("panda3d_culling.obj");
    no_errors(&imp);
    assert_eq!(imp.scene.triangle_count(), 385);
    find(&imp.scene, "levelgeo");
    find(&imp.scene, "portal_1to2_1");
}

#[test]
fn navigation_level_mesh_missing_mtl() {
    let path = fixture("third_party/navigation_level_mesh.obj");
    let imp = third_party("navigation_level_mesh.obj");
    assert_eq!(imp.scene.triangle_count(), expected_triangles(&path));
    assert_eq!(
        imp.scene.triangle_count(),
        138,
        "all 138 faces are triangles"
    );
    let d = imp
        .diagnostics
        .iter()
        .find(|d| d.code == Code::OBJ_MTL_MISSING)
        .expect("missing level_mesh.mtl is reported");
    assert_eq!(d.severity, Severity::Warning);
    assert!(d.message.contains("level_mesh.mtl"), "{d}");
    assert_eq!(d.location.source.line, Some(1));
    // `o level_mesh` then `g surface0`: the group is a child of the object.
    let g = find(&imp.scene, "level_mesh/surface0");
    assert!(imp.scene.nodes[g].mesh.is_some());
}

#[test]
fn pandora() {
    let path = fixture("third_party/pandora.obj");
    let imp = third_party("pandora.obj");
    no_errors(&imp);
    assert!(
        !imp.diagnostics.has(Code::OBJ_MTL_MISSING),
        "pandora.mtl is present"
    );
    let faces = std::fs::read_to_string(&path)
        .expect("text")
        .lines()
        .filter(|l| l.starts_with("f "))
        .count();
    assert_eq!(faces, 60810);
    assert_eq!(imp.scene.triangle_count(), expected_triangles(&path));
    // Groups with no `o` are top-level nodes.
    let slot2 = find(&imp.scene, "slot2");
    assert!(imp.scene.nodes[slot2].parent.is_none());
}

// --- hand-written files ---------------------------------------------------------------------

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n";

#[test]
fn object_then_group_is_a_child() {
    let imp = obj(&format!("{QUAD}o Room1\ng floor\nf 1 2 3 4\n"));
    let s = &imp.scene;
    let floor = find(s, "Room1/floor");
    assert_eq!(s.nodes[floor].source.line, Some(6));
    assert_eq!(s.nodes[find(s, "Room1")].source.line, Some(5));
    assert!(s.nodes[find(s, "Room1")].mesh.is_none());
    assert_eq!(s.triangle_count(), 2);
    assert!(s.nodes[floor].mesh.is_some());
}

#[test]
fn group_before_object_is_top_level() {
    let imp = obj(&format!(
        "{QUAD}g a b\nf 1 2 3\no Room\nf 1 3 4\ng\nf 1 2 4\ng default\nf 2 3 4\n"
    ));
    let s = &imp.scene;
    let ab = find(s, "a b");
    assert!(s.nodes[ab].parent.is_none());
    let room = find(s, "Room");
    assert!(s.nodes[room].parent.is_none());
    let m = &s.meshes[s.nodes[room].mesh.expect("room mesh")];
    assert_eq!(
        m.triangles.len(),
        3,
        "bare `g` and `g default` return to the object"
    );
}

#[test]
fn faces_before_any_name_use_the_file_stem() {
    let imp = obj(&format!(
        "{QUAD}f 1 2 3\ng part\nf 1 3 4\ng\nf 1 2 4\no later\nf 1 3 4\n"
    ));
    let s = &imp.scene;
    let n = find(s, "inline");
    assert_eq!(s.nodes[n].source.line, Some(5));
    assert_eq!(s.meshes[s.nodes[n].mesh.expect("mesh")].triangles.len(), 2);
    find(s, "part");
    find(s, "later");
    assert_eq!(s.roots.len(), 3);
}

#[test]
fn path_splitting() {
    let src = format!("{QUAD}o Level/room_x0y0/Floor\nf 1 2 3\no Level/room_x0y0/Wall\nf 1 3 4\no Level/room_x0y0/Floor\nf 1 2 4\n");
    let imp = obj(&src);
    let s = &imp.scene;
    assert_eq!(s.roots.len(), 1);
    let room = find(s, "Level/room_x0y0");
    assert_eq!(s.nodes[room].children.len(), 2);
    let floor = find(s, "Level/room_x0y0/Floor");
    let m = &s.meshes[s.nodes[floor].mesh.expect("floor mesh")];
    assert_eq!(
        m.triangles.len(),
        2,
        "the repeated path continues the same node"
    );
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(s.meshes.len(), 2);

    let flat = obj_with(
        &src,
        &ImportOptions {
            obj_split_paths: false,
            ..Default::default()
        },
    )
    .expect("imports");
    let s = &flat.scene;
    assert_eq!(s.roots.len(), 2);
    let floor = s
        .roots
        .iter()
        .copied()
        .find(|&n| s.nodes[n].name.as_deref() == Some("Level/room_x0y0/Floor"))
        .expect("unsplit name");
    assert!(s.nodes[floor].children.is_empty());
}

#[test]
fn usemtl_split_is_one_node_one_mesh_two_primitives() {
    let imp = obj(&format!(
        "mtllib nowhere.mtl\n{QUAD}o Box\nusemtl stone\nf 1 2 3\nf 1 3 4\nusemtl wood\nf 1 2 4\no Other\nf 2 3 4\no Box\nf 1 2 3\n"
    ));
    let s = &imp.scene;
    assert_eq!(s.nodes.len(), 2);
    assert_eq!(s.meshes.len(), 2);
    let b = find(s, "Box");
    let mesh = s.nodes[b].mesh.expect("box mesh");
    let m = &s.meshes[mesh];
    assert_eq!(m.primitives.len(), 2, "{:?}", m.primitives);
    assert_eq!(s.mesh_material_names(mesh), [Some("stone"), Some("wood")]);
    assert_eq!(m.primitives[0].triangle_count, 2);
    assert_eq!(
        m.primitives[1].triangle_count, 2,
        "`o Box` again still uses wood"
    );
    assert_eq!(m.primitives[0].source.line, Some(7));
    assert_eq!(m.primitives[1].source.line, Some(10));
    assert_eq!(s.materials.len(), 2);
    assert_eq!(s.materials[1].source.line, Some(10));
    // `Other` inherits `wood` from before its `o`: the span starts at its first face.
    let other = &s.meshes[s.nodes[find(s, "Other")].mesh.expect("other mesh")];
    assert_eq!(other.primitives[0].source.line, Some(13));
    assert!(imp.diagnostics.has(Code::OBJ_MTL_MISSING));
}

#[test]
fn negative_indices() {
    let imp = obj("o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1\nv 0 1 0\nf 1 -2 -1\n");
    let s = &imp.scene;
    assert_eq!(s.triangle_count(), 2);
    let m = &s.meshes[0];
    let p = |t: usize| m.triangles[t].map(|i| m.positions[i as usize]);
    assert_eq!(p(1), [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
    let err = obj_with("v 0 0 0\nf -1 -2 -3\n", &ImportOptions::default()).unwrap_err();
    assert_eq!(err.code, Code::OBJ_BAD_INDEX);
}

#[test]
fn concave_ngon_is_triangulated_exactly() {
    // An L-shaped floor (area 5) in the XZ plane, facing up, plus a U in a tilted wall.
    let src = "o floor\nv 0 0 0\nv 0 0 -3\nv 1 0 -3\nv 1 0 -1\nv 3 0 -1\nv 3 0 0\nf 1 6 5 4 3 2\n\
               o wall\nv 0 0 0\nv 3 0 0\nv 3 3 3\nv 2 3 3\nv 2 1 1\nv 1 1 1\nv 1 3 3\nv 0 3 3\n\
               f 7 8 9 10 11 12 13 14\n";
    let imp = obj(src);
    assert!(imp.diagnostics.is_empty(), "{:?}", imp.diagnostics);
    let s = &imp.scene;
    let floor = find(s, "floor");
    assert_eq!(
        s.meshes[s.nodes[floor].mesh.expect("mesh")].triangles.len(),
        4
    );
    assert!((area(s, floor) - 5.0).abs() < 1e-12);
    let m = &s.meshes[s.nodes[floor].mesh.expect("mesh")];
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).y > 0.0, "faces up like the polygon");
    }
    let wall = find(s, "wall");
    assert_eq!(
        s.meshes[s.nodes[wall].mesh.expect("mesh")].triangles.len(),
        6
    );
    // U = 3x3 minus the 1x2 notch, stretched by sqrt(2) along the tilt.
    assert!((area(s, wall) - 7.0 * 2f64.sqrt()).abs() < 1e-9);
}

#[test]
fn self_intersecting_face_is_fanned_with_warning() {
    let imp = obj("o bow\nv 0 0 0\nv 1 1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 4\n");
    let d = imp
        .diagnostics
        .iter()
        .find(|d| d.code == Code::OBJ_POLYGON_SELF_INTERSECTING)
        .expect("warned");
    assert_eq!(d.severity, Severity::Warning);
    assert_eq!(d.location.source.line, Some(6));
    assert_eq!(d.location.node.as_deref(), Some("bow"));
    assert_eq!(imp.scene.triangle_count(), 2);
}

#[test]
fn vertex_reference_forms_and_extras() {
    let src =
        "o a\nv 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\ns 1\n\
               f 1/1 2/2 3/2\nf 1//1 3//1 4//1\nfo 1/1/1 2/2/1 3/1/1\nl 1 2\nl 2 3\np 1\n";
    let imp = obj(src);
    assert_eq!(imp.scene.triangle_count(), 3);
    let info: Vec<_> = imp
        .diagnostics
        .iter()
        .filter(|d| d.code == Code::OBJ_UNSUPPORTED_STATEMENT)
        .collect();
    assert_eq!(info.len(), 1);
    assert_eq!(info[0].severity, Severity::Info);
    assert!(info[0].message.contains("2 × `l`"), "{}", info[0]);
    assert!(info[0].message.contains("1 × `p`"), "{}", info[0]);
    assert!(!info[0].message.contains("vt"));
    assert_eq!(
        imp.scene.meshes[0].positions[1],
        DVec3::X,
        "colour is not a coordinate"
    );
}

#[test]
fn continuation_lines_comments_crlf() {
    let src = "# header\r\no a # trailing comment\r\nv 0 0 \\\r\n 0\r\nv 1 0 0\r\n\r\nv 1 1 0\r\nf 1 \\\n 2 \\\n 3\r\no Room#2\nf 1 2 3\n";
    let imp = obj(src);
    let s = &imp.scene;
    assert_eq!(s.triangle_count(), 2);
    find(s, "a");
    let r = find(s, "Room#2");
    assert_eq!(s.nodes[r].source.line, Some(11));
    assert_eq!(s.meshes[0].positions[0], DVec3::ZERO);
}

#[test]
fn latin1_names_are_text() {
    let mut src = b"o Caf\xe9\n".to_vec();
    src.extend_from_slice(QUAD.as_bytes());
    src.extend_from_slice(b"f 1 2 3\n");
    let dir = tempfile::tempdir().expect("temp dir");
    let imp = import_bytes(
        &src,
        Path::new("l1.obj"),
        Format::Obj,
        dir.path(),
        &ImportOptions::default(),
    )
    .expect("Latin-1 is text");
    find(&imp.scene, "Café");
}

#[test]
fn bad_statements_are_fatal_with_line() {
    for (src, code, line) in [
        ("v 0 0 0\nv 1 0\n", Code::OBJ_BAD_STATEMENT, 2),
        ("v 0 0 0\n1 2 3\n", Code::OBJ_BAD_STATEMENT, 2),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n",
            Code::OBJ_BAD_STATEMENT,
            4,
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
            Code::OBJ_BAD_STATEMENT,
            4,
        ),
        ("v 0,5 0 0\n", Code::OBJ_BAD_STATEMENT, 1),
        (
            "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n",
            Code::OBJ_BAD_INDEX,
            3,
        ),
    ] {
        let err = obj_with(src, &ImportOptions::default()).unwrap_err();
        assert_eq!(err.code, code, "{src:?}: {err}");
        assert_eq!(err.location.source.line, Some(line), "{src:?}: {err}");
        assert!(err.hint.is_some());
    }
    let long = format!("v 1 2 {}\n", "9".repeat(500) + "z");
    let err = obj_with(&long, &ImportOptions::default()).unwrap_err();
    assert!(err.message.chars().count() < 300, "{}", err.message);
}

#[test]
fn hostile_input_never_panics() {
    let inputs: [&[u8]; 8] = [
        b"f",
        b"f -99999999999999999999 1 2",
        b"v 1e308 1e308 1e308\nv -1e308 1e308 0\nv 1e308 -1e308 5\nv 0 0 1e308\nf 1 2 3 4\n",
        b"v inf 0 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 4\nf 2 3 4\n",
        b"\\\n\\\n\\",
        b"g\no\nusemtl\nmtllib\n",
        b"v 0 0 0\nf 1 1 1 1\n",
        b"\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    ];
    for src in inputs {
        let dir = tempfile::tempdir().expect("temp dir");
        let _ = import_bytes(
            src,
            Path::new("h.obj"),
            Format::Obj,
            dir.path(),
            &ImportOptions::default(),
        );
    }
}

// --- malformed fixtures ---------------------------------------------------------------------

fn malformed(name: &str) -> (PathBuf, Result<Imported, Diagnostic>) {
    let path = fixture(&format!("malformed/obj/{name}"));
    let r = import_path(&path, &ImportOptions::default());
    (path, r)
}

/// The fatal diagnostic names the file, and the line when there is one.
fn assert_fatal(name: &str, code: Code, line: Option<usize>) -> Diagnostic {
    let (path, r) = malformed(name);
    let d = match r {
        Err(d) => d,
        Ok(_) => panic!("{name} should not import"),
    };
    assert_eq!(d.code, code, "{name}: {d}");
    let shown = d.to_string();
    assert!(shown.contains(&path.display().to_string()), "{shown}");
    if let Some(l) = line {
        assert_eq!(d.location.source.line, Some(l), "{shown}");
        assert!(shown.contains(&format!("{name}:{l}")), "{shown}");
        assert!(d.message.contains(&format!("line {l}")), "{shown}");
    }
    d
}

#[test]
fn malformed_empty() {
    assert_fatal("empty.obj", Code::INPUT_EMPTY, None);
}

/// binary.obj: 256 bytes, the low byte of each xorshift32 step from seed 0x2545F491, with
/// byte 16 set to 0. Regenerated here so the fixture's origin stays checkable.
#[test]
fn malformed_binary() {
    let mut x: u32 = 0x2545_F491;
    let mut want: Vec<u8> = (0..256)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as u8
        })
        .collect();
    want[16] = 0;
    let (path, _) = malformed("binary.obj");
    assert_eq!(std::fs::read(&path).expect("fixture"), want);
    let d = assert_fatal("binary.obj", Code::OBJ_NOT_TEXT, None);
    assert!(d.message.contains("byte 16"), "{d}");
}

#[test]
fn malformed_bad_index() {
    let d = assert_fatal("bad_index.obj", Code::OBJ_BAD_INDEX, Some(5));
    assert!(d.message.contains("99"), "{d}");
}

#[test]
fn malformed_zero_index() {
    assert_fatal("zero_index.obj", Code::OBJ_BAD_INDEX, Some(5));
}

#[test]
fn malformed_bad_number() {
    let d = assert_fatal("bad_number.obj", Code::OBJ_BAD_STATEMENT, Some(3));
    assert!(d.message.contains("v 1 x 3"), "{d}");
}

#[test]
fn malformed_short_face() {
    assert_fatal("short_face.obj", Code::OBJ_BAD_STATEMENT, Some(4));
}

#[test]
fn malformed_nan_is_reported_not_fatal() {
    let (path, r) = malformed("nan.obj");
    let imp = r.unwrap_or_else(|d| panic!("{d}"));
    assert_eq!(
        imp.scene.triangle_count(),
        1,
        "only the face without NaN is kept"
    );
    let d = imp
        .diagnostics
        .iter()
        .find(|d| d.code == Code::GEOM_NON_FINITE)
        .expect("non-finite vertex reported");
    assert_eq!(d.severity, Severity::Error);
    assert_eq!(d.location.source.line, Some(6));
    assert!(d.message.contains("line 8"), "names the dropped face: {d}");
    let shown = d.to_string();
    assert!(shown.contains(&format!("{}:6", path.display())), "{shown}");
    for p in &imp.scene.meshes[0].positions {
        assert!(p.is_finite());
    }
}

/// The file's precision is read from its digits: a writer that printed six significant
/// digits everywhere (`%g`) is taken at its sixth digit, round numbers as exact.
#[test]
fn precision_comes_from_the_digits_written() {
    use portcullis::scene::Precision;
    let g6 = "v 2.99397 1.48611 -0.838305\nv -2.30748 3.3704 3.18072\nv 0.997627 3.3704 0.115602\nv -4 0 4\nf 1 2 3\nf 1 3 4\n";
    assert_eq!(obj(g6).scene.precision, Precision::Decimal(6));
    // Fixed six places (Blender's writer): seven digits at the largest coordinates.
    let f6 = "v 1.000000 0.000000 -4.250000\nv 2.123457 3.370400 3.180720\nv 0.997627 3.370400 0.115602\nf 1 2 3\n";
    assert_eq!(obj(f6).scene.precision, Precision::Decimal(7));
    // Round values, however large, or a few long ones among them: exact as written.
    let round =
        "v 100000 0 100004\nv 100003.5 3 100000\nv 100008 0 100002.5\nv 0 0 2.01\nf 1 2 3\n";
    assert_eq!(obj(round).scene.precision, Precision::Binary64);
    let full = "v 0.1 0.30000000000000004 2\nv 1 2 3\nv 4 5 6\nf 1 2 3\n";
    assert_eq!(obj(full).scene.precision, Precision::Binary64);
    // A hostile exponent is a number like any other, not an overflow.
    let hostile =
        "v 1e-9223372036854775808 0 1.5e+9223372036854775807\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    assert_eq!(obj(hostile).scene.precision, Precision::Binary64);
    // What six digits mean at the level's size: 1e-5 m for coordinates up to 7.5 m.
    assert_eq!(Precision::Decimal(6).spacing(4.0), 1e-5);
}
