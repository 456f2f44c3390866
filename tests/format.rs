//! The extension's records (`portcullis::format`) against its JSON Schema
//! (schemas/PORTCULLIS_portals.schema.json): a record with every field set is valid, names
//! exactly the properties the schema lists for its object, and reads back as itself; an
//! unknown member is refused by both. The records and the schema are two statements of one
//! format, and this holds them together.

use portcullis::format::{
    Annotated, Bounds, CellRecord, GeneratedRecord, PortalRecord, RoomRecord, SplitPrimitive,
    SplitRecord,
};
use portcullis::schema::{validate, Schema};
use serde_json::{json, Value};

/// An annotation with every optional member present.
fn full() -> Annotated {
    let cell = |room: &str| CellRecord {
        room: room.to_string(),
        priority: 2,
        planes: vec![
            [1.0, 0.0, 0.0, -1.0],
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, -1.0],
            [0.0, -1.0, 0.0, 0.0],
        ],
        bounds: Bounds {
            min: [0.0, 0.0, 0.0],
            max: [1.0, 1.0, 1.0],
        },
        nodes: vec![0],
        draws: vec![[0, 0, 3]],
    };
    let mut identity = [0.0; 16];
    for i in 0..4 {
        identity[i * 5] = 1.0;
    }
    Annotated {
        version: 1,
        generator: "portcullis test".into(),
        input_hash: "xxh3v2:0123456789abcdef".into(),
        tolerance: 1e-5,
        tags: Some("doom".into()),
        generated: Some(GeneratedRecord {
            voxel: 0.25,
            split_ratio: 0.6,
            detail_area: Some(0.0625),
            grid: [10, 20, 30],
            axes: [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
            rooms: 2,
        }),
        rooms: vec![RoomRecord {
            name: "hall".into(),
            cells: vec![0, 1],
        }],
        cells: vec![cell("hall"), cell("hall")],
        portals: vec![
            PortalRecord {
                polygon: vec![[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 1.0, 1.0]],
                cells: vec![0, 1],
                kind: Some("teleporter".into()),
                one_way: true,
                closed: true,
                door: true,
                internal: true,
                transform: Some(identity),
                partner: Some(1),
                node: Some(0),
            },
            PortalRecord {
                polygon: vec![[1.0, 1.0, 1.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
                cells: vec![1, 0],
                kind: None,
                one_way: false,
                closed: false,
                door: false,
                internal: false,
                transform: None,
                partner: Some(0),
                node: None,
            },
        ],
        buried_occupants: vec![0],
        split: Some(SplitRecord {
            indices: 0,
            primitives: vec![SplitPrimitive {
                node: 0,
                primitive: 0,
                first: 0,
                count: 3,
            }],
        }),
        visibility: Some(json!({"method": "full", "encoding": "lists", "lists": [[0, 1], [0, 1]]})),
    }
}

/// The property names a schema object lists.
fn schema_properties(object: &Value) -> Vec<String> {
    let mut v: Vec<String> = object["properties"]
        .as_object()
        .expect("an object schema")
        .keys()
        .cloned()
        .collect();
    v.sort();
    v
}

fn keys(v: &Value) -> Vec<String> {
    let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
    k.sort();
    k
}

#[test]
fn a_full_record_is_valid_and_names_every_schema_property() {
    let schema: Value = serde_json::from_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("schemas/PORTCULLIS_portals.schema.json"),
        )
        .unwrap(),
    )
    .unwrap();
    let a = full();
    let v = serde_json::to_value(&a).unwrap();
    let problems = validate(Schema::Portals, &v);
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(keys(&v), schema_properties(&schema));
    assert_eq!(
        keys(&v["cells"][0]),
        schema_properties(&schema["$defs"]["cell"])
    );
    let portal_schema = schema_properties(&schema["$defs"]["portal"]);
    assert_eq!(keys(&v["portals"][0]), portal_schema);
    assert_eq!(
        keys(&v["rooms"][0]),
        schema_properties(&schema["properties"]["rooms"]["items"])
    );
    // What is left out when it says nothing: the defaults are not written.
    assert_eq!(keys(&v["portals"][1]), ["cells", "partner", "polygon"]);
    // And it reads back as itself.
    let back: Annotated = serde_json::from_value(v).unwrap();
    assert_eq!(back, a);
}

#[test]
fn an_unknown_member_is_refused_by_the_records_and_the_schema() {
    for pointer in ["", "/cells/0", "/portals/0", "/rooms/0"] {
        let mut v = serde_json::to_value(full()).unwrap();
        v.pointer_mut(pointer)
            .unwrap()
            .as_object_mut()
            .unwrap()
            .insert("surprise".into(), json!(1));
        assert!(
            serde_json::from_value::<Annotated>(v.clone()).is_err(),
            "the records took `surprise` at {pointer:?}"
        );
        assert!(
            !validate(Schema::Portals, &v).is_empty(),
            "the schema took `surprise` at {pointer:?}"
        );
    }
}
