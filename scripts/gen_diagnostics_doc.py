#!/usr/bin/env python3
"""Writes docs/diagnostics.md from the code registry in src/diag/codes.rs, with an example of
each code: what `portcullis` prints for its level in samples/broken/ (or for the command line
in samples/broken/README.md when no level file can trigger it). Run from the repository root
after `cargo build --features usd`, `cargo build --release` (a build without USD, for
USD_UNSUPPORTED_BUILD) and `python3 scripts/make_broken.py`; a unit test checks the doc lists every
code with an example or a reason.
"""
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXE = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target" / "debug" / "portcullis")
# USD_UNSUPPORTED_BUILD needs a build without the `usd` feature (the test suite's debug build
# has it): by default the release build of `cargo build --release`.
EXE_NO_USD = sys.argv[2] if len(sys.argv) > 2 else str(ROOT / "target" / "release" / "portcullis")
BROKEN = ROOT / "samples" / "broken"

# Codes a command line triggers, not a level file (see samples/broken/README.md).
COMMANDS = {
    "CONFIG_NOT_FOUND": ["check", "--config", "missing.toml", "two_rooms.gltf"],
    "TAGS_PRESET_UNKNOWN": ["check", "--tags", "unreal", "two_rooms.gltf"],
    "OUTPUT_FAILED": ["convert", "two_rooms.gltf", "-o", "/proc/out.glb"],
    "OUTPUT_WOULD_OVERWRITE_INPUT": ["convert", "two_rooms.gltf", "-o", "two_rooms.gltf"],
    "OUTPUT_FORMAT_UNKNOWN": ["convert", "two_rooms.gltf", "-o", "out.fbx"],
    # A level written by `convert --split-by-cell` (pillar_split.glb, made before the command).
    "CONVERT_SPLIT_INPUT": ["convert", "pillar_split.glb", "-o", "again.glb"],
}
# Portal files written into the command's folder as bad.prt (the .prt codes).
PRT_TEXT = {
    "PRT_UNKNOWN_FORMAT": "PRT3\n1\n0\n",
    "PRT_SYNTAX": "PRT1\n2\n1\n4 0 1 (0 0 0) (0 1 0) (0 1 1)\n",
    "PRT_BAD_INDEX": "PRT1\n2\n1\n4 0 7 (0 0 0) (0 1 0) (0 1 1) (0 0 1)\n",
    "PRT_TRAILING_DATA": "PRT1\n2\n1\n4 0 1 (0 0 0) (0 1 0) (0 1 1) (0 0 1)\nextra\n",
    "PRT_PORTAL_DEGENERATE": "PRT1\n2\n1\n3 0 1 (0 0 0) (1 1 1) (2 2 2)\n",
}
COMMANDS.update({c: ["vis", "bad.prt"] for c in PRT_TEXT})
COMMANDS["PRT_EXPORT_DROPPED"] = ["convert", "teleporter.gltf", "-o", "teleporter.prt"]
COMMANDS["VIS_TRANSFORM_DEPTH"] = ["vis", "teleporter.gltf"]
COMMANDS["VIS_FLOW_BUDGET"] = ["vis", "--flow-budget", "1", "stair_hall.gltf"]
COMMANDS["SIGHTLINES_CONFIRMED"] = ["check", "--sightlines", "200", "two_rooms.gltf"]
# Two rooms whose shared wall is slats with 5 mm slits (make_broken.slatted_rooms), written
# before the command runs.
COMMANDS["SIGHTLINES_THROUGH_CRACKS"] = ["check", "--sightlines", "200", "slats.gltf"]
# A converted two_rooms.gltf whose stored PVS lost the pairs out of cell 0 (written before the
# command runs, as tests/sightlines.rs does).
COMMANDS["PVS_MISSES_SIGHTLINE"] = ["check", "--sightlines", "200", "edited.gltf"]
# `cull` on a level written by `convert` (two_rooms.glb) with a cameras file whose second line
# gives the eye two numbers, and on the unconverted sample.
CAMERA = '{"eye":[2,1.6,2],"look":[1,0,0]}'
COMMANDS["CULL_NOT_CONVERTED"] = ["cull", "two_rooms.gltf", "--cameras", "cams.jsonl"]
COMMANDS["CULL_CAMERA_INVALID"] = ["cull", "two_rooms.glb", "--cameras", "bad.jsonl"]
COMMANDS["CULL_PORTAL_UNKNOWN"] = ["cull", "two_rooms.glb", "--cameras", "cams.jsonl", "--closed", "9"]
# The .bsp codes: a tiny BSP29 (two leafs side by side, one portal between them) and its
# PRT1, written into the command's folder with the broken variants (tiny_bsp below).
COMMANDS["BSP_TRUNCATED"] = ["vis", "cut.bsp"]
COMMANDS["BSP_UNSUPPORTED"] = ["vis", "q3.bsp"]
COMMANDS["BSP_LUMP_OUT_OF_RANGE"] = ["vis", "lumps.bsp"]
COMMANDS["BSP_BAD_INDEX"] = ["vis", "index.bsp"]
COMMANDS["BSP_PRT_MISMATCH"] = ["vis", "map.bsp", "--prt", "other.prt"]
COMMANDS["BSP_PRT_MISSING"] = ["vis", "leaky.bsp"]
COMMANDS["BSP_ALREADY_VISED"] = ["vis", "vised.bsp"]
# Where the hint shows by example, the fix says it in full.
FIX = {
    "CULL_CAMERA_INVALID": "One JSON object per line with `eye` and `look` (a direction), and optionally "
                           "`up`, `fov_y` (degrees, between 0 and 180), `aspect` and `near` (positive); "
                           "`up` must not lie along `look`.",
}
NO_EXAMPLE = {
    "USD_CORE_MISSING": "No level file triggers it: it is about the machine. Run a `usd` build with "
                        "`--python-venv` pointing at a venv without usd-core to see it; the fix is "
                        "`python3 -m venv .venv && .venv/bin/pip install usd-core==26.11`.",
    "USD_PYTHON_FAILED": "No known file triggers it: it reports a Python exception inside usd-core that "
                         "portcullis did not foresee, with its message. Please report it with the file.",
    "TAG_AMBIGUOUS_TARGET": "Reserved. Room names are unique (a second room with a name is "
                            "`TAG_DUPLICATE_ROOM` and joins the first), so no target can match two rooms today.",
    "TRANSFORM_NON_FINITE": "No file triggers it: JSON has no NaN or infinity and portcullis builds "
                            "transforms from finite quads. It guards portal sets built in code by library users.",
}


