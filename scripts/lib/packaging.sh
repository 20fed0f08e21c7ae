# The packaging tools, pinned, in a venv shared by the scripts that build and check the wheel
# (wheel.sh, install_check.sh) and server.json (server_json.py): maturin builds the wheel, uv
# runs it the way `uvx physics-mcp` does, jsonschema validates server.json. Sourced after `cd`
# to the repository. Sets `packaging_venv`.
MATURIN_VERSION=1.16.0
UV_VERSION=0.13.9
JSONSCHEMA_VERSION=4.26.0
packaging_venv="${PACKAGING_VENV:-${CARGO_TARGET_DIR:-target}/packaging-venv}"
if ! "$packaging_venv/bin/python" - "$MATURIN_VERSION" "$UV_VERSION" "$JSONSCHEMA_VERSION" 2>/dev/null <<'PY'
import sys, importlib.metadata as m
assert [m.version(p) for p in ("maturin", "uv", "jsonschema")] == sys.argv[1:]
PY
then
  python3 -m venv "$packaging_venv"
  "$packaging_venv/bin/pip" install --quiet --disable-pip-version-check \
    "maturin==$MATURIN_VERSION" "uv==$UV_VERSION" "jsonschema==$JSONSCHEMA_VERSION"
fi
