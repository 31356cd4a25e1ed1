#!/usr/bin/env bash
# The Python package from this checkout: formatting and lints of the
# bindings, the wheel built with maturin, installed with pip into a fresh
# virtual environment, and the Python tests (pytest, scikit-learn's
# estimator checks and gymnasium's environment checker among them).
# Needs python3 (with venv) and the package registries (PyPI, crates.io).
# Prints the wheel's build time and size.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
target=${CARGO_TARGET_DIR:-$root/target}
case $target in /*) ;; *) target=$root/$target ;; esac
target=$target/python
venv=$target/venv
rm -rf "$venv" "$target/wheels"
python3 -m venv "$venv"
"$venv/bin/pip" install -q --upgrade pip
"$venv/bin/pip" install -q -r "$here/requirements-ci.txt"
export PYO3_PYTHON="$venv/bin/python"
export CARGO_TARGET_DIR="$target"
cd "$here"
cargo fmt --check
cargo clippy --all-targets --locked -- -D warnings
start=$(date +%s)
"$venv/bin/maturin" build --release --locked -o "$target/wheels"
wheel=$(ls "$target"/wheels/nprl-*.whl)
echo "wheel: $(basename "$wheel"), $(du -k "$wheel" | cut -f1) KiB, built in $(( $(date +%s) - start )) s"
"$venv/bin/pip" install -q "$wheel"
# from outside the source tree, so that `import nprl` is the installed wheel
cd "$target"
"$venv/bin/python" -c 'import nprl, sys; print("nprl", nprl.__version__, "from", nprl.__file__)' 
"$venv/bin/python" -m pytest -q -p no:cacheprovider "$here/tests"