def sample_for(code):
    for p in sorted(BROKEN.glob(code + ".*")):
        return p
    d = BROKEN / code / "level.gltf"
    return d if d.exists() else None


def tiny_bsp(visleafs=2):
    """A BSP29 of two air leafs (x 0..64 and 64..128) and the solid leaf 0, one world model,
    no faces: what vis needs and nothing else."""
    import struct
    leaf = lambda contents, lo, hi: struct.pack("<ii6hHH4B", contents, -1, *lo, *hi, 0, 0, 0, 0, 0, 0)
    lumps = [b""] * 15
    lumps[0] = b'{\n"classname" "worldspawn"\n}\n\0'
    lumps[10] = leaf(-2, (0, 0, 0), (0, 0, 0)) + leaf(-1, (0, 0, 0), (64, 64, 64)) + leaf(-1, (64, 0, 0), (128, 64, 64))
    lumps[14] = struct.pack("<9f4i3i", 0, 0, 0, 128, 64, 64, 0, 0, 0, 0, 0, 0, 0, visleafs, 0, 0)
    out = bytearray(4 + 15 * 8)
    table = []
    for data in lumps:
        out += bytes(-len(out) % 4)
        table.append((len(out), len(data)))
        out += data
    struct.pack_into("<i", out, 0, 29)
    for i, (o, n) in enumerate(table):
        struct.pack_into("<ii", out, 4 + 8 * i, o, n)
    return bytes(out)


TINY_PRT = "PRT1\n2\n1\n4 0 1 (64 0 0) (64 64 0) (64 64 64) (64 0 64)\n"


def bsp_files(d):
    """The .bsp examples' files in folder `d`."""
    import struct
    good = tiny_bsp()
    (d / "map.bsp").write_bytes(good)
    (d / "map.prt").write_text(TINY_PRT)
    (d / "other.prt").write_text("PRT1\n3\n1\n4 0 1 (64 0 0) (64 64 0) (64 64 64) (64 0 64)\n")
    (d / "cut.bsp").write_bytes(good[:100])
    (d / "q3.bsp").write_bytes(b"IBSP" + struct.pack("<i", 46) + bytes(200))
    lumps = bytearray(good)
    struct.pack_into("<i", lumps, 4 + 8 * 10, len(good) + 64)
    (d / "lumps.bsp").write_bytes(bytes(lumps))
    (d / "index.bsp").write_bytes(tiny_bsp(visleafs=9))
    (d / "leaky.bsp").write_bytes(good)
    (d / "vised.bsp").write_bytes(good)
    (d / "vised.prt").write_text(TINY_PRT)
    subprocess.run([EXE, "vis", "vised.bsp"], cwd=d, capture_output=True, check=True)


