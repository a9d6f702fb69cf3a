//! The CAN variant's frames (`../shared/docs/pmc-board.md`, "CAN variant"): classic CAN,
//! 11-bit identifiers, node id `n`, little-endian fields. Pure functions over bytes.
//!
//! | id | direction | bytes |
//! | --- | --- | --- |
//! | `0x180 + n` | board → PC, every new power sample | `STATUS` u8, `OVERRIDE_APPLIED` u8, `OPERATOR_OVERRIDE` u8, `OVERRIDE_STEP` u8, power W u32 |
//! | `0x280 + n` | board → PC, with the frame above | `SPINDLE_RPM` u16, `SAMPLE_SEQ` u16, `PROGRAMMED_FEED` u16, reserved u16 |
//! | `0x300 + n` | board → PC, v2, with the frames above | `TOOL_NUMBER` u16, `ACTUAL_FEED` u16, `BLOCK_NUMBER` u16, `FALLBACK_OVERRIDE` u8, `STATUS` high byte u8 |
//! | `0x380 + n` | board → PC, v2, once a second | `PROTOCOL_VERSION` u16, `PROGRAM_NUMBER` u16, reserved u32 |
//! | `0x200 + n` | PC → board, every cycle | `OVERRIDE_CMD` u8, `CONTROL` u8, `HEARTBEAT` u16 |
//!
//! `0x180 + n` carries the low byte of `STATUS`; the v2 bits 8… (`BOARD_RESTARTED`) travel in
//! the `0x300 + n` frame. A v1 board sends no `0x300`/`0x380` frames.

use crate::{BoardStatus, ControlBits};

/// Base id of the first status frame (`0x180 + n`).
pub const STATUS_A_BASE: u16 = 0x180;
/// Base id of the second status frame (`0x280 + n`).
pub const STATUS_B_BASE: u16 = 0x280;
/// Base id of the command frame (`0x200 + n`).
pub const COMMAND_BASE: u16 = 0x200;
/// Base id of the v2 NC-context frame (`0x300 + n`).
pub const CONTEXT_BASE: u16 = 0x300;
/// Base id of the v2 identity frame (`0x380 + n`, once a second).
pub const IDENTITY_BASE: u16 = 0x380;
/// Allowed node ids (so that every id stays a distinct 11-bit identifier).
pub const NODE_RANGE: core::ops::RangeInclusive<u8> = 1..=127;

/// The three identifiers of node `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeIds {
    /// `0x180 + n`, board → PC.
    pub status_a: u16,
    /// `0x280 + n`, board → PC.
    pub status_b: u16,
    /// `0x200 + n`, PC → board.
    pub command: u16,
    /// `0x300 + n`, board → PC (v2).
    pub context: u16,
    /// `0x380 + n`, board → PC (v2, once a second).
    pub identity: u16,
}

impl NodeIds {
    /// Identifiers for `node` (1…127); `None` outside that range.
    pub fn new(node: u8) -> Option<Self> {
        NODE_RANGE.contains(&node).then(|| {
            let n = u16::from(node);
            Self {
                status_a: STATUS_A_BASE + n,
                status_b: STATUS_B_BASE + n,
                command: COMMAND_BASE + n,
                context: CONTEXT_BASE + n,
                identity: IDENTITY_BASE + n,
            }
        })
    }
}

/// A frame whose payload does not fit the layout.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CanCodecError {
    /// Wrong data length.
    #[error("frame {id:#05x} carries {received} data bytes, expected {expected}")]
    Length {
        /// Identifier.
        id: u16,
        /// Bytes the layout needs.
        expected: usize,
        /// DLC received.
        received: usize,
    },
    /// A percent value that does not fit a byte (the CAN layout carries u8 percent).
    #[error("{field} = {value} does not fit the frame's u8 field")]
    OutOfRange {
        /// Field name.
        field: &'static str,
        /// Value.
        value: u16,
    },
}

fn pct_u8(field: &'static str, value: u16) -> Result<u8, CanCodecError> {
    u8::try_from(value).map_err(|_| CanCodecError::OutOfRange { field, value })
}

