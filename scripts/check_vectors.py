#!/usr/bin/env python3
"""Checks an implementation of the portcullis runtime against the test vectors in
tests/vectors/ (docs/guide.md, "Test vectors"). Python 3 standard library only.

    python3 scripts/check_vectors.py [--case NAME]... [--bare] [--jobs N] IMPL...

IMPL... is the command that runs the implementation, e.g. `node js/portcullis-three/cli.js` or
`target/release/portcullis`. For every case of tests/vectors/manifest.json the level is
converted with `target/release/portcullis` (or $PORTCULLIS), and the implementation is run as

    IMPL... cull LEVEL.glb --cameras CAMERAS [CULL ARGS, e.g. --closed 2] --draw-lists --format jsonl

Every implementation gets the same arguments: it must print one JSON object per camera per
line (JSONL, a port's default; `--format jsonl` must be accepted), in the cameras' order,
tracing each camera with the previous one's cell as the location hint. `--bare` leaves
`--format jsonl` out, for a port that refuses it. Each answer is compared with the expected
line: the camera's `cell`, `location`, `nearest`, the `visible` entries (matched by cell and
transform, in any order) with their `depth`, `via`, `mirrored` and `draw` exactly, `rect` and
`transform` within 1e-9; `stats` is ignored, any other key not expected is a difference.

Prints, per case, how many cameras agree and the first difference; exits 1 on any difference,
2 when the vectors or the converter are missing. Cases of levels under ../shared are skipped
when ../shared is missing. `--levels DIR` keeps the converted levels in DIR and reuses them.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VECTORS = ROOT / "tests" / "vectors"
CONVERTER = os.environ.get("PORTCULLIS") or str(ROOT / "target" / "release" / "portcullis")


def close(a, b):
    """Rectangles and transforms are printed rounded to 1e-9: two right answers may differ by
    one step of it (and the float that prints it)."""
    return abs(a - b) <= 1e-9 * (1.0 + 1e-6) * max(abs(a), abs(b), 1.0)


def show(v):
    s = json.dumps(v, separators=(",", ":"))
    return s if len(s) <= 200 else s[:200] + "..."


def is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def differ(at, want, got, loose=False):
    """The first difference between `want` and `got`, or None."""
    bad = f"{at}: expected {show(want)}, got {show(got)}"
    if loose and is_number(want) and is_number(got):
        return None if close(float(want), float(got)) else bad
    if isinstance(want, dict) and isinstance(got, dict):
        for k, v in want.items():
            if k not in got:
                return f"{at}/{k}: missing (expected {show(v)})"
            if k == "visible":
                d = visible_differ(f"{at}/{k}", v, got[k])
            else:
                d = differ(f"{at}/{k}", v, got[k], loose or k in ("rect", "transform"))
            if d:
                return d
        for k in got:
            if k not in want:
                return f"{at}/{k}: not expected (got {show(got[k])})"
        return None
    if isinstance(want, list) and isinstance(got, list):
        if len(want) != len(got):
            return bad
        for i, (v, w) in enumerate(zip(want, got)):
            d = differ(f"{at}/{i}", v, w, loose)
            if d:
                return d
        return None
    if type(want) is not type(got) and not (is_number(want) and is_number(got)):
        return bad
    return None if want == got else bad


def same_entry(a, b):
    if not (isinstance(a, dict) and isinstance(b, dict)) or a.get("cell") != b.get("cell"):
        return False
    ta, tb = a.get("transform"), b.get("transform")
    if ta is None or tb is None:
        return ta is None and tb is None
    return differ("", ta, tb, True) is None


def visible_differ(at, want, got):
    if not (isinstance(want, list) and isinstance(got, list)):
        return differ(at, want, got)
    used = [False] * len(got)
    for v in want:
        key = "{cell %s%s}" % (json.dumps(v.get("cell")), ", transformed" if "transform" in v else "")
        j = next((j for j in range(len(got)) if not used[j] and same_entry(v, got[j])), None)
        if j is None:
            return f"{at}: {key} expected, not seen"
        used[j] = True
        d = differ(f"{at}/{key}", v, got[j])
        if d:
            return d
    for j, u in enumerate(used):
        if not u:
            cell = got[j].get("cell") if isinstance(got[j], dict) else got[j]
            return f"{at}: {{cell {json.dumps(cell)}}} seen, not expected"
    return None


def lines(path):
    return path.read_text().splitlines()


def check(case, glb, impl, bare):
    """(agreeing, cameras, first difference or None) for one case."""
    cams = VECTORS / case["cameras"]
    want = [json.loads(l) for l in lines(VECTORS / case["expected"])]
    labels = lines(VECTORS / case["labels"]) if case.get("labels") else []
    cmd = impl + ["cull", str(glb), "--cameras", str(cams)] + case["cull"] + ["--draw-lists"]
    if not bare:
        cmd += ["--format", "jsonl"]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if r.returncode != 0:
        err = r.stderr.decode(errors="replace").strip().splitlines()
        return 0, len(want), f"`{' '.join(cmd)}` exited {r.returncode}: {' / '.join(err[:5])}"
    got = []
    for n, l in enumerate(r.stdout.decode(errors="replace").splitlines()):
        if not l.strip():
            continue
        try:
            got.append(json.loads(l))
        except ValueError as e:
            return 0, len(want), f"output line {n + 1} is not JSON ({e}): {l[:120]}"
    for g in got:
        if isinstance(g, dict):
            g.pop("stats", None)
    agree, first = 0, None
    for i, w in enumerate(want):
        label = labels[i] if i < len(labels) else ""
        if i >= len(got):
            first = first or f"camera {i + 1} ({label}): no answer ({len(got)} answers for {len(want)} cameras)"
            continue
        d = differ("", w, got[i])
        if d is None:
            agree += 1
        elif first is None:
            first = f"camera {i + 1} ({label}): {d}"
    if len(got) > len(want) and first is None:
        first = f"{len(got)} answers for {len(want)} cameras"
    return agree, len(want), first


def convert(level, args, out):
    cmd = [CONVERTER, "convert", str(ROOT / level), "-o", str(out)] + args
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if not out.exists():
        err = r.stderr.decode(errors="replace")
        raise RuntimeError(f"`{' '.join(cmd)}` wrote nothing:\n{err}")


def main():
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--case", action="append", default=[], help="only this case (repeatable)")
    ap.add_argument("--bare", action="store_true", help="do not pass --format jsonl")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="cases run at once")
    ap.add_argument("--levels", metavar="DIR", help="keep the converted levels in DIR and use "
                    "those already there (for checking several implementations with one converter)")
    ap.add_argument("impl", nargs=argparse.REMAINDER, help="the implementation's command")
    a = ap.parse_args()
    if not a.impl:
        ap.error("give the implementation's command, e.g. node js/portcullis-three/cli.js")
    manifest = json.loads((VECTORS / "manifest.json").read_text())
    cases = [c for c in manifest["cases"] if not a.case or c["name"] in a.case]
    if not cases:
        sys.exit(f"no case named {', '.join(a.case)}")
    if not Path(CONVERTER).exists():
        print(f"{CONVERTER} is missing: run `cargo build --release`, or set $PORTCULLIS", file=sys.stderr)
        sys.exit(2)
    with tempfile.TemporaryDirectory() as tmp:
        store = Path(a.levels) if a.levels else Path(tmp)
        store.mkdir(parents=True, exist_ok=True)
        levels = {}
        for c in cases:
            key = (c["level"], tuple(c["convert"]))
            name = "_".join([Path(c["level"]).name, *c["convert"]]).replace("-", "")
            levels.setdefault(key, store / f"{name}.glb")

        def prepare(item):
            (level, args), glb = item
            if level.startswith("../shared/") and not (ROOT / level).exists():
                return None
            if not (a.levels and glb.exists()):
                convert(level, list(args), glb)
            return glb

        with ThreadPoolExecutor(max(1, a.jobs)) as pool:
            converted = dict(zip(levels, pool.map(prepare, levels.items())))

            def run(c):
                glb = converted[(c["level"], tuple(c["convert"]))]
                return None if glb is None else check(c, glb, a.impl, a.bare)

            results = list(pool.map(run, cases))
    failed = agreeing = total = skipped = 0
    for c, r in zip(cases, results):
        if r is None:
            skipped += 1
            print(f"skip  {c['name']}: {c['level']} is missing (no ../shared)")
            continue
        agree, n, first = r
        agreeing += agree
        total += n
        if first is None:
            print(f"ok    {c['name']}: {agree}/{n} cameras agree")
        else:
            failed += 1
            print(f"FAIL  {c['name']}: {agree}/{n} cameras agree; first difference: {first}")
    ran = len(cases) - skipped
    print(f"{ran - failed}/{ran} cases agree, {agreeing}/{total} cameras" + (f"; {skipped} skipped" if skipped else ""))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
