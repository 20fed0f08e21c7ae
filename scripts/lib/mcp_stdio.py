"""The scripts' MCP client over stdio (Python's standard library only): starts a server command
the way an MCP client does — its own working directory and environment, JSON-RPC lines on
stdin/stdout, stderr kept as its log — and makes tool calls. Used by install_check.py and
bundle_check.py to start the installed binary, `uvx` and a bundle's manifest command.
"""

import json
import subprocess
import tempfile

PROTOCOL = "2025-11-25"


class StdioServer:
    """One server process and its one MCP session (initialized on start)."""

    def __init__(self, argv, cwd, env, timeout=120):
        self.argv = argv
        self.timeout = timeout
        self.log = tempfile.TemporaryFile()
        self.proc = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.log)
        self.next_id = 0
        init = self.request("initialize", {
            "protocolVersion": PROTOCOL,
            "capabilities": {},
            "clientInfo": {"name": "physics-mcp-install-check", "version": "1"},
        })
        self.server_info = init["serverInfo"]
        self.send({"jsonrpc": "2.0", "method": "notifications/initialized"})

    def send(self, message):
        self.proc.stdin.write((json.dumps(message) + "\n").encode())
        self.proc.stdin.flush()

    def request(self, method, params):
        self.next_id += 1
        self.send({"jsonrpc": "2.0", "id": self.next_id, "method": method, "params": params})
        while True:
            line = self.proc.stdout.readline()
            if not line:
                raise SystemExit(f"{' '.join(self.argv)}: the server closed stdout during {method}; its log:\n{self.stderr()}")
            message = json.loads(line)
            if message.get("id") == self.next_id:
                if "error" in message:
                    raise SystemExit(f"{method}: {message['error']}")
                return message["result"]

    def call(self, tool, arguments):
        """A tool's structuredContent; a refusal ends the script."""
        result = self.request("tools/call", {"name": tool, "arguments": arguments})
        if result.get("isError"):
            raise SystemExit(f"{tool}: refused: {result['content']}")
        return result["structuredContent"]

    def stderr(self):
        self.log.seek(0)
        return self.log.read().decode(errors="replace")

    def close(self):
        """Ends the session as a client does (closes stdin) and waits; returns the exit code."""
        self.proc.stdin.close()
        try:
            return self.proc.wait(self.timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            raise SystemExit(f"{' '.join(self.argv)}: did not exit within {self.timeout} s of its input closing")


def refused_start(argv, cwd, env, timeout=60):
    """Starts a server that is expected not to start; returns (exit code, stderr)."""
    proc = subprocess.run(argv, cwd=cwd, env=env, stdin=subprocess.PIPE, capture_output=True, timeout=timeout)
    return proc.returncode, proc.stderr.decode(errors="replace")
