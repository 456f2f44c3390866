//! What the plugin's tests share: the converter, running it, a scratch folder, a file's JSON.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The converter, or None (with the reason printed) outside CI.
pub fn converter() -> Option<PathBuf> {
    let p = std::env::var_os("PORTCULLIS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let target =
                std::env::var_os("CARGO_TARGET_DIR").map_or(root().join("target"), PathBuf::from);
            target.join("debug/portcullis")
        });
    if p.is_file() {
        return Some(p);
    }
    let why = format!(
        "no portcullis binary at {} (run `cargo build` first)",
        p.display()
    );
    assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
    eprintln!("skipped: {why}");
    None
}

pub fn run(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert!(
        out.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

pub fn tempfile_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "portcullis-bevy-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn gltf_json(glb: &Path) -> Value {
    let bytes = std::fs::read(glb).unwrap();
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

/// `source` converted with `args` into `dir`, or None (with the reason printed) where the
/// converter or the level is missing outside CI.
pub fn converted(source: &Path, args: &[&str], dir: &Path) -> Option<PathBuf> {
    let portcullis = converter()?;
    if !source.exists() {
        let ci = std::env::var("CI").as_deref() == Ok("true");
        assert!(!ci, "{} is missing", source.display());
        eprintln!(
            "skipped: {} is missing (../shared beside the clone)",
            source.display()
        );
        return None;
    }
    let glb = dir.join("level.glb");
    // With $PORTCULLIS_LEVEL_CACHE (scripts/test.sh sets it, fresh each run), the JavaScript
    // tests' conversions are reused: the same file converted with the same arguments.
    let name = |s: &str| {
        s.chars()
            .filter(|c| c.is_ascii_alphanumeric() || "_.".contains(*c))
            .collect::<String>()
    };
    let kept = std::env::var_os("PORTCULLIS_LEVEL_CACHE").map(|d| {
        let file = source.file_name().unwrap().to_string_lossy();
        let key: Vec<String> = std::iter::once(name(&file))
            .chain(args.iter().map(|a| name(a)))
            .collect();
        PathBuf::from(d).join(key.join("_") + ".glb")
    });
    if let Some(k) = kept.as_ref().filter(|k| k.is_file()) {
        std::fs::copy(k, &glb).unwrap();
        return Some(glb);
    }
    run(Command::new(&portcullis)
        .arg("convert")
        .arg(source)
        .arg("-o")
        .arg(&glb)
        .args(args)
        .args(["--color", "never"]));
    if let Some(k) = kept {
        std::fs::create_dir_all(k.parent().unwrap()).unwrap();
        let part = k.with_extension("part");
        std::fs::copy(&glb, &part).unwrap();
        std::fs::rename(&part, &k).unwrap();
    }
    Some(glb)
}

/// `portcullis cull --draw-lists --format jsonl` on `glb` for the camera `lines` (written to
/// `dir`): its answers, one per camera.
pub fn cull(glb: &Path, lines: &[String], dir: &Path) -> Vec<Value> {
    let file = dir.join("cameras.jsonl");
    std::fs::write(&file, lines.join("\n") + "\n").unwrap();
    let out = run(Command::new(converter().expect("the converter"))
        .arg("cull")
        .arg(glb)
        .arg("--cameras")
        .arg(&file)
        .args(["--draw-lists", "--format", "jsonl"]));
    let answers: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(answers.len(), lines.len());
    answers
}
