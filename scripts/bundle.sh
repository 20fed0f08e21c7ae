#!/usr/bin/env bash
# Builds the MCP Bundle (dist/physics-mcp-<version>.mcpb): the wheel's binary as the stdio
# server, a manifest from packaging/mcpb/manifest.in.json (version and tools filled in by
# scripts/bundle.py), validated and packed by the pinned @anthropic-ai/mcpb
# (packaging/mcpb/package-lock.json, `npm ci`). Then unpacks the bundle and starts its server
# with the manifest's command, as a bundle host does. Needs the wheel (scripts/wheel.sh).
#
#   scripts/bundle.sh [WHEEL]    # default: dist/physics_mcp-<version>-*.whl
set -euo pipefail
cd "$(dirname "$0")/.."

version=$(python3 -c 'import tomllib; print(tomllib.load(open("Cargo.toml", "rb"))["workspace"]["package"]["version"])')
wheel="${1:-$(ls dist/physics_mcp-"$version"-*.whl 2>/dev/null | head -n1)}"
[[ -f "$wheel" ]] || { echo "bundle: no wheel for $version in dist/; run scripts/wheel.sh first" >&2; exit 1; }

# The pinned CLI (scripts/lib/mcpb_tools.sh).
source scripts/lib/mcpb_tools.sh

scratch=$(mktemp -d "${TMPDIR:-/tmp}/physics-mcp-bundle.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
stage="$scratch/physics-mcp"
mkdir -p "$stage/server"
python3 -m zipfile -e "$wheel" "$scratch/wheel"
install -m 0755 "$scratch/wheel/physics_mcp-$version.data/scripts/physics-mcp" "$stage/server/physics-mcp"
python3 scripts/bundle.py manifest "$stage/server/physics-mcp" packaging/mcpb/manifest.in.json "$stage/manifest.json"

"$mcpb" validate "$stage/manifest.json" >&2
out="dist/physics-mcp-$version.mcpb"
rm -f "$out"
"$mcpb" pack "$stage" "$out" >"$scratch/pack.log" 2>&1 || { cat "$scratch/pack.log" >&2; exit 1; }
grep -E '^(package size|unpacked size):' "$scratch/pack.log" | sed 's/^/bundle: /' >&2

"$mcpb" unpack "$out" "$scratch/unpacked" >&2
python3 scripts/bundle.py start "$scratch/unpacked"
echo "$out"
