//! `convert IN -o OUT.usda`: the annotated level as a USD text layer, written atomically, with
//! cells and portals as `portcullis:` custom attributes. Needs no `usd` feature (the layer is
//! written as text); reading it back through usd-core is checked in tests/import_usd.rs.

mod common;

use assert_cmd::Command;
use common::sample;

fn portcullis() -> Command {
    let mut c = Command::cargo_bin("portcullis").unwrap();
    c.env("NO_COLOR", "1");
    c
}

#[test]
fn convert_writes_a_usda_layer_with_cells_and_portals() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("two_rooms.usda");
    common::succeeds(
        portcullis()
            .arg("convert")
            .arg(sample("two_rooms.gltf"))
            .arg("-o")
            .arg(&out),
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("#usda 1.0\n"));
    assert!(text.contains("upAxis = \"Y\""));
    assert!(text.contains("metersPerUnit = 1"));
    assert!(text.contains("def Scope \"PortcullisAnnotation\""));
    let (t, c, p) = common::load_level(&sample("two_rooms.gltf"), None);
    let _ = t;
    assert_eq!(
        text.matches("custom double4[] portcullis:planes").count(),
        c.cells.len()
    );
    assert_eq!(
        text.matches("custom double3[] portcullis:polygon").count(),
        p.portals.len()
    );
    assert!(text.contains("def Mesh"));
    // Written atomically: nothing but the output in the folder.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
    assert_eq!(names.len(), 1);
    // The same input gives the same bytes.
    let again = dir.path().join("again.usda");
    portcullis()
        .arg("convert")
        .arg(sample("two_rooms.gltf"))
        .arg("-o")
        .arg(&again)
        .assert()
        .success();
    let text2 = std::fs::read_to_string(&again).unwrap();
    assert_eq!(
        text.replace("two_rooms.usda", ""),
        text2.replace("again.usda", "")
    );
}

#[test]
fn names_that_are_not_usd_identifiers_keep_their_spelling_as_display_names() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::write(
        dir.path(),
        "names.gltf",
        &common::gltf(&[
            common::n("kitchen-room", None, false),
            common::n("1 floor", Some(0), true),
            common::n("1 floor", Some(0), true),
        ]),
    );
    // The flat room is an error, which would leave no output; demoted, the run passes.
    std::fs::write(
        dir.path().join("portcullis.toml"),
        "[check]\nseverity = { CELL_ROOM_DEGENERATE = \"warning\" }\n",
    )
    .unwrap();
    let out = dir.path().join("names.usda");
    portcullis()
        .arg("convert")
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .assert()
        .code(0);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("def Xform \"kitchen_room\" ("), "{text}");
    assert!(text.contains("displayName = \"kitchen-room\""));
    assert!(text.contains("def Mesh \"_1_floor\" ("));
    assert!(text.contains("def Mesh \"_1_floor_1\" ("));
}

/// With a PVS, the layer carries it as two flat arrays (offsets and visible cells), the same
/// sets `vis` computes; with `--vis none` it has none.
#[test]
fn convert_stores_the_pvs_in_the_usda_layer() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pillar.usda");
    let input = sample("pillar_room.gltf");
    common::succeeds(portcullis().arg("convert").arg(&input).arg("-o").arg(&out));
    let text = std::fs::read_to_string(&out).unwrap();
    let array = |name: &str| -> Vec<usize> {
        let key = format!("custom int[] portcullis:{name} = [");
        let start = text.find(&key).unwrap_or_else(|| panic!("no {name}")) + key.len();
        let end = start + text[start..].find(']').unwrap();
        text[start..end]
            .split(',')
            .map(|v| v.trim().parse().unwrap())
            .collect()
    };
    let (offsets, visible) = (array("offsets"), array("visible"));
    assert!(text.contains("custom token portcullis:method = \"full\""));
    let (_, c, p) = common::load_level(&input, None);
    let pvs = portcullis::vis::of_level(
        c.cells.len(),
        &p,
        c.tolerance.distance,
        &portcullis::vis::VisOptions::default(),
    );
    assert_eq!(offsets.len(), c.cells.len() + 1);
    assert!(c.cells.len() > 1);
    for cell in 0..c.cells.len() {
        let want: Vec<usize> = pvs.visible(cell).collect();
        assert_eq!(
            visible[offsets[cell]..offsets[cell + 1]],
            want[..],
            "cell {cell}"
        );
    }
    let none = dir.path().join("none.usda");
    common::succeeds(
        portcullis()
            .arg("convert")
            .arg(&input)
            .args(["--vis", "none", "-o"])
            .arg(&none),
    );
    assert!(!std::fs::read_to_string(&none)
        .unwrap()
        .contains("portcullis:visible"));
}
