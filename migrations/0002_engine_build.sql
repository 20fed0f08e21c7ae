-- physics-mcp log schema v2: every root event records the engine build that made it
-- (physics_core::engine::ENGINE_BUILD, e.g. "rapier3d 0.36.1 (serde-serialize,
-- enhanced-determinism)"), copied with inherited roots. NULL on other events, and on roots
-- written before v2, which read as physics_core::engine::UNRECORDED_ENGINE_BUILD.
ALTER TABLE events ADD COLUMN engine TEXT;
