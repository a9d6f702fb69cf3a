//! Delay judge: *is the line's delay more than the gains in use tolerate?* The loop delay
//! measured on the line ([`crate::echo`]) against the law's delay margin
//! ([`acc_core::OverrideLaw::delay_margin_periods`]): beyond it, feed hold, the `delay`
//! alarm and a latched release ([`super::Release::Delay`]), so that ACC never drives on into
//! an oscillation.

/// The measured extra delay and the margin when the delay exceeds the margin: the
/// estimate has been later than the designed 1 period on at least two informative
/// periods in a row (`late_streak`) and
/// is more periods late than the law's gains tolerate. `None` when the law cannot judge
/// its margin (no model: the comparison baselines).
///
/// A confirmed replay of the board's past (`replay_lag_periods`: `SAMPLE_SEQ` went back and
/// the next read went on from there) is judged at once: its very first sample is already
/// that many periods old.
///
/// `margin` is asked only when a delay was measured (the margin's Schur–Cohn scan stays off
/// the control period otherwise).
pub fn delay_exceeded(
    d: &crate::echo::DelayReading,
    margin: impl FnOnce() -> Option<u32>,
) -> Option<(u32, u32)> {
    let echo = d
        .echo_periods
        .filter(|_| d.late_streak >= 2)
        .map(|e| e.saturating_sub(1));
    let extra = echo.max(d.replay_lag_periods).filter(|e| *e > 0)?;
    let margin = margin()?;
    (extra > margin).then_some((extra, margin))
}
