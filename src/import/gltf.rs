//! glTF 2.0 import (.gltf and .glb).
//!
//! The container is detected from the bytes, not the extension, because levels arrive through
//! stdin and renamed files. The JSON is kept untouched (with every buffer's bytes) in
//! [`GltfSource`] so the exporter can write the same file back with only our extension added;
//! everything the pipeline needs is read from it with the lenient structs in `schema` and our
//! own accessor reader, which checks every size the file claims against the bytes present before
//! allocating anything.
//!
//! The GLB container is parsed with the gltf crate, the JSON with our own small serde structs, item
//! by item from the text (the gltf crate's validation rejects KHR_mesh_quantization and keeps node
//! transforms as f32). A big top-level array is read in runs of about 1 MB on every thread, cut
//! between object items (a cut in the wrong place leaves its run unreadable, and the array is then
//! read whole). Meshes are built on every thread while the nodes are walked; a mesh that fails
//! counts only if the walk reached it, so the error is the one a mesh-by-mesh walk gives. A mesh's
//! first all-finite POSITION list becomes the mesh's without a copy, and JSON pointers are written
//! only for a diagnostic.

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::Imported;
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::scene::{json_text, Format, GltfSource, Material, Scene, SourceRef, TextInFile};

mod accessor;
mod buffers;
mod earlier;
mod graph;
mod mesh;
mod schema;

/// What every diagnostic of one import shares: the file it is about.
pub(crate) struct Ctx {
    path: PathBuf,
    /// Short name put in messages, so a message read without its location still says which file.
    name: String,
}

impl Ctx {
    fn new(path: &Path) -> Ctx {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| path.display().to_string());
        Ctx {
            path: path.to_path_buf(),
            name,
        }
    }

    fn location(&self) -> Location {
        Location::file(&self.path)
    }

    /// A diagnostic about the item at JSON `pointer`.
    fn diag(&self, code: Code, pointer: impl Into<String>, msg: impl AsRef<str>) -> Diagnostic {
        Diagnostic::new(
            code,
            format!("{}: {}", self.name, msg.as_ref()),
            self.location().with_pointer(pointer),
        )
    }

    /// A diagnostic about the file as a whole (container, JSON syntax).
    fn file_diag(&self, code: Code, msg: impl AsRef<str>) -> Diagnostic {
        Diagnostic::new(
            code,
            format!("{}: {}", self.name, msg.as_ref()),
            self.location(),
        )
    }
}

const VALIDATOR_HINT: &str =
    "the exporter wrote an invalid glTF; check it with the Khronos glTF validator and re-export";