/// Encode a status block as the two board → PC payloads (`0x180+n`, `0x280+n`); the
/// `0x180+n` frame carries the low byte of `STATUS`.
pub fn encode_status(s: &BoardStatus) -> Result<([u8; 8], [u8; 8]), CanCodecError> {
    let regs = s.to_input_registers();
    let mut a = [0u8; 8];
    a[0] = (regs[0] & 0xFF) as u8;
    a[1] = pct_u8("OVERRIDE_APPLIED", s.override_applied_pct)?;
    a[2] = pct_u8("OPERATOR_OVERRIDE", s.operator_override_pct)?;
    a[3] = pct_u8("OVERRIDE_STEP", s.override_step_pct)?;
    a[4..8].copy_from_slice(&s.spindle_power_w.to_le_bytes());
    let mut b = [0u8; 8];
    b[0..2].copy_from_slice(&s.spindle_rpm.to_le_bytes());
    b[2..4].copy_from_slice(&s.sample_seq.to_le_bytes());
    b[4..6].copy_from_slice(&s.programmed_feed_mm_min.to_le_bytes());
    Ok((a, b))
}

/// Encode the v2 NC-context payload (`0x300+n`): tool, actual feed, block, the clamp and
/// the high byte of `STATUS`.
pub fn encode_context(s: &BoardStatus) -> Result<[u8; 8], CanCodecError> {
    let regs = s.to_input_registers();
    let mut c = [0u8; 8];
    c[0..2].copy_from_slice(&s.tool_number.to_le_bytes());
    c[2..4].copy_from_slice(&s.actual_feed_mm_min.to_le_bytes());
    c[4..6].copy_from_slice(&s.block_number.to_le_bytes());
    c[6] = pct_u8("FALLBACK_OVERRIDE", s.fallback_override_pct)?;
    c[7] = (regs[0] >> 8) as u8;
    Ok(c)
}

/// Decode a v2 NC-context payload (`0x300+n`) into `status` (tool, actual feed, block,
/// clamp, and `STATUS` bits 8…15: `BOARD_RESTARTED`).
pub fn decode_context(
    ids: NodeIds,
    data: &[u8],
    status: &mut BoardStatus,
) -> Result<(), CanCodecError> {
    let c: &[u8; 8] = data.try_into().map_err(|_| CanCodecError::Length {
        id: ids.context,
        expected: 8,
        received: data.len(),
    })?;
    let mut regs = status.to_input_registers();
    regs[0] = (regs[0] & 0x00FF) | (u16::from(c[7]) << 8);
    regs[10] = u16::from_le_bytes([c[0], c[1]]);
    regs[13] = u16::from_le_bytes([c[2], c[3]]);
    regs[12] = u16::from_le_bytes([c[4], c[5]]);
    regs[14] = u16::from(c[6]);
    *status = BoardStatus::from_input_registers(&regs);
    Ok(())
}

/// Encode the v2 identity payload (`0x380+n`, once a second): protocol version and
/// program number.
pub fn encode_identity(s: &BoardStatus) -> [u8; 8] {
    let mut d = [0u8; 8];
    d[0..2].copy_from_slice(&s.protocol_version.to_le_bytes());
    d[2..4].copy_from_slice(&s.program_number.to_le_bytes());
    d
}

/// Decode a v2 identity payload (`0x380+n`): `(PROTOCOL_VERSION, PROGRAM_NUMBER)`.
pub fn decode_identity(ids: NodeIds, data: &[u8]) -> Result<(u16, u16), CanCodecError> {
    let d: &[u8; 8] = data.try_into().map_err(|_| CanCodecError::Length {
        id: ids.identity,
        expected: 8,
        received: data.len(),
    })?;
    Ok((
        u16::from_le_bytes([d[0], d[1]]),
        u16::from_le_bytes([d[2], d[3]]),
    ))
}

