"""The scripts' one MCP client over streamable HTTP (Python's standard library only): start the
real server on a free loopback port with throwaway directories, and talk raw JSON-RPC over one
kept-alive HTTP connection, so what a script measures is the server and its framing, not a
client library. Used by sse_priming_bench.py, compare_pybullet.py and cluster_bench.py.
"""

import http.client
import json
import os
import re
import subprocess
import threading

PROTOCOL = "2025-11-25"


def start(binary, env_extra, tmp, extra_args=()):
    """Start `binary serve` with data in tmp/data and workspace tmp/ws (and `extra_args`, e.g.
    --cluster); return (process, host:port). Its stderr is drained in the background (a long
    run logs more than a pipe holds, and a full pipe would stall the server)."""
    env = dict(os.environ, **env_extra)
    proc = subprocess.Popen(
        [binary, "serve", "--bind", "127.0.0.1:0", "--data", f"{tmp}/data", "--workspace", f"{tmp}/ws", *extra_args],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        env=env,
        text=True,
    )
    said = []
    for line in proc.stderr:
        m = re.match(r"physics-mcp listening on http://([^/]+)(/mcp)", line)
        if m:
            threading.Thread(target=lambda: [None for _ in proc.stderr], daemon=True).start()
            return proc, m.group(1)
        said.append(line.rstrip())
    raise SystemExit("the server did not start: " + " | ".join(said[-5:]))


class Session:
    """One MCP session on one kept-alive connection."""

    def __init__(self, hostport):
        self.conn = http.client.HTTPConnection(hostport)
        self.session = None
        self.next_id = 0

    def post(self, method, params, notify=False, raw_arguments=None):
        """One JSON-RPC message; with raw_arguments (JSON text), params["arguments"] is sent as
        that text, so a large request can be encoded once and sent many times."""
        body = {"jsonrpc": "2.0"}
        if not notify:
            self.next_id += 1
            body["id"] = self.next_id
        body["method"], body["params"] = method, params  # params last: raw_arguments ends it
        text = json.dumps(body)
        if raw_arguments is not None:
            text = text[:-2] + ', "arguments": ' + raw_arguments + "}}"
        headers = {"Content-Type": "application/json", "Accept": "application/json, text/event-stream"}
        if self.session:
            headers["Mcp-Session-Id"] = self.session
            headers["MCP-Protocol-Version"] = PROTOCOL
        self.conn.request("POST", "/mcp", text, headers)
        r = self.conn.getresponse()
        self.session = r.getheader("Mcp-Session-Id") or self.session
        text = r.read().decode()
        if notify:
            return None
        for line in text.splitlines():
            if line.startswith("data:") and line[5:].strip():
                msg = json.loads(line[5:])
                if msg.get("id") == body["id"]:
                    return msg
        if text.lstrip().startswith("{"):
            return json.loads(text)
        raise SystemExit(f"{method}: no response in {text!r}")

    def open(self, name="script"):
        """initialize + notifications/initialized; returns the initialize result."""
        msg = self.post("initialize", {"protocolVersion": PROTOCOL, "capabilities": {}, "clientInfo": {"name": name, "version": "0"}})
        self.post("notifications/initialized", {}, notify=True)
        return msg["result"]

    def tools(self):
        """The names tools/list offers."""
        return {t["name"] for t in self.post("tools/list", {})["result"]["tools"]}

    def call(self, tool, args):
        """A tool's structuredContent; a refusal ends the script with its message. args may
        be a dict, or JSON text already encoded (see post)."""
        if isinstance(args, str):
            msg = self.post("tools/call", {"name": tool}, raw_arguments=args)
        else:
            msg = self.post("tools/call", {"name": tool, "arguments": args})
        if "error" in msg:
            raise SystemExit(f"{tool}: JSON-RPC error {msg['error']}")
        result = msg["result"]
        if result.get("isError"):
            raise SystemExit(f"{tool} refused: {result}")
        return result.get("structuredContent")