def block(text, code):
    """The lines of the first diagnostic with `code` in human output."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if re.match(rf"(error|warning|info)\[{code}\]", line):
            out = [line]
            for nxt in lines[i + 1:]:
                if nxt.startswith("  "):
                    out.append(nxt)
                else:
                    break
            return out
    return None


def example(code):
    if code in COMMANDS:
        with tempfile.TemporaryDirectory() as d:
            (Path(d) / "two_rooms.gltf").write_bytes((ROOT / "samples" / "two_rooms.gltf").read_bytes())
            for name in ("teleporter.gltf", "stair_hall.gltf", "pillar_room.gltf"):
                (Path(d) / name).write_bytes((ROOT / "samples" / name).read_bytes())
            if code in PRT_TEXT:
                (Path(d) / "bad.prt").write_text(PRT_TEXT[code])
            if code.startswith("BSP_"):
                bsp_files(Path(d))
            if code.startswith("CULL_"):
                subprocess.run([EXE, "convert", "two_rooms.gltf", "-o", "two_rooms.glb"], cwd=d,
                               capture_output=True, check=True)
                (Path(d) / "cams.jsonl").write_text(CAMERA + "\n")
                (Path(d) / "bad.jsonl").write_text(CAMERA + '\n{"eye":[2,1.6],"look":[1,0,0]}\n')
            if code == "CONVERT_SPLIT_INPUT":
                subprocess.run([EXE, "convert", "pillar_room.gltf", "--split-by-cell", "-o", "pillar_split.glb"],
                               cwd=d, capture_output=True, check=True)
            if code == "SIGHTLINES_THROUGH_CRACKS":
                sys.path.insert(0, str(ROOT / "scripts"))
                import make_broken
                make_broken.ms.write_gltf(make_broken.slatted_rooms(), Path(d) / "slats.gltf")
            if code == "PVS_MISSES_SIGHTLINE":
                subprocess.run([EXE, "convert", "two_rooms.gltf", "-o", "edited.gltf"], cwd=d,
                               capture_output=True, check=True)
                doc = json.loads((Path(d) / "edited.gltf").read_text())
                ext = doc["extensions"]["PORTCULLIS_portals"]
                n = len(ext["cells"])
                lists = [[0]] + [list(range(n)) for _ in range(1, n)]
                ext["visibility"] = {"method": "full", "encoding": "lists", "lists": lists}
                (Path(d) / "edited.gltf").write_text(json.dumps(doc))
            r = subprocess.run([EXE, *COMMANDS[code], "--color", "never"], cwd=d, capture_output=True, text=True)
            cmd = "portcullis " + " ".join(COMMANDS[code])
            return cmd, block(r.stdout + r.stderr, code)
    sample = sample_for(code)
    if sample is None:
        return None, None
    rel = sample.relative_to(BROKEN)
    exe = EXE_NO_USD if code == "USD_UNSUPPORTED_BUILD" else EXE
    r = subprocess.run([exe, "check", str(rel), "--color", "never"], cwd=BROKEN, capture_output=True, text=True)
    return f"portcullis check samples/broken/{rel}", block(r.stdout + r.stderr, code)


def main():
    src = (ROOT / "src" / "diag" / "codes.rs").read_text()
    body = src[src.index("codes! {"):]
    sections = []
    for line in body.splitlines():
        m = re.match(r"\s*// --- (.*) ---", line)
        if m:
            sections.append((m.group(1), []))
            continue
        m = re.match(r'\s*([A-Z0-9_]+) = (\w+), "(.*)";', line)
        if m:
            sections[-1][1].append((m.group(1), m.group(2).lower(), m.group(3)))
    out = ["# Diagnostic codes", "",
           "Every diagnostic portcullis prints has a stable code, a severity, a message, a location (file, "
           "node path, JSON pointer or line, 3D point where geometric) and a hint that says how to fix it. "
           "Codes never change meaning. Severities are the defaults; `--severity CODE=LEVEL` and `--ignore CODE` "
           "(or `[check]` in portcullis.toml) change them.", "",
           "Exit codes: a diagnostic that stops a file from being read at all (the input section, and "
           "configuration errors) gives exit 2; other errors mean the level is wrong (exit 1); warnings "
           "fail the run only with `--deny warnings`.", "",
           "Each code below has an example: what `portcullis` printed for the level named after it in "
           "`samples/broken/` (generated by `scripts/make_broken.py`; `tests/check.rs` asserts that each "
           "triggers exactly its code). Regenerate this page with `python3 scripts/gen_diagnostics_doc.py`.", ""]
    for title, codes in sections:
        out += ["", f"## {title[0].upper() + title[1:]}", "", "| code | severity | meaning |", "|---|---|---|"]
        out += [f"| [`{c}`](#{c.lower()}) | {sev} | {meaning} |" for c, sev, meaning in codes]
    out += ["", "## Examples and fixes", ""]
    missing = []
    for title, codes in sections:
        for c, sev, meaning in codes:
            out += [f"### `{c}`", "", f"*{sev}* — {meaning}.", ""]
            if c in NO_EXAMPLE:
                out += [NO_EXAMPLE[c], ""]
                continue
            cmd, lines = example(c)
            if not lines:
                missing.append(c)
                out += ["(no example: regenerate samples/broken)", ""]
                continue
            hint = next((ln.split("= hint: ", 1)[1] for ln in lines if "= hint: " in ln), None)
            out += [f"`{cmd}`:", "", "```text", *lines, "```", ""]
            if c in FIX:
                out += [f"**Fix:** {FIX[c]}", ""]
            elif hint:
                out += [f"**Fix:** {hint[0].upper() + hint[1:]}.", ""]
    (ROOT / "docs" / "diagnostics.md").write_text("\n".join(out).rstrip() + "\n")
    if missing:
        sys.exit("no example for: " + ", ".join(missing))


if __name__ == "__main__":
    main()
