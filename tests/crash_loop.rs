//! Crash loop (issue #15): written below.
