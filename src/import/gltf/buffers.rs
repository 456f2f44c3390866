//! Loads every buffer's bytes: the GLB BIN chunk, `data:` URIs and external files.
//!
//! All buffers are loaded, not only those our meshes use, because the exporter writes the
//! document back and needs them all. Images are never loaded: a missing texture says nothing
//! about the level's shape and must not stop an import.

use std::path::Path;

use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig};
use base64::engine::DecodePaddingMode;
use base64::Engine as _;

use super::schema::Doc;
use super::Ctx;
use crate::diag::{Code, Diagnostic};
use crate::scene::Format;

/// Exporters differ on base64 padding; accept it either way.
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &base64::alphabet::STANDARD,
    GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

pub fn resolve(
    ctx: &Ctx,
    doc: &Doc,
    mut bin: Option<Vec<u8>>,
    base_dir: &Path,
    format: Format,
) -> Result<Vec<Vec<u8>>, Diagnostic> {
    let mut out = Vec::with_capacity(doc.buffers.len());
    for (i, buffer) in doc.buffers.iter().enumerate() {
        let pointer = format!("/buffers/{i}");
        let Some(byte_length) = buffer.byte_length else {
            return Err(ctx
                .diag(
                    Code::GLTF_INVALID_JSON,
                    format!("{pointer}/byteLength"),
                    format!("buffer {i} has no byteLength"),
                )
                .hint(super::VALIDATOR_HINT));
        };
        let (data, what) = match buffer.uri.as_deref() {
            None if i == 0 && format == Format::Glb => match bin.take() {
                Some(b) => (b, "the GLB BIN chunk".to_string()),
                None => {
                    return Err(ctx
                        .diag(
                            Code::GLTF_BUFFER_MISSING,
                            pointer,
                            "buffer 0 has no uri and the GLB has no BIN chunk to supply it",
                        )
                        .hint("the .glb is damaged or was cut off; export it again"));
                }
            },
            None => {
                return Err(ctx
                    .diag(
                        Code::GLTF_BUFFER_MISSING,
                        pointer,
                        format!("buffer {i} has no uri (only buffer 0 of a .glb may omit it)"),
                    )
                    .hint(super::VALIDATOR_HINT));
            }
            Some(uri) if uri.starts_with("data:") => {
                (decode_data_uri(ctx, uri, &pointer)?, "its data: URI".into())
            }
            Some(uri) => {
                let file = resolve_file_uri(ctx, uri, base_dir, &pointer)?;
                let data = std::fs::read(&file).map_err(|e| {
                    ctx.diag(
                        Code::GLTF_BUFFER_MISSING,
                        pointer.clone(),
                        format!(
                            "cannot read buffer {i} from \"{uri}\" ({}): {e}",
                            file.display()
                        ),
                    )
                    .hint("keep the .bin file next to the .gltf, or export a self-contained .glb")
                })?;
                (data, format!("\"{uri}\""))
            }
        };
        if (data.len() as u64) < byte_length {
            return Err(ctx
                .diag(
                    Code::GLTF_BUFFER_TOO_SHORT,
                    pointer,
                    format!(
                        "buffer {i} declares byteLength {byte_length} but {what} holds only {} bytes",
                        data.len()
                    ),
                )
                .hint("the buffer file is truncated or stale; export the level again"));
        }
        out.push(data);
    }
    Ok(out)
}

fn decode_data_uri(ctx: &Ctx, uri: &str, pointer: &str) -> Result<Vec<u8>, Diagnostic> {
    let bad = |why: &str| {
        let shown: String = uri.chars().take(48).collect();
        ctx.diag(
            Code::GLTF_BUFFER_MISSING,
            pointer,
            format!("buffer data: URI \"{shown}…\" cannot be read: {why}"),
        )
        .hint("re-export the file; data: URIs must be base64 (`data:application/octet-stream;base64,...`)")
    };
    let Some((header, payload)) = uri.split_once(',') else {
        return Err(bad("it has no ',' separating the header from the data"));
    };
    if !header.ends_with(";base64") {
        return Err(bad("only base64-encoded data: URIs are supported"));
    }
    let payload: String = payload
        .chars()
        .filter(|c| !c.is_ascii_whitespace())
        .collect();
    BASE64
        .decode(payload.as_bytes())
        .map_err(|e| bad(&format!("invalid base64 ({e})")))
}

fn resolve_file_uri(
    ctx: &Ctx,
    uri: &str,
    base_dir: &Path,
    pointer: &str,
) -> Result<std::path::PathBuf, Diagnostic> {
    let bad = |why: String| {
        ctx.diag(
            Code::GLTF_BUFFER_MISSING,
            pointer,
            format!("buffer uri \"{uri}\" cannot be used: {why}"),
        )
        .hint("use a relative file path or a data: URI, or export a self-contained .glb")
    };
    if let Some((scheme, _)) = uri.split_once(':') {
        let is_scheme = scheme.len() > 1
            && scheme
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c));
        if is_scheme {
            return Err(bad(format!(
                "`{scheme}:` URIs are not read, only relative files"
            )));
        }
    }
    let path_part = uri.split(['?', '#']).next().unwrap_or(uri);
    let decoded = percent_decode(path_part)
        .ok_or_else(|| bad("it has an invalid percent-escape or is not UTF-8".into()))?;
    Ok(base_dir.join(decoded))
}

/// Decodes `%XX` escapes (URIs in glTF are percent-encoded: `my%20level.bin`).
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&b) = bytes.get(i) {
        if b == b'%' {
            let hex = bytes.get(i + 1..i + 3)?;
            if !hex.iter().all(u8::is_ascii_hexdigit) {
                return None;
            }
            let hex = std::str::from_utf8(hex).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::percent_decode;

    #[test]
    fn percent_decoding() {
        assert_eq!(
            percent_decode("my%20level.bin").as_deref(),
            Some("my level.bin")
        );
        assert_eq!(percent_decode("a%2").as_deref(), None);
        assert_eq!(percent_decode("a%+f").as_deref(), None);
        assert_eq!(percent_decode("%C3%A9.bin").as_deref(), Some("é.bin"));
    }
}