/// Decode the two board → PC payloads into a status block (the v1 fields; the v2 fields
/// come from [`decode_context`] and [`decode_identity`] and read as unknown until then).
pub fn decode_status(ids: NodeIds, a: &[u8], b: &[u8]) -> Result<BoardStatus, CanCodecError> {
    let a: &[u8; 8] = a.try_into().map_err(|_| CanCodecError::Length {
        id: ids.status_a,
        expected: 8,
        received: a.len(),
    })?;
    let b: &[u8; 8] = b.try_into().map_err(|_| CanCodecError::Length {
        id: ids.status_b,
        expected: 8,
        received: b.len(),
    })?;
    let power = u32::from_le_bytes([a[4], a[5], a[6], a[7]]);
    let mut regs = [0u16; crate::regs::input::COUNT as usize];
    regs[..9].copy_from_slice(&[
        u16::from(a[0]),
        u16::from(a[1]),
        u16::from(a[2]),
        u16::from(a[3]),
        (power >> 16) as u16,
        (power & 0xFFFF) as u16,
        u16::from_le_bytes([b[0], b[1]]),
        u16::from_le_bytes([b[2], b[3]]),
        u16::from_le_bytes([b[4], b[5]]),
    ]);
    regs[crate::regs::input::FALLBACK_OVERRIDE as usize] = crate::regs::FALLBACK_NONE_PCT;
    Ok(BoardStatus::from_input_registers(&regs))
}

/// The PC → board command (`0x200+n`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Command {
    /// `OVERRIDE_CMD`, percent.
    pub override_pct: u8,
    /// `CONTROL` bits.
    pub control: ControlBits,
    /// `HEARTBEAT`.
    pub heartbeat: u16,
}

/// Encode the command payload (4 bytes).
pub fn encode_command(c: &Command) -> [u8; 4] {
    let hb = c.heartbeat.to_le_bytes();
    // CONTROL uses bits 0…2 only.
    [c.override_pct, c.control.to_register() as u8, hb[0], hb[1]]
}