/// Reads a glTF; owned `bytes` are dropped as soon as the JSON text and buffers are copied out.
/// `reread`: the bytes are the whole of the regular file at `path`, which can be read again
/// (see `scene::TextInFile`).
pub fn import(
    bytes: std::borrow::Cow<'_, [u8]>,
    path: &Path,
    base_dir: &Path,
    reread: bool,
) -> Result<Imported, Diagnostic> {
    let ctx = Ctx::new(path);
    if bytes.is_empty() {
        return Err(ctx
            .file_diag(Code::INPUT_EMPTY, "the file is empty (0 bytes)")
            .hint("the export may have failed; export the level again"));
    }
    let (format, json_bytes, bin) = if crate::format::glb::is_glb(&bytes) {
        let (json, bin) = split_glb(&ctx, &bytes)?;
        (Format::Glb, json, bin)
    } else {
        (Format::Gltf, &bytes[..], None)
    };
    // The text is checked and read at once, on two threads: on a big level each is a pass over
    // tens of megabytes. The check decides first, as it would alone; what was read is kept
    // only if the checked text is the text that was read (see `parse_json`).
    let (checked, early) = rayon::join(
        || parse_json(&ctx, json_bytes),
        || std::str::from_utf8(trimmed(json_bytes)).map(|s| read_doc(&ctx, s)),
    );
    let (mut text, verbatim) = checked?;
    // Ranges of the early read are of the same text when it is kept verbatim.
    let (doc, members_at) = match early {
        Ok(doc) if verbatim => doc?,
        _ => read_doc(&ctx, &text)?,
    };
    let bin_at = bin.map(|b| {
        let start = b.as_ptr() as usize - bytes.as_ptr() as usize;
        start..start + b.len()
    });
    // Where buffer 0 came from in the file, if it is the BIN chunk (see `release_bin`).
    let bin_file = bin_at
        .clone()
        .filter(|b| doc.buffers.first().is_some_and(|b0| b0.uri.is_none()) && !b.is_empty())
        .map(|b| crate::scene::BinInFile {
            path: path.to_path_buf(),
            offset: b.start as u64,
            len: b.len(),
            file_len: bytes.len() as u64,
            modified: None,
            released: false,
        });
    // Not held from here on: it is read back when asked for (see `TextInFile`).
    let text_in_file = (reread && verbatim).then(|| {
        let json = trimmed(json_bytes);
        let start = (json.as_ptr() as usize - bytes.as_ptr() as usize) as u64;
        TextInFile::release(&mut text, path, start..start + json.len() as u64)
    });
    let bin = bin_at.map(|at| bin_chunk(bytes, at));
    let buffers = buffers::resolve(&ctx, &doc, bin, base_dir, format)?;

    let mut scene = Scene::new(path.to_path_buf(), format);
    scene.stored_tags = doc.stored_tags.clone();
    let mut diagnostics = Diagnostics::default();
    scene.materials = doc
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| Material {
            name: m.name.clone(),
            extras: m.extras.clone(),
            double_sided: m.double_sided,
            source: SourceRef::pointer(format!("/materials/{i}")),
        })
        .collect();
    {
        let reader = accessor::Reader::new(&ctx, &doc, &buffers);
        let meshes = mesh::Builder::new(&ctx, &doc, reader);
        let mut tally = mesh::Tally::default();
        graph::build(
            &ctx,
            &doc,
            &mut scene,
            &meshes,
            &mut tally,
            &mut diagnostics,
        )?;
        meshes.finish(tally, &mut diagnostics);
    }
    let (mut buffers, mut bin_file) = (buffers, bin_file);
    let earlier = earlier::of(&doc, &buffers.iter().map(Vec::len).collect::<Vec<_>>());
    if let Some(e) = &earlier {
        e.drop_bytes(&mut buffers, &mut bin_file);
    }
    scene.gltf = Some(GltfSource {
        json: text,
        json_file: text_in_file,
        reloaded: Default::default(),
        buffers,
        base_dir: base_dir.to_path_buf(),
        bin_file,
        members_at: Some(members_at),
        earlier,
        parts: doc.parts.len(),
    });
    Ok(Imported { scene, diagnostics })
}

/// Splits a GLB into its JSON and BIN chunks, a malformed container as a diagnostic.
fn split_glb<'a>(ctx: &Ctx, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), Diagnostic> {
    use crate::format::glb::{self, GlbError};
    glb::split(bytes)
        .map(|g| (g.json, g.bin))
        .map_err(|e| match e {
            GlbError::Version(_) => ctx
                .file_diag(Code::GLTF_UNSUPPORTED_VERSION, e.to_string())
                .hint("convert the file to glTF 2.0 (e.g. open and re-export it in Blender)"),
            _ => ctx
                .file_diag(Code::GLB_INVALID, e.to_string())
                .hint("the .glb is damaged or was cut off while copying; export it again"),
        })
}

/// The JSON chunk without what real exporters emit although the spec forbids it: a UTF-8 BOM,
/// and NUL padding at the end of a GLB JSON chunk.
fn trimmed(bytes: &[u8]) -> &[u8] {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let end = bytes
        .iter()
        .rposition(|&b| b != 0 && !b.is_ascii_whitespace())
        .map_or(0, |p| p + 1);
    bytes.get(..end).unwrap_or(bytes)
}

/// The BIN chunk at `at` of the file's `bytes`, which are let go. A file read into memory
/// becomes the chunk where it lies: the chunk (the file's tail) is moved to the front and the
/// rest freed, instead of copied into new memory, which on a big level was a serial stretch of
/// page faults as long as the copy.
fn bin_chunk(bytes: std::borrow::Cow<'_, [u8]>, at: std::ops::Range<usize>) -> Vec<u8> {
    match bytes {
        std::borrow::Cow::Owned(mut v) => {
            v.truncate(at.end);
            v.drain(..at.start);
            v.shrink_to_fit();
            v
        }
        std::borrow::Cow::Borrowed(b) => b[at].to_vec(),
    }
}

/// What the importer reads of a checked text: the root object, the version, the required
/// extensions and the arrays the scene is built from, with the first problem in that order.
/// Also returns where the root members lie in `text`.
fn read_doc(ctx: &Ctx, text: &str) -> Result<(schema::Doc, MemberRanges), Diagnostic> {
    let Some(root) = schema::Root::new(text) else {
        return Err(ctx
            .diag(
                Code::GLTF_INVALID_JSON,
                "",
                "the top level of a glTF document must be a JSON object",
            )
            .hint(VALIDATOR_HINT));
    };
    check_version(ctx, &root)?;
    check_required_extensions(ctx, &root)?;
    schema::Doc::from_root(ctx, &root).map(|doc| (doc, root.ranges(text)))
}

