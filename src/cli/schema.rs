//! `portcullis schema`: print the shipped JSON Schemas and tag presets, so users can validate
//! their own files and start a config from a preset.

use clap::Args;

use portcullis::schema::FILES;
use portcullis::tags::presets::PRESETS;

#[derive(Debug, Args)]
pub struct SchemaArgs {
    /// A schema file name (config.schema.json, tags.schema.json, PORTCULLIS_portals.schema.json
    /// for the extension `convert` writes; the name without `.schema.json` also works) or
    /// `preset:NAME` (e.g. preset:godot). Without it, lists what is available.
    pub name: Option<String>,
}

pub fn run(a: &SchemaArgs) -> i32 {
    let Some(name) = &a.name else {
        println!("schemas:");
        for (n, _) in FILES {
            println!("  {n}");
        }
        println!("tag presets:");
        for (n, _) in PRESETS {
            println!("  preset:{n}");
        }
        return 0;
    };
    let text = match name.strip_prefix("preset:") {
        Some(p) => portcullis::tags::presets::as_config(p),
        None => FILES
            .iter()
            .find(|(n, _)| {
                n.eq_ignore_ascii_case(name)
                    || n.trim_end_matches(".schema.json")
                        .eq_ignore_ascii_case(name)
            })
            .map(|(_, t)| t.to_string()),
    };
    match text {
        Some(t) => {
            print!("{t}");
            0
        }
        None => {
            eprintln!(
                "error: no schema or preset called `{name}`; run `portcullis schema` for the list"
            );
            2
        }
    }
}
