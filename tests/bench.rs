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
    // | rooms | triangles | file | cells | portals | floor | ... | convert process | process /
    // floor | peak memory | memory / file |
    assert_eq!(cells.len(), 20, "{row}");
    let triangles: usize = cells[2].parse().unwrap();
    assert!(triangles > 1000, "{row}");
    assert!(
        cells[6].ends_with(" s") && cells[15].ends_with(" s") && cells[17].ends_with(" MB"),
        "{row}"
    );
    let process: f64 = cells[15].trim_end_matches(" s").parse().unwrap();
    assert!(process > 0.0, "{row}");
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("| 10 |")).collect();
    // CPU seconds: six stages and their total, the total their sum (to the rounding shown).
    let cpu: Vec<f64> = rows[1]
        .split('|')
        .map(str::trim)
        .filter(|c| c.ends_with(" s"))
        .map(|c| c.trim_end_matches(" s").parse().unwrap())
        .collect();
    assert_eq!(cpu.len(), 7, "{}", rows[1]);
    assert!(
        (cpu[..6].iter().sum::<f64>() - cpu[6]).abs() < 0.004,
        "{}",
        rows[1]
    );
    // Triangles and draw calls per view: the draw lists submit no more than the nodes whole,
    // which submit no more than frustum culling alone.
    let draw = rows
        .iter()
        .find(|r| r.contains(" tris, "))
        .expect("a draw row");
    let tris: Vec<f64> = (draw.split('|').map(str::trim))
        .filter_map(|c| c.split_once(" tris, "))
        .map(|(t, _)| t.parse().unwrap())
        .collect();
    assert_eq!(tris.len(), 3, "{draw}");
    assert!(
        0.0 < tris[0] && tris[0] <= tris[1] && tris[1] < tris[2],
        "{draw}"
    );
    // The PVS table has the one method asked for, and the others as n/a.
    let vis = rows
        .iter()
        .find(|r| r.contains("pairs"))
        .expect("a PVS row");
    assert!(vis.contains("n/a"), "{vis}");
    // A method that does not exist is a usage error.
    let bad = Command::cargo_bin("portcullis")
        .unwrap()
        .args(["bench", "--rooms", "10", "--methods", "fastest"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}
