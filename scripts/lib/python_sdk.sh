# The Python `mcp` SDK, pinned, in a venv shared by the scripts that drive the server through
# it (python_sdk_check.sh, agent_tasks.sh): sourced after `cd` to the repository. Sets `venv`.
MCP_VERSION=2.3.0
venv="${PYTHON_SDK_VENV:-${CARGO_TARGET_DIR:-target}/python-sdk-venv}"
if ! "$venv/bin/python" -c "import mcp, importlib.metadata as m; assert m.version('mcp') == '$MCP_VERSION'" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check "mcp==$MCP_VERSION"
fi
