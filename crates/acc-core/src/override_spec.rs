//! Feed override values, resolution and range.

/// A feed override in percent of the programmed feed (integer percent).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FeedOverride(pub u16);

/// Override resolution and range of the PMC board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OverrideSpec {
    /// Step in percent: 10 for a 4-bit PMC board, 1 for a byte board.
    pub step_pct: u16,
    /// Minimum override, percent (default 0).
    pub min_pct: u16,
    /// Maximum override, percent (default 150; never above 150).
    pub max_pct: u16,
}
