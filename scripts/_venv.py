"""Shared by the comparison scripts: run inside the repository's reference
virtual environment (.venv-ref/, created from scripts/requirements.txt on
first use)."""
import os
import pathlib
import subprocess
import sys
import timeit

ROOT = pathlib.Path(__file__).resolve().parents[1]
VENV = ROOT / ".venv-ref"


def ensure_venv(script):
    """Re-executes `script` with the venv's Python unless already inside it."""
    py = VENV / "bin" / "python"
    if pathlib.Path(sys.prefix).resolve() == VENV.resolve():
        return
    # NPRL_ANY_PYTHON=1: run in the current Python, which has the packages
    # the script needs (a lighter venv than the full reference one)
    if os.environ.get("NPRL_ANY_PYTHON") == "1":
        return
    if not py.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        subprocess.run([str(py), "-m", "pip", "install", "-q", "-r", str(ROOT / "scripts" / "requirements.txt")], check=True)
    os.execv(str(py), [str(py), script, *sys.argv[1:]])



def median_time(f, repeat, divide):
    """The median seconds per call of `f` over `repeat` (odd) timings, each
    of 1/`divide` of the call count timeit's autorange picks."""
    timer = timeit.Timer(f)
    number, _ = timer.autorange()
    number = max(1, number // divide)
    runs = sorted(t / number for t in timer.repeat(repeat=repeat, number=number))
    return runs[repeat // 2]
