#!/usr/bin/env bash
# The Python package as a user installs it: `pip install ./python` (a release wheel, optimized
# SPIR-V) into a fresh virtual environment, then the package's tests against that install, run
# from outside the checkout's package folder so `import vkengine` is the wheel. The tests compare
# with the `volume` and `cornell` CLIs of the wheel's own (release) profile, built here.
# Takes long (a release build of the engine); not part of tools/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --disable-pip-version-check ./python pytest "dask[distributed]"
cargo build --locked --release --bin volume --bin cornell
"$work/venv/bin/python" -c 'import vkengine, sys; print("testing", vkengine.__file__, vkengine._native.BUILD_PROFILE, file=sys.stderr)'
cd "$work"
"$work/venv/bin/python" -m pytest -q -p no:cacheprovider --rootdir "$root/python" "$root/python/tests" "$@"
