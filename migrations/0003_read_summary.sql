-- physics-mcp log schema v3: a read event records a one-line summary of what it returned
-- (src/log/summary.rs), shown by get_history. Not part of any hash (state, result, or a saved
-- file's MAC): a convenience for readers of the log. NULL on other events and on reads written
-- before v3, which get_history shows as "read".
ALTER TABLE events ADD COLUMN summary TEXT;