type MemberRanges = Vec<(String, std::ops::Range<usize>)>;

/// The document's text, checked to parse as JSON. It is not parsed into a `Value`: that takes
/// ten times the text's room, and the importer reads only parts (see [`schema::Root`]).
/// `true` with it when the text is [`trimmed`] `bytes` as they are (not written back from a
/// `Value`).
fn parse_json(ctx: &Ctx, bytes: &[u8]) -> Result<(String, bool), Diagnostic> {
    let bytes = trimmed(bytes);
    // A text only a `Value` parse reads right is parsed, and written back as plain JSON.
    let as_value = || serde_json::from_slice::<Value>(bytes).map(|v| (v.to_string(), false));
    let checked = match json_text::check(bytes) {
        // A checked text is UTF-8 (JSON outside strings is ASCII, strings are checked).
        Ok(()) => {
            std::str::from_utf8(bytes).map_or_else(|_| as_value(), |s| Ok((s.to_owned(), true)))
        }
        Err(e) if e.to_string().contains(json_text::RAW_VALUE_KEY) => as_value(),
        Err(e) => Err(e),
    };
    checked.map_err(|e| {
        let line = e.line();
        Diagnostic::new(
            Code::GLTF_INVALID_JSON,
            // serde_json's message already ends with "at line L column C".
            format!("{}: invalid JSON: {e}", ctx.name),
            ctx.location().with_line(line.max(1)),
        )
        .hint("the file is not valid JSON; it may be truncated or not a glTF file at all")
    })
}

fn check_version(ctx: &Ctx, root: &schema::Root) -> Result<(), Diagnostic> {
    let Some(asset) = root.value("asset") else {
        return Err(ctx
            .diag(
                Code::GLTF_INVALID_JSON,
                "/asset",
                "the required `asset` object is missing",
            )
            .hint(VALIDATOR_HINT));
    };
    let asset: schema::Asset = serde_json::from_value(asset).map_err(|e| {
        ctx.diag(
            Code::GLTF_INVALID_JSON,
            "/asset",
            format!("`asset` does not follow the glTF schema: {e}"),
        )
        .hint(VALIDATOR_HINT)
    })?;
    let Some(version) = asset.version else {
        return Err(ctx
            .diag(
                Code::GLTF_INVALID_JSON,
                "/asset/version",
                "the required `asset.version` is missing",
            )
            .hint(VALIDATOR_HINT));
    };
    if version.split('.').next() != Some("2") {
        return Err(ctx
            .diag(
                Code::GLTF_UNSUPPORTED_VERSION,
                "/asset/version",
                format!("asset version is \"{version}\"; only glTF 2.x is read"),
            )
            .hint("convert the file to glTF 2.0 (e.g. open and re-export it in Blender)"));
    }
    Ok(())
}

/// Required extensions known not to change where triangles are: materials, textures, lights,
/// metadata, animation. Anything else that is *required* could change positions or hide
/// geometry we would then silently miss, so it is refused.
fn is_readable_required_extension(name: &str) -> bool {
    const KNOWN: &[&str] = &[
        "KHR_mesh_quantization",
        "KHR_texture_transform",
        "KHR_lights_punctual",
        "KHR_texture_basisu",
        "KHR_xmp_json_ld",
        "KHR_animation_pointer",
        "KHR_techniques_webgl",
        "EXT_texture_webp",
        "EXT_texture_avif",
        "EXT_lights_image_based",
        "MSFT_texture_dds",
        "MSFT_packing_normalRoughnessMetallic",
        "MSFT_packing_occlusionRoughnessMetallic",
    ];
    KNOWN.contains(&name) || name.starts_with("KHR_materials_")
}

