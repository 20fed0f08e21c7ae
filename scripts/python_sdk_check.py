#!/usr/bin/env python3
"""The Python `mcp` SDK (2.x, from PyPI) against a running physics-mcp (`.ci/run`).

    python scripts/python_sdk_check.py http://127.0.0.1:PORT/mcp WORKSPACE_DIR

Two sessions, as the SDK makes them:
  * `mode="auto"` (the SDK's default): it discovers the server and speaks 2026-07-28 —
    lists tools, calls a few, a 16,384-ray ray_test_batch with output_path (the reply stays
    small, the rays go to a file in the workspace), and a `subscriptions/listen` stream that
    must announce a step of the watched simulation;
  * `mode="legacy"` (2025-11-25, initialize + session): resources/subscribe, a step, the
    `notifications/resources/updated` it causes, then the session ends (DELETE).

Fails (exit 1) on any error and on any warning — Python's `warnings` or a log record at
WARNING or above from any logger (the SDK reports protocol trouble that way, e.g. an SSE
event over its 1 MiB limit or a failed session termination). The SDK's own deprecation
notice for resources/subscribe is expected: that call is the legacy path on purpose.
"""

import asyncio
import json
import logging
import os
import sys
import warnings

from mcp import Client
from mcp.shared.exceptions import MCPDeprecationWarning

RAYS = 16_384
TIMEOUT_S = 30


class Complaints(logging.Handler):
    """Every log record at WARNING or above, from any logger."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.records = []

    def emit(self, record):
        self.records.append(self.format(record))


def check(cond, what):
    if not cond:
        raise AssertionError(what)


def structured(result, tool):
    check(not result.is_error, f"{tool} was refused: {result.content}")
    return result.structured_content


async def modern_session(url, workspace):
    async with Client(url) as client:
        print(f"auto mode negotiated protocol {client.protocol_version}")
        tools = await client.list_tools()
        names = {t.name for t in tools.tools}
        for needed in ("create_simulation", "step_simulation", "ray_test_batch"):
            check(needed in names, f"tools/list lacks {needed}")
        print(f"tools/list: {len(names)} tools")

        sim = structured(await client.call_tool("create_simulation", {}), "create_simulation")["simulation_id"]
        structured(
            await client.call_tool("add_box", {"sim_id": sim, "dimensions": [10, 10, 1], "mass": 0, "position": [0, 0, -0.5]}),
            "add_box",
        )
        structured(await client.call_tool("step_simulation", {"sim_id": sim, "steps": 10}), "step_simulation")
        info = structured(await client.call_tool("get_simulation_info", {"sim_id": sim}), "get_simulation_info")
        check(info["current_time"] > 0, f"time did not advance: {info}")

        rays_from = [[(i % 128) * 0.05 - 3.2, (i // 128) * 0.05 - 3.2, 2.0] for i in range(RAYS)]
        rays_to = [[x, y, -2.0] for x, y, _ in rays_from]
        out = "rays.json"
        r = await client.call_tool(
            "ray_test_batch", {"sim_id": sim, "rays_from": rays_from, "rays_to": rays_to, "output_path": out}
        )
        structured(r, "ray_test_batch")
        path = os.path.join(workspace, out)
        check(os.path.exists(path), f"ray_test_batch wrote no {path}")
        with open(path) as f:
            written = json.load(f)
        hits = written.get("results", written) if isinstance(written, dict) else written
        check(len(hits) == RAYS, f"{path} holds {len(hits)} rays, not {RAYS}")
        print(f"ray_test_batch: {RAYS} rays written to {out}")

        uri = f"sim://{sim}/info"
        async with client.listen(resource_subscriptions=[uri]) as sub:
            structured(await client.call_tool("step_simulation", {"sim_id": sim, "steps": 1}), "step_simulation")
            event = await asyncio.wait_for(anext(aiter(sub)), TIMEOUT_S)
            print(f"subscriptions/listen: {event}")
            check(uri in repr(event), f"the listen stream announced {event}, not {uri}")


async def legacy_session(url):
    updated = asyncio.Event()
    heard = []

    async def on_message(message):
        root = getattr(message, "root", message)
        method = getattr(root, "method", None)
        if method == "notifications/resources/updated":
            heard.append(root.params.uri)
            updated.set()

    async with Client(url, mode="legacy", message_handler=on_message) as client:
        print(f"legacy mode negotiated protocol {client.protocol_version}")
        sim = structured(await client.call_tool("create_simulation", {}), "create_simulation")["simulation_id"]
        uri = f"sim://{sim}/info"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MCPDeprecationWarning)
            await client.subscribe_resource(uri)
        structured(await client.call_tool("step_simulation", {"sim_id": sim, "steps": 1}), "step_simulation")
        await asyncio.wait_for(updated.wait(), TIMEOUT_S)
        check(uri in heard, f"heard updates of {heard}, not {uri}")
        print(f"resources/subscribe: heard the update of {uri}")
    print("legacy session ended")


async def main(url, workspace):
    await modern_session(url, workspace)
    await legacy_session(url)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    warnings.simplefilter("error")  # any warning fails the check
    complaints = Complaints()
    logging.basicConfig(level=logging.WARNING, handlers=[logging.StreamHandler(sys.stderr)])
    logging.getLogger().addHandler(complaints)
    try:
        asyncio.run(main(sys.argv[1], sys.argv[2]))
    except BaseException as e:  # noqa: BLE001 - report everything, including exception groups
        print(f"python_sdk_check: FAILED: {e!r}", file=sys.stderr)
        sys.exit(1)
    if complaints.records:
        print("python_sdk_check: FAILED: warnings were logged:", *complaints.records, sep="\n  ", file=sys.stderr)
        sys.exit(1)
    print("python_sdk_check: ok")
