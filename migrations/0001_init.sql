-- physics-mcp log schema v1: one file per simulation.
-- A simulation is the deterministic fold of its state-changing events (root, change, move).
CREATE TABLE meta (
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
) STRICT;

-- Every tool call on the simulation. Root/change events form a tree through `parent`
-- (the head they were applied to); move (undo/redo), read and refused events have no parent.
CREATE TABLE events (
    seq         INTEGER PRIMARY KEY,
    kind        TEXT    NOT NULL CHECK (kind IN ('root', 'change', 'move', 'read', 'refused')),
    parent      INTEGER,
    tool        TEXT    NOT NULL,
    arguments   TEXT    NOT NULL,  -- the client's JSON, or {"blob": hash, "bytes": n} over 64 KB
    command     TEXT,              -- the validated Command JSON (root/change), move target (move)
    version     INTEGER NOT NULL,  -- event encoding version (command.rs EVENT_VERSION)
    ok          INTEGER NOT NULL,
    mutates     INTEGER NOT NULL,
    inherited   INTEGER NOT NULL DEFAULT 0,
    result      TEXT,              -- result JSON (root/change/move) or the refusal sentence
    result_hash TEXT,              -- blake3 of the result JSON (accepted events)
    state_hash  TEXT    NOT NULL   -- the world's state hash after this event
) STRICT;

-- The state-changing event the world currently reflects.
CREATE TABLE head (
    id       INTEGER PRIMARY KEY CHECK (id = 1),
    head_seq INTEGER NOT NULL
) STRICT;

-- Full-world snapshots (postcard) on the chain, with their blake3.
CREATE TABLE snapshots (
    seq   INTEGER PRIMARY KEY,
    hash  TEXT NOT NULL,
    bytes BLOB NOT NULL
) STRICT;

-- Content-addressed blobs: URDF text, meshes, arguments over 64 KB.
CREATE TABLE blobs (
    hash  TEXT PRIMARY KEY,
    bytes BLOB NOT NULL
) STRICT;
