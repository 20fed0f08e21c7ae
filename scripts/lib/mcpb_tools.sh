# The pinned MCP Bundle CLI, @anthropic-ai/mcpb (packaging/mcpb/package-lock.json, `npm ci`),
# installed once per lock file into target/mcpb-npm (MCPB_TOOLS_DIR picks another place);
# scripts/ci_prepare.sh fetches it ahead. Sourced after `cd` to the repository. Sets `mcpb`.
mcpb_tools="${MCPB_TOOLS_DIR:-${CARGO_TARGET_DIR:-target}/mcpb-npm}"
if ! cmp -s packaging/mcpb/package-lock.json "$mcpb_tools/package-lock.json" || [[ ! -x "$mcpb_tools/node_modules/.bin/mcpb" ]]; then
  rm -rf "$mcpb_tools"
  mkdir -p "$mcpb_tools"
  cp packaging/mcpb/package.json packaging/mcpb/package-lock.json "$mcpb_tools/"
  npm ci --prefix "$mcpb_tools" --no-audit --no-fund --loglevel=error >&2
fi
mcpb="$mcpb_tools/node_modules/.bin/mcpb"
