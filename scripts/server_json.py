"""The MCP Registry entry, server.json at the repository's root (what `mcp-publisher publish`
reads): written from the crate's version and pyproject.toml's package name, and checked against
the registry's schema kept in packaging/registry/ (CI cannot reach the registry).

    python scripts/server_json.py --write   # regenerate server.json
    python scripts/server_json.py --check   # CI: committed == generated, schema-valid,
                                            # and the README carries the ownership line

Needs `jsonschema` (scripts/lib/packaging.sh's venv). The registry checks a PyPI package's
ownership by finding `mcp-name: <name>` in its README (the wheel's long description), so the
README's last line carries it; publishing needs NAME's namespace to be the publisher's
(`io.github.<account>/…` after `mcp-publisher login github`).
"""

import hashlib
import json
import pathlib
import sys
import tomllib

ROOT = pathlib.Path(__file__).resolve().parent.parent
NAME = "io.github.physics-mcp/physics-mcp"
SCHEMA = ROOT / "packaging/registry/server.schema.json"
SCHEMA_URL = "https://static.modelcontextprotocol.io/schemas/2025-12-11/server.schema.json"
# The registry's file as taken (packaging/registry/README.md says from where).
SCHEMA_SHA256 = "d4c163f299ece68b7432f4e44c4108f2fdb663d99dc088c8344142e5b0a4b520"


def generated():
    with open(ROOT / "Cargo.toml", "rb") as f:
        version = tomllib.load(f)["workspace"]["package"]["version"]
    with open(ROOT / "pyproject.toml", "rb") as f:
        package = tomllib.load(f)["project"]["name"]
    pypi = {"registryType": "pypi", "registryBaseUrl": "https://pypi.org", "identifier": package, "version": version, "runtimeHint": "uvx"}
    directory = "Defaults to ./{} when the working directory is writable (not / or home), else $XDG_DATA_HOME/physics-mcp/{}."
    return {
        "$schema": SCHEMA_URL,
        "name": NAME,
        "title": "Physics (rapier3d)",
        "description": "Deterministic, replayable rigid-body physics simulations on rapier3d, with PyBullet's tools",
        "version": version,
        "packages": [
            {
                **pypi,
                "transport": {"type": "stdio"},
                "packageArguments": [
                    {"type": "positional", "value": "stdio"},
                    {"type": "named", "name": "--workspace", "format": "filepath",
                     "description": "Folder that model, save and output paths are confined to. " + directory.format("physics-mcp-workspace", "workspace")},
                    {"type": "named", "name": "--data", "format": "filepath",
                     "description": "The server's folder of simulation logs (one process at a time). " + directory.format("physics-mcp-data", "data")},
                ],
            },
            {
                **pypi,
                "transport": {"type": "streamable-http", "url": "http://127.0.0.1:8000/mcp"},
                "packageArguments": [{"type": "positional", "value": "serve"}],
            },
        ],
    }


def text():
    return json.dumps(generated(), indent=2) + "\n"


def check():
    import jsonschema

    path = ROOT / "server.json"
    if path.read_text() != text():
        raise SystemExit("server_json: server.json is not what scripts/server_json.py --write makes (the crate's version changed?)")
    if hashlib.sha256(SCHEMA.read_bytes()).hexdigest() != SCHEMA_SHA256:
        raise SystemExit(f"server_json: {SCHEMA} is not the registry's file it was taken as (packaging/registry/README.md)")
    schema = json.loads(SCHEMA.read_text())
    validator = jsonschema.Draft7Validator(schema, format_checker=jsonschema.Draft7Validator.FORMAT_CHECKER)
    errors = sorted(validator.iter_errors(json.loads(path.read_text())), key=lambda e: list(e.path))
    if errors:
        raise SystemExit("server_json: server.json breaks the registry schema:\n" + "\n".join(f"  {list(e.path)}: {e.message}" for e in errors))
    if f"mcp-name: {NAME}" not in (ROOT / "README.md").read_text():
        raise SystemExit(f"server_json: README.md (the wheel's description) lacks 'mcp-name: {NAME}', which the registry needs")
    print(f"server_json: server.json ({NAME} {generated()['version']}) is valid against {SCHEMA_URL}", file=sys.stderr)


if __name__ == "__main__":
    if sys.argv[1:] == ["--write"]:
        (ROOT / "server.json").write_text(text())
    elif sys.argv[1:] == ["--check"]:
        check()
    else:
        raise SystemExit(__doc__)
