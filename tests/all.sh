#!/usr/bin/env bash
# The README's test command: the Rust tests (`cargo test`), then the Python module's
# (`pip install .` into a venv, then pytest against the CLI's outputs), then the device
# check's smoke size (benches/device-check.sh). CI runs it through
# .ci/run. MESHRAD_VENV names the venv (default target/python-venv, made if missing).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck disable=SC1091
[ -f "$HOME/.cargo/env" ] && . "$HOME/.cargo/env"
cargo test
# The Python tests compare the module with the CLI: the release binary (built already by
# the README's first command, and then this compiles nothing).
cargo build --release
bin="$(cd "${CARGO_TARGET_DIR:-target}" && pwd)/release/meshrad"
venv="${MESHRAD_VENV:-target/python-venv}"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q ".[test]"
MESHRAD_BIN="$bin" "$venv/bin/python" -m pytest -q python/tests
# The device check at its smoke size on every Vulkan device here (lavapipe in CI): GPU
# against CPU images of the shipped scenes, an animate sequence, bench table2 --smoke.
bash benches/device-check.sh "$bin" --smoke --out target/device-check >/dev/null \
  || { cat target/device-check/report.md; exit 1; }
