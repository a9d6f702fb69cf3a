//! What the policy's state is made of: the state, why ACC let go, why it re-armed, the
//! alarms in force.

/// Why ACC let go of the override.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Release {
    /// The operator switched ACC off (not latched: switching on re-arms).
    SwitchOff,
    /// The operator turned the override knob down by more than the hand-back amount.
    OperatorHandback,
    /// Link failures for more than `link_hold_periods`.
    LinkLost,
    /// Invalid or stale power for more than `invalid_power_periods`.
    PowerInvalid,
    /// The board's watchdog tripped.
    Watchdog,
    /// The board dropped `ACC_ACTIVE` unexplained (power cycle / reset).
    BoardReset,
    /// The board never confirmed `ACC_ACTIVE` after arming.
    NoBoardAck,
    /// Force above the overload limit for too long (feed hold requested).
    Overload,
    /// Tool breakage suspected: a sudden force drop or spike (feed hold requested).
    Breakage,
    /// The measured loop delay exceeds what the gains in use tolerate (feed hold
    /// requested): see [`crate::echo`].
    Delay,
    /// The run log's writer stalled past the logger's buffer (feed hold requested): the cut
    /// never goes on without a record ([`crate::runner`]).
    LogStalled,
}

impl Release {
    /// Short lower-case name for logs.
    pub fn as_str(self) -> &'static str {
        match self {
            Release::SwitchOff => "switch_off",
            Release::OperatorHandback => "operator_handback",
            Release::LinkLost => "link_lost",
            Release::PowerInvalid => "power_invalid",
            Release::Watchdog => "watchdog",
            Release::BoardReset => "board_reset",
            Release::NoBoardAck => "no_board_ack",
            Release::Overload => "overload",
            Release::Breakage => "breakage",
            Release::Delay => "delay",
            Release::LogStalled => "log_stalled",
        }
    }

    /// Whether re-arming needs the operator's switch to be cycled off and on.
    pub fn latches(self) -> bool {
        !matches!(self, Release::SwitchOff)
    }
}

/// Why the policy re-armed by itself ([`super::Event::Rearmed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rearm {
    /// The board restarted (v2 `BOARD_RESTARTED`, v1 an unexplained `ACC_ACTIVE` drop).
    BoardRestart,
    /// The link came back after an outage, the cut still on.
    LinkRestored,
}

impl Rearm {
    /// Short lower-case name for logs (`board_restart`, `link_restored`).
    pub fn as_str(self) -> &'static str {
        match self {
            Rearm::BoardRestart => "board_restart",
            Rearm::LinkRestored => "link_restored",
        }
    }
}

/// ACC state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccState {
    /// Not driving the override; arms when the operator's switch is on.
    Idle,
    /// Driving the override (`ACC_REQUEST` set).
    Active,
    /// Released after a fault or a hand-back; re-arms only after the switch cycles off → on.
    Latched(Release),
}

impl AccState {
    /// Short name for logs (`idle`, `active`, `latched:<reason>`).
    pub fn name(self) -> &'static str {
        match self {
            AccState::Idle => "idle",
            AccState::Active => "active",
            AccState::Latched(r) => r.as_str(),
        }
    }
}

/// Alarms in force (cleared when the operator re-arms by cycling the switch).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Alarms {
    /// Link lost for more than the hold time.
    pub link_lost: bool,
    /// Power invalid or stale for too long.
    pub power_invalid: bool,
    /// Board watchdog tripped.
    pub watchdog: bool,
    /// Board reset / did not confirm ACC.
    pub board_reset: bool,
    /// Overload: feed hold requested.
    pub overload: bool,
    /// Tool breakage suspected (sudden force drop or spike): feed hold requested.
    pub breakage: bool,
    /// The loop delay exceeded the gains' delay margin: feed hold requested.
    pub delay: bool,
}

impl Alarms {
    /// Any alarm set.
    pub fn any(&self) -> bool {
        self.link_lost
            || self.power_invalid
            || self.watchdog
            || self.board_reset
            || self.overload
            || self.breakage
            || self.delay
    }

    /// The alarms in force by name, comma-separated (`none` when there are none): `link_lost`,
    /// `power_invalid`, `watchdog`, `board_reset`, `overload`.
    ///
    /// ```
    /// use acc_runtime::Alarms;
    /// let a = Alarms { watchdog: true, overload: true, ..Alarms::default() };
    /// assert_eq!(a.names(), "watchdog, overload");
    /// assert_eq!(Alarms::default().names(), "none");
    /// ```
    pub fn names(&self) -> String {
        let all = [
            (self.link_lost, "link_lost"),
            (self.power_invalid, "power_invalid"),
            (self.watchdog, "watchdog"),
            (self.board_reset, "board_reset"),
            (self.overload, "overload"),
            (self.breakage, "breakage"),
            (self.delay, "delay"),
        ];
        let on: Vec<&str> = all.iter().filter(|(b, _)| *b).map(|(_, n)| *n).collect();
        if on.is_empty() {
            "none".into()
        } else {
            on.join(", ")
        }
    }

    /// Compact bit code for the run log: bit 0 link, 1 power, 2 watchdog, 3 board reset,
    /// 4 overload, 5 breakage, 6 delay.
    pub fn bits(&self) -> u8 {
        u8::from(self.link_lost)
            | u8::from(self.power_invalid) << 1
            | u8::from(self.watchdog) << 2
            | u8::from(self.board_reset) << 3
            | u8::from(self.overload) << 4
            | u8::from(self.breakage) << 5
            | u8::from(self.delay) << 6
    }

    /// Raise the alarm of a release (none for the operator's own acts).
    pub(crate) fn raise(&mut self, why: Release) {
        match why {
            Release::LinkLost => self.link_lost = true,
            Release::PowerInvalid => self.power_invalid = true,
            Release::Watchdog => self.watchdog = true,
            Release::BoardReset | Release::NoBoardAck => self.board_reset = true,
            Release::Overload => self.overload = true,
            Release::Breakage => self.breakage = true,
            Release::Delay => self.delay = true,
            Release::LogStalled | Release::SwitchOff | Release::OperatorHandback => {}
        }
    }
}
