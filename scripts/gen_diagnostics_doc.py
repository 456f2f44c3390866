#!/usr/bin/env python3
"""Writes docs/diagnostics.md from the code registry in src/diag/codes.rs.
Run from the repository root after adding a code; a unit test checks the doc lists every code."""
import re

src = open('src/diag/codes.rs').read()
body = src[src.index('codes! {'):]
rows = []
for line in body.splitlines():
    m = re.match(r'\s*// --- (.*) ---', line)
    if m:
        rows.append(('##', m.group(1)))
        continue
    m = re.match(r'\s*([A-Z0-9_]+) = (\w+), "(.*)";', line)
    if m:
        rows.append((m.group(1), m.group(2), m.group(3)))
out = ["# Diagnostic codes", "",
       "Every diagnostic portcullis prints has a stable code, a severity, a message, a location (file, "
       "node path, JSON pointer or line, 3D point where geometric) and a hint that says how to fix it. "
       "Codes never change meaning. Severities are the defaults.", "",
       "Exit codes: a diagnostic that stops a file from being read at all (the input section, and "
       "configuration errors) gives exit 2; other errors mean the level is wrong (exit 1); warnings "
       "fail the run only with `--deny warnings`.", ""]
for r in rows:
    if r[0] == '##':
        out += ["", f"## {r[1][0].upper() + r[1][1:]}", "", "| code | severity | meaning |", "|---|---|---|"]
    else:
        out.append(f"| `{r[0]}` | {r[1].lower()} | {r[2]} |")
open('docs/diagnostics.md', 'w').write("\n".join(out) + "\n")
