"""The installed wheel works where MCP clients start it (scripts/install_check.sh, `.ci/run`):
`physics-mcp` as pip installed it, with no Rust on PATH, and the same wheel through `uvx`, each
started over stdio with no flags from `/`, from a temporary directory and from a directory it
cannot write (as another user when run as root), making a simulation and checking where its
log landed and what the first log line said.

    python3 scripts/install_check.py BIN WHEEL UVX
"""

import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "lib"))
import mcp_stdio  # noqa: E402

NOBODY = 65534


def check(ok, what):
    if not ok:
        raise SystemExit(f"install_check: FAILED: {what}")
    print(f"ok    {what}")


def clean_env(home, path):
    """An environment like a desktop client's: a HOME, a PATH, no XDG_DATA_HOME, no Rust."""
    return {"HOME": str(home), "PATH": path, "LANG": "C.UTF-8"}


def session(argv, cwd, env):
    """Starts `argv` over stdio, makes a simulation with a built-in model, ends; returns (sim id,
    stderr lines)."""
    server = mcp_stdio.StdioServer(argv, cwd, env)
    sim = server.call("create_simulation", {})["simulation_id"]
    # A built-in model, found from any directory: it is compiled into the binary.
    server.call("load_urdf", {"sim_id": sim, "file_path": "plane.urdf"})
    listed = server.call("list_simulations", {})
    code = server.close()
    log = server.stderr().splitlines()
    check(code == 0 and any(s["simulation_id"] == sim for s in listed["simulations"]),
          f"{' '.join(argv[-2:])} from {cwd}: created and listed {sim}, exit {code}")
    return sim, log


def user_data(home):
    return pathlib.Path(home) / ".local/share/physics-mcp"


def expect_user_dirs(sim, log, home, why):
    data = user_data(home) / "data"
    check((data / f"{sim}.sqlite").is_file(), f"its log is {data}/{sim}.sqlite")
    check((user_data(home) / "workspace").is_dir(), f"its workspace is {user_data(home)}/workspace")
    first = log[0] if log else ""
    check(first.startswith(f"physics-mcp: data in {data}, workspace in {user_data(home)}/workspace") and why in first,
          f"the first log line says where and why: {first!r}")


def main():
    binary, wheel, uvx = (os.path.abspath(a) for a in sys.argv[1:4])
    path = f"{os.path.dirname(binary)}:/usr/bin:/bin"
    check(shutil.which("cargo", path=path) is None and shutil.which("rustc", path=path) is None,
          f"no Rust on the PATH the checks use ({path})")
    root_had_data = pathlib.Path("/physics-mcp-data").exists()
    with tempfile.TemporaryDirectory(prefix="physics-mcp-install-") as tmp:
        tmp = pathlib.Path(tmp)
        version = subprocess.run([binary, "--version"], env=clean_env(tmp, path), capture_output=True, text=True, check=True)
        check(version.stdout.startswith("physics-mcp "), f"{binary} --version: {version.stdout.strip()}")

        # From /, as clients often start stdio servers: the user's data directory.
        home = tmp / "home-root"
        home.mkdir()
        sim, log = session([binary, "stdio"], "/", clean_env(home, path))
        expect_user_dirs(sim, log, home, "the working directory / is the file system's root")
        if not root_had_data:
            check(not pathlib.Path("/physics-mcp-data").exists(), "nothing was made at /physics-mcp-data")

        # From a usable directory: today's defaults, there, and no note.
        work = tmp / "project"
        work.mkdir()
        sim, log = session([binary, "stdio"], str(work), clean_env(tmp / "home-unused", path))
        check((work / "physics-mcp-data" / f"{sim}.sqlite").is_file(), f"from {work}: its log is ./physics-mcp-data/{sim}.sqlite")
        check((work / "physics-mcp-workspace").is_dir() and not log, "and ./physics-mcp-workspace, with nothing on stderr")

        # From a directory it cannot write: as root, as another user (root writes anywhere).
        locked = tmp / "read-only"
        locked.mkdir()
        home = tmp / "home-unwritable"
        home.mkdir()
        argv = [binary, "stdio"]
        if os.geteuid() == 0:
            # The other user needs to reach the binary and its home: a copy in a 0755 tree.
            tmp.chmod(0o755)
            shared = tmp / "bin"
            shared.mkdir()
            shutil.copy2(binary, shared / "physics-mcp")
            os.chown(home, NOBODY, NOBODY)
            argv = ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups", str(shared / "physics-mcp"), "stdio"]
        else:
            locked.chmod(0o555)
        sim, log = session(argv, str(locked), clean_env(home, path))
        expect_user_dirs(sim, log, home, f"the working directory {locked} is not writable")

        # The wheel through uvx, from /, offline: what `{"command": "uvx", "args": [...]}` runs.
        home = tmp / "home-uvx"
        home.mkdir()
        env = dict(clean_env(home, path), UV_CACHE_DIR=str(tmp / "uv-cache"), UV_PYTHON_DOWNLOADS="never", UV_NO_CONFIG="1")
        sim, log = session([uvx, "--quiet", "--offline", "--from", wheel, "physics-mcp", "stdio"], "/", env)
        expect_user_dirs(sim, log, home, "the working directory / is the file system's root")
    print("install_check: every check passed")


if __name__ == "__main__":
    main()
