"""Shared by the comparison scripts: run inside the repository's reference
virtual environment (.venv-ref/, created from scripts/requirements.txt on
first use)."""
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
VENV = ROOT / ".venv-ref"


def ensure_venv(script):
    """Re-executes `script` with the venv's Python unless already inside it."""
    py = VENV / "bin" / "python"
    if pathlib.Path(sys.prefix).resolve() == VENV.resolve():
        return
    if not py.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        subprocess.run([str(py), "-m", "pip", "install", "-q", "-r", str(ROOT / "scripts" / "requirements.txt")], check=True)
    os.execv(str(py), [str(py), script, *sys.argv[1:]])

