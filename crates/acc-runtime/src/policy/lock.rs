//! Lock judge: *has the NC locked the override?* While `OVERRIDE_LOCKED` (tapping,
//! threading, override cancel) the law is frozen ([`acc_core::OverrideLaw::set_frozen`])
//! and not stepped, and the last command is held: the NC is not fought.

/// Whether the law is frozen.
#[derive(Debug, Clone, Default)]
pub(crate) struct LockJudge {
    frozen: bool,
}

impl LockJudge {
    /// This period's `OVERRIDE_LOCKED`: `Some(frozen)` when the law must be frozen
    /// (`true`) or thawed (`false`) now.
    pub(crate) fn judge(&mut self, locked: bool) -> Option<bool> {
        (self.frozen != locked).then(|| {
            self.frozen = locked;
            locked
        })
    }

    /// Thaw on a release or a re-arm: `true` when the law was frozen (thaw it).
    pub(crate) fn thaw(&mut self) -> bool {
        std::mem::take(&mut self.frozen)
    }
}
