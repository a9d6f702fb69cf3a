//! Log judge: *can this period be recorded?* The run log's writer stalled past the logger's
//! buffer ([`crate::runner`]: `runtime.log_buffer` records behind) means a cut would go on
//! without a record: ACC does not arm, and an active ACC releases with a feed hold and
//! latches ([`super::Release::LogStalled`]).

use super::PolicyInput;

/// The period can be recorded: the run log's writer is not stalled past its buffer.
pub fn recordable(input: &PolicyInput) -> bool {
    !input.log_stalled
}
