"""Zip the Blender add-on (integrations/blender/incandescent_blender) for Blender's installer.

    python scripts/package_blender_addon.py [OUT.zip]     # default: dist/incandescent_blender.zip

Then in Blender (>= 3.4): Edit › Preferences › Add-ons › Install… the zip, enable "Render:
incandescent", and set the incandescent executable's path in its preferences (docs/blender.md).
"""

from __future__ import annotations

import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "integrations" / "blender" / "incandescent_blender"


def package(out: Path) -> Path:
    """Write the add-on's zip (its Python files under ``incandescent_blender/``) to ``out``."""
    files = sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in files:
            archive.write(path, Path(PACKAGE.name) / path.relative_to(PACKAGE))
    tmp.replace(out)
    return out


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "dist" / "incandescent_blender.zip"
    print(f"wrote {package(target)}")
