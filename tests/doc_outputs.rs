//! Issue 45, item 10: every command output quoted in README.md and docs/guide.md is the real
//! output. A fenced `text` block that shows one starts with `$ portcullis ARGS`; this test runs
//! it from the repository root without colour, and the rest of the block must be what it
//! prints (standard output, then standard error), line for line. Any other `text` block must
//! be the guide's synopsis of the commands (lines starting `portcullis `), so an output quoted
//! without its command cannot slip in untested.

mod common;

/// (file, line of the fence, the block's lines) of every fenced `text` block.
fn text_blocks(file: &str) -> Vec<(usize, Vec<String>)> {
    let text = std::fs::read_to_string(common::root().join(file)).unwrap();
    let mut out = Vec::new();
    let mut open: Option<(usize, Vec<String>)> = None;
    let mut other_fence = false;
    for (i, line) in text.lines().enumerate() {
        let fence = line.trim_start().starts_with("```");
        match (&mut open, fence) {
            (Some(_), true) => out.push(open.take().unwrap()),
            (Some((_, lines)), false) => lines.push(line.to_string()),
            (None, true) if other_fence => other_fence = false,
            (None, true) if line.trim() == "```text" => open = Some((i + 1, Vec::new())),
            (None, true) => other_fence = true,
            (None, false) => {}
        }
    }
    out
}

#[test]
fn every_quoted_command_output_is_the_real_output() {
    let mut ran = 0;
    for file in ["README.md", "docs/guide.md"] {
        for (at, lines) in text_blocks(file) {
            let first = lines.first().map(String::as_str).unwrap_or("");
            let Some(command) = first.strip_prefix("$ portcullis ") else {
                assert!(
                    first.starts_with("portcullis "),
                    "{file}:{at}: a text block that is neither a command's output (`$ portcullis ...` first) nor the synopsis"
                );
                continue;
            };
            let o = std::process::Command::new(env!("CARGO_BIN_EXE_portcullis"))
                .args(command.split_whitespace())
                .current_dir(common::root())
                .env("NO_COLOR", "1")
                .output()
                .unwrap();
            let printed = format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            );
            let got: Vec<&str> = printed.lines().map(str::trim_end).collect();
            let want: Vec<&str> = lines[1..].iter().map(|l| l.trim_end()).collect();
            assert_eq!(
                want, got,
                "{file}:{at}: `portcullis {command}` prints otherwise"
            );
            ran += 1;
        }
    }
    assert!(ran >= 3, "only {ran} quoted outputs");
}
