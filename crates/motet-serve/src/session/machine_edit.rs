//! Changing the running machine's planning limits (a grbl sender's `$110=`
//! and the like): only at rest, and only what is sound without touching
//! the nodes (their configuration, steps and travel stay as the machine
//! file says). Nothing is written back to the machine file.

use super::{Session, State};
use crate::events::Level;
use crate::session::ActionError;
use motet_host::Machine;
use std::sync::Arc;

impl Session {
    /// Replaces the machine's planning limits by `edit`'s, at rest: the
    /// next run plans with them. `edit` may change only what plans (speeds,
    /// accelerations, junction deviation); the caller checks its values.
    pub fn edit_limits(
        &mut self,
        what: &str,
        edit: impl FnOnce(&mut Machine),
    ) -> Result<(), ActionError> {
        if !matches!(self.state, State::Idle | State::Stopped | State::Alarm) {
            return Err(ActionError::WrongState {
                action: "change the machine's limits",
                state: self.state,
            });
        }
        let mut m = (*self.machine).clone();
        edit(&mut m);
        self.machine = Arc::new(m);
        self.events
            .push(self.now, Level::Info, format!("{what} changed (not saved)"));
        Ok(())
    }
}
