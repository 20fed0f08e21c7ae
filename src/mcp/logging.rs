//! MCP logging (`logging/setLevel`, `notifications/message`): what an operator watching a
//! client would want to see, each session at its own level.
//!
//! A session hears nothing until it sets a level (the protocol lets the server choose; an
//! agent that never asked should not spend context on log lines). Then it hears, at or above
//! its level: every simulation skipped as damaged when the server started (`warning`, sent
//! once right after `setLevel`, since no session exists at start), the reason of every
//! refused tool call (`info`), and a slow snapshot write of the simulation it called
//! (`warning`, `Sim::take_stalls`).
#![allow(deprecated)] // rmcp marks MCP logging deprecated (SEP-2577); 2025-11-25 clients use it.

use std::sync::{Arc, Mutex};

use rmcp::model::{LoggingLevel, LoggingMessageNotificationParam};
use rmcp::{Peer, RoleServer};
use serde_json::Value;

/// The name `notifications/message` carries as its `logger`.
const LOGGER: &str = "physics-mcp";

/// Severity rank (the order RFC 5424 gives, debug lowest).
fn rank(level: LoggingLevel) -> u8 {
    match level {
        LoggingLevel::Debug => 0,
        LoggingLevel::Info => 1,
        LoggingLevel::Notice => 2,
        LoggingLevel::Warning => 3,
        LoggingLevel::Error => 4,
        LoggingLevel::Critical => 5,
        LoggingLevel::Alert => 6,
        LoggingLevel::Emergency => 7,
    }
}

/// One session's chosen level (none until `logging/setLevel`).
#[derive(Clone, Default)]
pub struct SessionLog(Arc<Mutex<Option<LoggingLevel>>>);

impl SessionLog {
    /// `logging/setLevel`.
    pub fn set(&self, level: LoggingLevel) {
        *self.0.lock().unwrap_or_else(|p| p.into_inner()) = Some(level);
    }

    /// Whether a message at `level` goes to this session.
    pub fn wants(&self, level: LoggingLevel) -> bool {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_some_and(|min| rank(level) >= rank(min))
    }

    /// Sends `data` at `level` to `peer` if this session wants it, in the background (a log
    /// line never holds up a reply).
    pub fn send(&self, peer: &Peer<RoleServer>, level: LoggingLevel, data: Value) {
        if !self.wants(level) {
            return;
        }
        let peer = peer.clone();
        let mut message = LoggingMessageNotificationParam::new(level, data);
        message.logger = Some(LOGGER.to_string());
        tokio::spawn(async move {
            if let Err(e) = peer.notify_logging_message(message).await {
                tracing::debug!("log message not delivered: {e}");
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_session_hears_its_level_and_above_and_nothing_before_choosing() {
        let log = SessionLog::default();
        assert!(!log.wants(LoggingLevel::Emergency));
        log.set(LoggingLevel::Warning);
        assert!(log.wants(LoggingLevel::Warning));
        assert!(log.wants(LoggingLevel::Error));
        assert!(!log.wants(LoggingLevel::Info));
        log.set(LoggingLevel::Debug);
        assert!(log.wants(LoggingLevel::Info));
    }
}
