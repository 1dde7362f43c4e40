"""Runs a test script inside Blender in background mode (factory settings, Python errors make
Blender exit non-zero); exits 77 (ctest's SKIP_RETURN_CODE) with a message where Blender is not
installed. The Blender executable is $BLENDER or `blender` on PATH."""
import os
import shutil
import subprocess
import sys

blender = os.environ.get("BLENDER") or shutil.which("blender")
if not blender:
    print("SKIPPED: Blender is not installed (Debian: apt-get install blender; or set BLENDER)")
    sys.exit(77)
command = [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", sys.argv[1]]
print(" ".join(command), flush=True)
sys.exit(subprocess.run(command).returncode)
