//! `portcullis bench` on the smallest building: every column filled, the floor measured.

use assert_cmd::Command;

#[test]
fn a_small_bench_fills_every_column() {
    let out = Command::cargo_bin("portcullis")
        .unwrap()
        .args(["bench", "--rooms", "10", "--runs", "2", "--methods", "full"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("fastest of 2 run(s)"), "{text}");
    let row = text
        .lines()
        .find(|l| l.starts_with("| 10 |"))
        .unwrap_or_else(|| panic!("no row for 10 rooms: {text}"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    // | rooms | triangles | file | cells | portals | floor | ... | peak memory | memory / file |
    assert_eq!(cells.len(), 18, "{row}");
    let triangles: usize = cells[2].parse().unwrap();
    assert!(triangles > 1000, "{row}");
    assert!(
        cells[6].ends_with(" s") && cells[15].ends_with(" MB"),
        "{row}"
    );
    // The PVS table has the one method asked for, and the others as n/a.
    let vis = text
        .lines()
        .filter(|l| l.starts_with("| 10 |"))
        .nth(1)
        .unwrap();
    assert!(vis.contains("n/a") && vis.contains("pairs"), "{vis}");
    // A method that does not exist is a usage error.
    let bad = Command::cargo_bin("portcullis")
        .unwrap()
        .args(["bench", "--rooms", "10", "--methods", "fastest"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}