fn check_required_extensions(ctx: &Ctx, root: &schema::Root) -> Result<(), Diagnostic> {
    let required: Vec<String> = schema::array(ctx, root, "extensionsRequired")?;
    for (i, name) in required.iter().enumerate() {
        if is_readable_required_extension(name) {
            continue;
        }
        let (why, hint) = match name.as_str() {
            "KHR_draco_mesh_compression" => (
                "its meshes are Draco-compressed",
                "re-export without Draco compression, or decompress with `gltf-transform cp in.glb out.glb`",
            ),
            "EXT_meshopt_compression" | "KHR_meshopt_compression" => (
                "its buffers are meshopt-compressed",
                "re-export without meshopt compression, or decompress with `gltf-transform cp in.glb out.glb`",
            ),
            "EXT_mesh_gpu_instancing" => (
                "it places mesh instances with GPU instancing, which would be missed",
                "re-export with instances realised as separate nodes (or make the extension optional)",
            ),
            _ => (
                "portcullis does not know whether it changes the geometry",
                "re-export without this extension, or ask for it to be supported",
            ),
        };
        return Err(ctx
            .diag(
                Code::GLTF_REQUIRED_EXTENSION_UNSUPPORTED,
                format!("/extensionsRequired/{i}"),
                format!("the file requires extension {name}, which cannot be read: {why}"),
            )
            .hint(hint));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::borrow::Cow;

    /// The text a file import reads back (after letting it go) is the text a borrowed import
    /// keeps, on every sample and on texts with a byte-order mark and padding around them.
    #[test]
    fn text_read_back_is_the_text_kept() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("samples");
        let tmp = tempfile::tempdir().unwrap();
        let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "glb" || x == "gltf"))
            .collect();
        let padded = tmp.path().join("padded.gltf");
        let text = r#"{"asset": {"version": "2.0"}, "nodes": [{"name": "a"}], "scenes": [{"nodes": [0]}]}"#;
        std::fs::write(&padded, format!("\u{feff}  {text} \n\n")).unwrap();
        files.push(padded);
        assert!(files.len() >= 3);
        let opts = crate::import::ImportOptions::default();
        for f in files {
            let bytes = std::fs::read(&f).unwrap();
            let format = match f.extension().is_some_and(|x| x == "glb") {
                true => crate::scene::Format::Glb,
                false => crate::scene::Format::Gltf,
            };
            let kept = crate::import::import_bytes(&bytes, &f, format, &dir, &opts).unwrap();
            let read = crate::import::import_path(&f, &opts).unwrap();
            let text = |i: &crate::import::Imported| {
                let src = i.scene.gltf.as_ref().unwrap();
                src.text().unwrap().to_string()
            };
            let released = |i: &crate::import::Imported| {
                let src = i.scene.gltf.as_ref().unwrap();
                src.json.is_empty() && src.json_file.is_some()
            };
            assert!(!released(&kept) && released(&read), "{}", f.display());
            assert!(!text(&kept).is_empty(), "{}", f.display());
            assert_eq!(text(&read), text(&kept), "{}", f.display());
        }
    }

    /// A file read into memory and a borrowed one give the same chunk, wherever it lies.
    #[test]
    fn bin_chunk_is_the_range_either_way() {
        let file: Vec<u8> = (0..=255u8).cycle().take(5000).collect();
        for at in [0..0, 0..5000, 20..5000, 1000..1004, 4999..5000, 7..7] {
            let want = file[at.clone()].to_vec();
            assert_eq!(super::bin_chunk(Cow::Borrowed(&file), at.clone()), want);
            assert_eq!(super::bin_chunk(Cow::Owned(file.clone()), at.clone()), want);
        }
    }

    /// The root members the importer keeps as ranges are the members a scan of the kept text
    /// finds, on a .glb and a .gltf, on a text kept as read and one written back from a
    /// `Value` (a repeated key, or the marker key, leaves the text to the `Value` parser).
    #[test]
    fn member_ranges_are_the_members_of_the_kept_text() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("samples");
        let mut texts: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "glb" || x == "gltf"))
            .map(|p| (p.display().to_string(), std::fs::read(&p).unwrap()))
            .collect();
        assert!(texts.len() >= 2);
        let doc = r#" {"asset": {"version": "2.0"}, "nodes": [{"name": "a"}], "scenes": [{"nodes": [0]}],
            "asset": {"version": "2.0", "generator": "again"}, "extras": {"x": 1} } "#;
        texts.push(("repeated key".into(), doc.as_bytes().to_vec()));
        let marker =
            r#"{"asset": {"version": "2.0"}, "extras": {"$serde_json::private::RawValue": "1"}}"#;
        texts.push(("marker key".into(), marker.as_bytes().to_vec()));
        for (name, bytes) in texts {
            let path = dir.join("level.gltf");
            let got = super::import(Cow::Owned(bytes), &path, &dir, false)
                .unwrap_or_else(|e| panic!("{name}: {e:?}"));
            let src = got.scene.gltf.unwrap();
            assert!(src.members_at.is_some(), "{name}");
            let scanned: Vec<(String, String)> =
                crate::scene::json_text::members(src.text().unwrap())
                    .unwrap()
                    .into_iter()
                    .map(|(k, v)| (k, v.get().to_string()))
                    .collect();
            let kept: Vec<(String, String)> = src
                .members()
                .unwrap()
                .unwrap()
                .into_iter()
                .map(|(k, v)| (k, v.to_string()))
                .collect();
            assert_eq!(kept, scanned, "{name}");
        }
    }
}
