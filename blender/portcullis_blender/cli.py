"""The portcullis command line, as the add-on runs it: no Blender here, so it is tested alone.

The add-on is a client of the documented CLI and its JSON report (`check --format json`,
`inspect --format json`), never of the tool's internals, so it keeps working as the tool evolves.
"""
import json
import os
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path


class ToolError(Exception):
    """The tool could not do its job (exit 2, or it is not installed): its own message."""


@dataclass
class Diagnostic:
    severity: str
    code: str
    message: str
    hint: str
    node: str

    @property
    def object_name(self):
        """The Blender object the diagnostic names: the last part of its node path (the glTF
        exporter writes each object as a node named after it)."""
        return self.node.rsplit("/", 1)[-1] if self.node else ""


@dataclass
class Result:
    """What one export's run found: the converted file, the debug glTF, the diagnostics, the
    rooms and portals `inspect` recognised, and the exit code of `check` (0 clean, 1 errors)."""
    output: str
    debug: str
    exit_code: int
    diagnostics: list = field(default_factory=list)
    rooms: list = field(default_factory=list)
    portals: list = field(default_factory=list)


def find_binary(configured=""):
    """The `portcullis` binary: the configured path, else $PORTCULLIS_BIN, else on PATH."""
    for candidate in (configured, os.environ.get("PORTCULLIS_BIN", "")):
        if candidate and Path(candidate).is_file():
            return candidate
    found = shutil.which("portcullis")
    if not found:
        raise ToolError(
            "the `portcullis` binary was not found: set its path in the add-on's preferences, "
            "or put it on PATH (cargo install --path . in the portcullis repository)")
    return found


def _run(binary, args):
    try:
        return subprocess.run([binary, *args], capture_output=True, text=True)
    except OSError as e:
        raise ToolError(f"cannot run {binary}: {e}") from e


def _json(proc, what):
    if proc.returncode == 2:
        raise ToolError(proc.stderr.strip() or f"portcullis {what} failed (exit 2)")
    try:
        return json.loads(proc.stdout)
    except json.JSONDecodeError as e:
        raise ToolError(f"portcullis {what} wrote no JSON report: {e}") from e


def diagnostics_of(report):
    out = []
    for f in report.get("files", []):
        for d in f.get("diagnostics", []):
            out.append(Diagnostic(
                severity=d.get("severity", ""),
                code=d.get("code", ""),
                message=d.get("message", ""),
                hint=d.get("hint") or "",
                node=(d.get("location") or {}).get("node") or "",
            ))
    order = {"error": 0, "warning": 1, "info": 2}
    out.sort(key=lambda d: order.get(d.severity, 3))
    return out


def convert_and_check(binary, exported, preset="", sealed=False):
    """Converts the exported glTF (`NAME.portals.glb` and the debug `NAME.debug.glb` beside it),
    checks it and inspects it. Exit 1 of `check` is the level's errors; exit 2 of any step is
    the tool's failure, raised with its message."""
    src = Path(exported)
    stem = src.with_suffix("")
    output = f"{stem}.portals.glb"
    debug = f"{stem}.debug.glb"
    common = ["--tags", preset] if preset else []
    conv = _run(binary, ["convert", str(src), "-o", output, "--debug", debug, *common,
                         *(["--sealed"] if sealed else [])])
    if conv.returncode == 2:
        raise ToolError(conv.stderr.strip() or "portcullis convert failed (exit 2)")
    check = _run(binary, ["check", str(src), "--format", "json", *common,
                          *(["--sealed"] if sealed else [])])
    report = _json(check, "check")
    inspect = _json(_run(binary, ["inspect", str(src), "--format", "json", *common]), "inspect")
    tags = (inspect.get("files") or [{}])[0].get("tags") or {}
    return Result(
        output=output if Path(output).exists() else "",
        debug=debug if Path(debug).exists() else "",
        exit_code=check.returncode,
        diagnostics=diagnostics_of(report),
        rooms=[r.get("name", "") for r in tags.get("rooms", [])],
        portals=[(p.get("node", ""), p.get("source") or "", p.get("target") or "")
                 for p in tags.get("portals", [])],
    )


def view_page(binary, exported, page, preset=""):
    """Writes `portcullis view`'s offline page of the level."""
    proc = _run(binary, ["view", str(exported), "-o", str(page),
                         *(["--tags", preset] if preset else [])])
    if proc.returncode == 2:
        raise ToolError(proc.stderr.strip() or "portcullis view failed (exit 2)")
    return page
