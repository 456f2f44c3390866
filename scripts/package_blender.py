#!/usr/bin/env python3
"""Zips the Blender add-on (blender/portcullis_blender) into dist/portcullis_blender-VERSION.zip,
installable from Blender's Preferences > Add-ons (Install from Disk) in Blender 4.2 and later.
Run from anywhere: python3 scripts/package_blender.py [OUT.zip]"""
import re
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "blender" / "portcullis_blender"
version = re.search(r'^version = "([^"]+)"', (SRC / "blender_manifest.toml").read_text(), re.M)[1]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "dist" / f"portcullis_blender-{version}.zip"
out.parent.mkdir(exist_ok=True)
with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
    for f in sorted(SRC.rglob("*")):
        if f.is_file() and "__pycache__" not in f.parts and f.suffix != ".png":
            z.write(f, Path("portcullis_blender") / f.relative_to(SRC))
print(out)
