"""The MCP Bundle's two Python steps (scripts/bundle.sh runs them around the pinned `mcpb`):

    python3 scripts/bundle.py manifest BIN TEMPLATE OUT   # fill in the version and the tools
    python3 scripts/bundle.py start UNPACKED_DIR          # start the unpacked bundle's server

`manifest` writes packaging/mcpb/manifest.in.json with the crate's version and the tools the
binary lists (name and first sentence), so the bundle's manifest never lags the server.
`start` does what a bundle host does: reads the unpacked manifest, fills in `${__dirname}`,
`${HOME}` and the user_config defaults, starts its command from `/` over stdio, makes a
simulation and checks that its log landed in the configured data directory.
"""

import json
import os
import pathlib
import re
import sys
import tempfile
import tomllib

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "lib"))
import mcp_stdio  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent


def crate_version():
    with open(ROOT / "Cargo.toml", "rb") as f:
        return tomllib.load(f)["workspace"]["package"]["version"]


def first_sentence(text):
    sentence = re.split(r"(?<=[.;:])\s|\n", text.strip(), maxsplit=1)[0]
    return sentence.rstrip(".;: ")


def listed_tools(binary):
    with tempfile.TemporaryDirectory() as tmp:
        env = {"HOME": tmp, "PATH": "/usr/bin:/bin"}
        server = mcp_stdio.StdioServer([binary, "stdio", "--data", f"{tmp}/data", "--workspace", f"{tmp}/ws"], tmp, env)
        tools, cursor = [], None
        while True:
            page = server.request("tools/list", {"cursor": cursor} if cursor else {})
            tools += [{"name": t["name"], "description": first_sentence(t.get("description", ""))} for t in page["tools"]]
            cursor = page.get("nextCursor")
            if not cursor:
                break
        server.close()
    return tools


def manifest(binary, template, out):
    data = json.loads(pathlib.Path(template).read_text())
    data["version"] = crate_version()
    data["tools"] = listed_tools(binary)
    pathlib.Path(out).write_text(json.dumps(data, indent=2) + "\n")
    print(f"bundle: manifest {data['name']} {data['version']} with {len(data['tools'])} tools", file=sys.stderr)


def substitute(value, variables):
    return re.sub(r"\$\{([^}]+)\}", lambda m: variables[m.group(1)], value)


def start(unpacked):
    unpacked = pathlib.Path(unpacked).resolve()
    data = json.loads((unpacked / "manifest.json").read_text())
    with tempfile.TemporaryDirectory(prefix="physics-mcp-bundle-") as home:
        variables = {"__dirname": str(unpacked), "HOME": home, "pathSeparator": "/"}
        for key, option in data.get("user_config", {}).items():
            variables[f"user_config.{key}"] = substitute(option["default"], variables)
        config = data["server"]["mcp_config"]
        argv = [substitute(config["command"], variables)] + [substitute(a, variables) for a in config.get("args", [])]
        env = {"HOME": home, "PATH": "/usr/bin:/bin", **{k: substitute(v, variables) for k, v in config.get("env", {}).items()}}
        server = mcp_stdio.StdioServer(argv, "/", env)
        sim = server.call("create_simulation", {})["simulation_id"]
        server.call("add_sphere", {"sim_id": sim, "radius": 0.1, "position": [0, 0, 1]})
        code = server.close()
        log = pathlib.Path(variables["user_config.data"]) / f"{sim}.sqlite"
        if code != 0 or not log.is_file():
            raise SystemExit(f"bundle: FAILED: {' '.join(argv)} exited {code}; {log} is missing; its log:\n{server.stderr()}")
        print(f"bundle: the unpacked bundle's server ({server.server_info['name']} {server.server_info['version']}) "
              f"ran from /: {' '.join(argv)}; its log is {log}", file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "manifest":
        manifest(*sys.argv[2:])
    elif len(sys.argv) == 3 and sys.argv[1] == "start":
        start(sys.argv[2])
    else:
        raise SystemExit(__doc__)