/// Decode a command payload.
pub fn decode_command(ids: NodeIds, data: &[u8]) -> Result<Command, CanCodecError> {
    let d: &[u8; 4] = data.try_into().map_err(|_| CanCodecError::Length {
        id: ids.command,
        expected: 4,
        received: data.len(),
    })?;
    Ok(Command {
        override_pct: d[0],
        control: ControlBits::from_register(u16::from(d[1])),
        heartbeat: u16::from_le_bytes([d[2], d[3]]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const IDS: NodeIds = NodeIds {
        status_a: 0x181,
        status_b: 0x281,
        command: 0x201,
        context: 0x301,
        identity: 0x381,
    };

    #[test]
    fn node_ids() {
        assert_eq!(NodeIds::new(1), Some(IDS));
        assert_eq!(
            NodeIds::new(127).map(|i| (i.status_a, i.status_b, i.command)),
            Some((0x1FF, 0x2FF, 0x27F))
        );
        assert_eq!(NodeIds::new(0), None);
        assert_eq!(NodeIds::new(128), None);
    }

    #[test]
    fn status_frames_byte_layout() {
        let a = [
            0x07, // STATUS: ACC_SWITCH | ACC_ACTIVE | CYCLE_ACTIVE
            0x6E, // OVERRIDE_APPLIED 110 %
            0x64, // OPERATOR_OVERRIDE 100 %
            0x0A, // OVERRIDE_STEP 10 %
            0x80, 0x38, 0x01, 0x00, // power 0x0001_3880 = 80 000 W, little-endian
        ];
        let b = [
            0x70, 0x17, // SPINDLE_RPM 6000, little-endian
            0x34, 0x12, // SAMPLE_SEQ 0x1234
            0xB0, 0x04, // PROGRAMMED_FEED 1200 mm/min
            0x00, 0x00, // reserved
        ];
        let s = decode_status(IDS, &a, &b).expect("decode");
        assert!(s.acc_switch && s.acc_active && s.cycle_active && !s.watchdog_tripped);
        assert_eq!(
            (
                s.override_applied_pct,
                s.operator_override_pct,
                s.override_step_pct
            ),
            (110, 100, 10)
        );
        assert_eq!(s.spindle_power_w, 80_000);
        assert_eq!(
            (s.spindle_rpm, s.sample_seq, s.programmed_feed_mm_min),
            (6000, 0x1234, 1200)
        );
        assert_eq!(encode_status(&s), Ok((a, b)));
    }

    #[test]
    fn v2_frames_byte_layout() {
        let mut s = BoardStatus {
            acc_switch: true,
            fallback_active: true,
            board_restarted: true,
            ..BoardStatus::default()
        };
        s.tool_number = 12;
        s.actual_feed_mm_min = 720;
        s.block_number = 0x1234;
        s.fallback_override_pct = 90;
        s.protocol_version = 2;
        s.program_number = 4711;
        let (a, _) = encode_status(&s).expect("encode");
        assert_eq!(a[0], 0x81); // ACC_SWITCH | FALLBACK_ACTIVE: low byte only
        let c = encode_context(&s).expect("context");
        assert_eq!(c, [12, 0, 0xD0, 0x02, 0x34, 0x12, 90, 0x01]);
        let d = encode_identity(&s);
        assert_eq!(d, [2, 0, 0x67, 0x12, 0, 0, 0, 0]);
        let (a, b) = encode_status(&s).expect("encode");
        let mut back = decode_status(IDS, &a, &b).expect("decode");
        // The v1 frames alone: bit 7 is in frame A; no clamp value, version unknown.
        assert!(back.fallback_active && !back.board_restarted && !back.is_v2());
        assert_eq!(back.fallback_override_pct, 150);
        decode_context(IDS, &c, &mut back).expect("context");
        let (version, program) = decode_identity(IDS, &d).expect("identity");
        back.protocol_version = version;
        back.program_number = program;
        // The context frame brings STATUS bit 8 and keeps bit 7 of frame A.
        assert!(back.board_restarted && back.fallback_active);
        assert_eq!(
            (back.tool_number, back.actual_feed_mm_min, back.block_number),
            (12, 720, 0x1234)
        );
        assert_eq!(
            (
                back.fallback_override_pct,
                back.protocol_version,
                back.program_number
            ),
            (90, 2, 4711)
        );
        assert_eq!(
            decode_context(IDS, &[0; 7], &mut back),
            Err(CanCodecError::Length {
                id: 0x301,
                expected: 8,
                received: 7
            })
        );
    }

    #[test]
    fn command_frame_byte_layout() {
        let c = Command {
            override_pct: 120,
            control: ControlBits {
                acc_request: true,
                feed_hold_request: false,
                alarm_reset: true,
            },
            heartbeat: 0xBEEF,
        };
        let bytes = [
            0x78, // OVERRIDE_CMD 120 %
            0x05, // CONTROL: ACC_REQUEST | ALARM_RESET
            0xEF, 0xBE, // HEARTBEAT 0xBEEF, little-endian
        ];
        assert_eq!(encode_command(&c), bytes);
        assert_eq!(decode_command(IDS, &bytes), Ok(c));
    }

    #[test]
    fn wrong_lengths_and_ranges_are_errors() {
        assert_eq!(
            decode_status(IDS, &[0; 7], &[0; 8]),
            Err(CanCodecError::Length {
                id: 0x181,
                expected: 8,
                received: 7
            })
        );
        assert_eq!(
            decode_status(IDS, &[0; 8], &[0; 2]),
            Err(CanCodecError::Length {
                id: 0x281,
                expected: 8,
                received: 2
            })
        );
        assert_eq!(
            decode_command(IDS, &[0; 8]),
            Err(CanCodecError::Length {
                id: 0x201,
                expected: 4,
                received: 8
            })
        );
        let s = BoardStatus {
            override_step_pct: 300,
            ..BoardStatus::default()
        };
        assert_eq!(
            encode_status(&s),
            Err(CanCodecError::OutOfRange {
                field: "OVERRIDE_STEP",
                value: 300
            })
        );
    }
}
