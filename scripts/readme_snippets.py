"""Runs every ```python block of the READMEs as a script, as a reader who saves one does.

Usage: python scripts/readme_snippets.py [README ...] (default: README.md, python/README.md).
Each block runs in its own process from the repository's root (the FMU snippet's default
path, target/fmu/BldcDrive.fmu, is relative to it). Exits non-zero on the first block that
fails, and when a README has no python block at all (a renamed fence must not turn this
check into a silent pass).
"""

import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
BLOCK = re.compile(r"^```python\n(.*?)^```$", re.S | re.M)


def blocks(readme):
    """(first line number, code) of each python block of `readme`."""
    text = readme.read_text(encoding="utf-8")
    return [(text.count("\n", 0, m.start()) + 2, m.group(1)) for m in BLOCK.finditer(text)]


def main(argv):
    readmes = [ROOT / p for p in (argv or ["README.md", "python/README.md"])]
    with tempfile.TemporaryDirectory() as tmp:
        for readme in readmes:
            found = blocks(readme)
            if not found:
                sys.exit(f"error: {readme}: no ```python block found")
            for line, code in found:
                name = f"{os.path.relpath(readme, ROOT)}:{line}"
                script = pathlib.Path(tmp) / f"snippet_{len(os.listdir(tmp))}.py"
                script.write_text(code, encoding="utf-8")
                t = time.monotonic()
                r = subprocess.run([sys.executable, str(script)], cwd=ROOT,
                                   capture_output=True, text=True)
                if r.returncode != 0:
                    sys.stderr.write(r.stdout + r.stderr)
                    sys.exit(f"error: the python block at {name} failed as a script "
                             f"(exit {r.returncode})")
                print(f"{name}: ran as a script in {time.monotonic() - t:.1f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
