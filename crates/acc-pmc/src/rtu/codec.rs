//! Modbus RTU frames for the board: pure functions over bytes, no I/O.
//!
//! Frame generation and frame-length guessing come from the `rmodbus` crate, CRC-16/MODBUS
//! from the `crc` crate (`rmodbus` keeps its own CRC private); this
//! module only adds the board's transactions and a *layered* classification of replies:
//! a bad checksum ([`FrameError::Crc`]) is kept apart from a device exception
//! ([`FrameError::Exception`]) and from a reply that checks out but violates the protocol
//! ([`FrameError::Protocol`]). Transport errors (timeouts, I/O) never arise here.

use rmodbus::client::ModbusRequest;
use rmodbus::ModbusProto;

/// Modbus function codes the board serves.
pub mod function {
    /// FC03 read holding registers.
    pub const READ_HOLDING: u8 = 0x03;
    /// FC04 read input registers.
    pub const READ_INPUT: u8 = 0x04;
    /// FC06 write single register.
    pub const WRITE_SINGLE: u8 = 0x06;
    /// FC16 write multiple registers.
    pub const WRITE_MULTIPLE: u8 = 0x10;
    /// Bit set in the function byte of an exception reply.
    pub const EXCEPTION_FLAG: u8 = 0x80;
}

/// The CRC-16/MODBUS algorithm (the `crc` crate's catalogue entry).
const MODBUS_CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_MODBUS);

/// CRC-16/MODBUS of `data` (polynomial 0xA001 reflected, init 0xFFFF, no final XOR), for a
/// body of any length. On the wire the CRC is sent low byte first.
pub fn crc16(data: &[u8]) -> u16 {
    MODBUS_CRC.checksum(data)
}

/// Append the CRC (low byte first) to a frame body.
pub fn append_crc(frame: &mut Vec<u8>) {
    let crc = crc16(frame);
    frame.extend_from_slice(&crc.to_le_bytes());
}

/// Whether a whole RTU frame (body + 2 CRC bytes) carries a correct CRC.
pub fn crc_ok(frame: &[u8]) -> bool {
    match frame.len().checked_sub(2) {
        Some(n) if n >= 2 => crc16(&frame[..n]) == u16::from_le_bytes([frame[n], frame[n + 1]]),
        _ => false,
    }
}

/// A reply that parses but breaks the protocol.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProtocolError {
    /// Fewer bytes than the smallest possible reply (5).
    #[error("reply of {len} bytes is shorter than the minimum of 5")]
    Truncated {
        /// Bytes received.
        len: usize,
    },
    /// The reply came from another slave address.
    #[error("reply from slave {received}, expected slave {expected}")]
    SlaveMismatch {
        /// Our slave address.
        expected: u8,
        /// Address in the reply.
        received: u8,
    },
    /// The reply is for another function.
    #[error("reply for function {received:#04x}, expected {expected:#04x}")]
    FunctionMismatch {
        /// Function of the request.
        expected: u8,
        /// Function byte in the reply.
        received: u8,
    },
    /// A read reply with the wrong byte count or frame length.
    #[error("read reply carries {received} data bytes, expected {expected}")]
    ByteCount {
        /// 2 × registers requested.
        expected: usize,
        /// Byte count (or data length) in the reply.
        received: usize,
    },
    /// A write reply whose address/value/count echo differs from the request.
    #[error("write reply echoes {received:02x?}, expected {expected:02x?}")]
    EchoMismatch {
        /// Bytes 2…5 of the request.
        expected: [u8; 4],
        /// Bytes 2…5 of the reply.
        received: [u8; 4],
    },
    /// The first bytes do not start any reply the board can send (unknown function byte).
    #[error("unrecognisable reply header {header:02x?}")]
    BadHeader {
        /// The first bytes received.
        header: Vec<u8>,
    },
}

/// What is wrong with one received reply frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The CRC does not match the frame: line noise; the content must not be trusted.
    #[error("CRC mismatch: frame says {received:#06x}, computed {computed:#06x}")]
    Crc {
        /// CRC computed over the received body.
        computed: u16,
        /// CRC carried by the frame.
        received: u16,
    },
    /// The board answered with a Modbus exception: the link works, the request was refused.
    #[error("board answered exception {code:02} ({}) to function {function:#04x}", exception_name(*code))]
    Exception {
        /// Function of the request.
        function: u8,
        /// Exception code (01 illegal function, 02 illegal address, 03 illegal value, …).
        code: u8,
    },
    /// The frame is intact but not a valid answer to the request.
    #[error(transparent)]
    Protocol(#[from] ProtocolError),
}

/// Human name of a Modbus exception code.
pub fn exception_name(code: u8) -> &'static str {
    match code {
        0x01 => "illegal function",
        0x02 => "illegal data address",
        0x03 => "illegal data value",
        0x04 => "slave device failure",
        0x05 => "acknowledge",
        0x06 => "slave device busy",
        _ => "other",
    }
}

/// A decoded positive reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decoded {
    /// Register values of a read (FC03/FC04), in address order.
    Registers(Vec<u16>),
    /// A write (FC06/FC16) was acknowledged with the correct echo.
    WriteAck,
}

/// A caller error: a request that cannot be built (register count outside 1…123/125), or
/// a transaction used for what it cannot give (registers from a write).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot build Modbus request: {0}")]
pub struct BuildError(pub &'static str);

/// One request/response pair: the request bytes and what a valid reply must look like.
#[derive(Debug)]
pub struct Transaction {
    inner: ModbusRequest,
    slave: u8,
    function: u8,
    count: u16,
    request: Vec<u8>,
}

impl Transaction {
    fn build(
        slave: u8,
        function: u8,
        count: u16,
        gen: impl FnOnce(&mut ModbusRequest, &mut Vec<u8>) -> Result<(), rmodbus::ErrorKind>,
    ) -> Result<Self, BuildError> {
        let mut inner = ModbusRequest::new(slave, ModbusProto::Rtu);
        let mut request = Vec::with_capacity(16);
        gen(&mut inner, &mut request).map_err(|_| BuildError("frame generation failed"))?;
        Ok(Self {
            inner,
            slave,
            function,
            count,
            request,
        })
    }

    /// FC04: read `count` (1…125) input registers from `addr`.
    pub fn read_input_registers(slave: u8, addr: u16, count: u16) -> Result<Self, BuildError> {
        if !(1..=125).contains(&count) {
            return Err(BuildError("read count must be 1..=125"));
        }
        Self::build(slave, function::READ_INPUT, count, |r, v| {
            r.generate_get_inputs(addr, count, v)
        })
    }

    /// FC03: read `count` (1…125) holding registers from `addr`.
    pub fn read_holding_registers(slave: u8, addr: u16, count: u16) -> Result<Self, BuildError> {
        if !(1..=125).contains(&count) {
            return Err(BuildError("read count must be 1..=125"));
        }
        Self::build(slave, function::READ_HOLDING, count, |r, v| {
            r.generate_get_holdings(addr, count, v)
        })
    }

    /// FC06: write one holding register.
    pub fn write_single_register(slave: u8, addr: u16, value: u16) -> Result<Self, BuildError> {
        Self::build(slave, function::WRITE_SINGLE, 1, |r, v| {
            r.generate_set_holding(addr, value, v)
        })
    }

    /// FC16: write 1…123 consecutive holding registers from `addr`.
    pub fn write_multiple_registers(
        slave: u8,
        addr: u16,
        values: &[u16],
    ) -> Result<Self, BuildError> {
        let count = u16::try_from(values.len()).map_err(|_| BuildError("too many registers"))?;
        if !(1..=123).contains(&count) {
            return Err(BuildError("write count must be 1..=123"));
        }
        Self::build(slave, function::WRITE_MULTIPLE, count, |r, v| {
            r.generate_set_holdings_bulk(addr, values, v)
        })
    }

    /// The request frame, CRC included.
    pub fn request_bytes(&self) -> &[u8] {
        &self.request
    }

    /// The function code of the request.
    pub fn function(&self) -> u8 {
        self.function
    }

    /// Length of the whole reply frame once its first bytes are known (`rmodbus`
    /// `guess_response_frame_len`): `Ok(None)` = need more bytes (at most 3 are needed),
    /// `Err` = these bytes cannot start a reply.
    pub fn reply_len(&self, head: &[u8]) -> Result<Option<usize>, ProtocolError> {
        match rmodbus::guess_response_frame_len(head, ModbusProto::Rtu) {
            Ok(n) => Ok(Some(usize::from(n))),
            Err(rmodbus::ErrorKind::OOB) => Ok(None),
            Err(_) => Err(ProtocolError::BadHeader {
                header: head.to_vec(),
            }),
        }
    }

    /// Classify and decode one complete reply frame. Order: CRC ([`crc16`]), slave
    /// address, exception flag, function, then length/echo; values are parsed by `rmodbus`.
    pub fn decode(&self, reply: &[u8]) -> Result<Decoded, FrameError> {
        if reply.len() < 5 {
            return Err(ProtocolError::Truncated { len: reply.len() }.into());
        }
        let n = reply.len() - 2;
        let computed = crc16(&reply[..n]);
        let received = u16::from_le_bytes([reply[n], reply[n + 1]]);
        if computed != received {
            return Err(FrameError::Crc { computed, received });
        }
        if reply[0] != self.slave {
            return Err(ProtocolError::SlaveMismatch {
                expected: self.slave,
                received: reply[0],
            }
            .into());
        }
        if reply[1] == self.function | function::EXCEPTION_FLAG {
            if reply.len() != 5 {
                return Err(ProtocolError::ByteCount {
                    expected: 1,
                    received: n - 2,
                }
                .into());
            }
            return Err(FrameError::Exception {
                function: self.function,
                code: reply[2],
            });
        }
        if reply[1] != self.function {
            return Err(ProtocolError::FunctionMismatch {
                expected: self.function,
                received: reply[1],
            }
            .into());
        }
        match self.function {
            function::READ_INPUT | function::READ_HOLDING => {
                let expected = usize::from(self.count) * 2;
                if usize::from(reply[2]) != expected || reply.len() != expected + 5 {
                    return Err(ProtocolError::ByteCount {
                        expected,
                        received: usize::from(reply[2]),
                    }
                    .into());
                }
                let mut values: Vec<u16> = Vec::with_capacity(usize::from(self.count));
                self.inner
                    .parse_u16(reply, &mut values)
                    .map_err(|_| ProtocolError::ByteCount {
                        expected,
                        received: reply.len() - 5,
                    })?;
                if values.len() != usize::from(self.count) {
                    return Err(ProtocolError::ByteCount {
                        expected,
                        received: values.len() * 2,
                    }
                    .into());
                }
                Ok(Decoded::Registers(values))
            }
            _ => {
                let expected = [
                    self.request[2],
                    self.request[3],
                    self.request[4],
                    self.request[5],
                ];
                if reply.len() != 8 {
                    return Err(ProtocolError::ByteCount {
                        expected: 4,
                        received: n - 2,
                    }
                    .into());
                }
                let received = [reply[2], reply[3], reply[4], reply[5]];
                if received != expected {
                    return Err(ProtocolError::EchoMismatch { expected, received }.into());
                }
                Ok(Decoded::WriteAck)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! Byte-level tests. The CRC bytes are the published CRC-16/MODBUS values, checked
    //! against the frames in the Modbus over serial line guide where they coincide.
    use super::*;

    #[test]
    fn crc_of_known_frames() {
        // Classic example "01 03 00 00 00 0A" → CRC C5 CD (sent C5 first).
        assert_eq!(
            crc16(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A]).to_le_bytes(),
            [0xC5, 0xCD]
        );
        // "01 04 00 00 00 09" → CRC 30 0C.
        assert_eq!(
            crc16(&[0x01, 0x04, 0x00, 0x00, 0x00, 0x09]).to_le_bytes(),
            [0x30, 0x0C]
        );
        let mut f = vec![0x01, 0x06, 0x00, 0x02, 0x00, 0x01];
        append_crc(&mut f);
        assert!(crc_ok(&f));
        f[3] ^= 0x01;
        assert!(!crc_ok(&f));
        assert!(!crc_ok(&[0x01, 0x02, 0x03]));
    }

    #[test]
    fn crc_of_bodies_longer_than_255_bytes() {
        // 300 zero bytes → 0x3065 and 01 10 00 01 … (300 bytes) → 0xF2C5: CRC-16/MODBUS
        // computed bit by bit (poly 0xA001 reflected, init 0xFFFF).
        assert_eq!(crc16(&[0u8; 300]), 0x3065);
        let mut body = vec![0x01, 0x10];
        body.extend((0..298u32).map(|i| (i % 256) as u8));
        assert_eq!(crc16(&body), 0xF2C5);
        // A corrupted long frame is caught like a short one.
        let mut f = body.clone();
        append_crc(&mut f);
        assert!(crc_ok(&f));
        f[200] ^= 0x04;
        assert!(!crc_ok(&f));
    }

    #[test]
    fn read_status_request_bytes() {
        let t = Transaction::read_input_registers(1, 0, 9).expect("build");
        assert_eq!(
            t.request_bytes(),
            &[
                0x01, // slave address 1
                0x04, // FC04 read input registers
                0x00, 0x00, // first register 0 (STATUS)
                0x00, 0x09, // 9 registers (STATUS … PROGRAMMED_FEED)
                0x30, 0x0C, // CRC-16/MODBUS, low byte first
            ]
        );
    }

    #[test]
    fn write_override_request_bytes() {
        let t = Transaction::write_multiple_registers(1, 0, &[120, 0x1234]).expect("build");
        let expected = vec![
            0x01, // slave address 1
            0x10, // FC16 write multiple registers
            0x00, 0x00, // first register 0 (OVERRIDE_CMD)
            0x00, 0x02, // 2 registers
            0x04, // 4 data bytes follow
            0x00, 0x78, // OVERRIDE_CMD = 120 %
            0x12, 0x34, // HEARTBEAT = 0x1234
            0x7E, 0xC1, // CRC-16/MODBUS 0xC17E, low byte first (independently computed)
        ];
        assert_eq!(t.request_bytes(), expected.as_slice());
    }

    #[test]
    fn write_control_request_bytes() {
        let t = Transaction::write_single_register(7, 2, 0x0005).expect("build");
        let expected = [
            0x07, // slave address 7
            0x06, // FC06 write single register
            0x00, 0x02, // register 2 (CONTROL)
            0x00, 0x05, // ACC_REQUEST | ALARM_RESET
            0xE8, 0x6F, // CRC-16/MODBUS 0x6FE8, low byte first (independently computed)
        ];
        assert_eq!(t.request_bytes(), expected.as_slice());
    }

    #[test]
    fn decode_status_reply() {
        let t = Transaction::read_input_registers(1, 0, 9).expect("build");
        let mut reply = vec![
            0x01, // slave 1
            0x04, // FC04
            0x12, // 18 data bytes = 9 registers
            0x00, 0x03, // STATUS: ACC_SWITCH | ACC_ACTIVE
            0x00, 0x6E, // OVERRIDE_APPLIED 110 %
            0x00, 0x64, // OPERATOR_OVERRIDE 100 %
            0x00, 0x0A, // OVERRIDE_STEP 10 %
            0x00, 0x01, // POWER_HI
            0x38, 0x80, // POWER_LO → 0x0001_3880 = 80 000 W
            0x17, 0x70, // SPINDLE_RPM 6000
            0xFF, 0xFF, // SAMPLE_SEQ 65535
            0x04, 0xB0, // PROGRAMMED_FEED 1200 mm/min
        ];
        append_crc(&mut reply); // CRC low, CRC high
        assert_eq!(t.reply_len(&reply[..3]), Ok(Some(23)));
        assert_eq!(t.reply_len(&reply[..1]), Ok(None));
        let regs = match t.decode(&reply) {
            Ok(Decoded::Registers(r)) => r,
            other => panic!("{other:?}"),
        };
        assert_eq!(regs, vec![3, 110, 100, 10, 1, 0x3880, 6000, 65535, 1200]);
    }

    #[test]
    fn decode_layers_crc_exception_protocol() {
        let t = Transaction::write_multiple_registers(1, 0, &[155, 1]).expect("build");
        let mut exc = vec![
            0x01, // slave 1
            0x90, // FC16 | 0x80: exception
            0x03, // exception 03 illegal data value (155 is not a multiple of 10)
        ];
        append_crc(&mut exc); // CRC low, CRC high
        assert_eq!(t.reply_len(&exc[..2]), Ok(Some(5)));
        assert_eq!(
            t.decode(&exc),
            Err(FrameError::Exception {
                function: 0x10,
                code: 3
            })
        );
        // The same bytes with one CRC bit flipped are a CRC error, not an exception.
        let mut bad = exc.clone();
        bad[4] ^= 0x80;
        assert!(matches!(t.decode(&bad), Err(FrameError::Crc { .. })));
        // A valid frame from slave 2.
        let mut other = vec![
            0x02, // slave 2 (not ours)
            0x10, // FC16
            0x00, 0x00, // register 0
            0x00, 0x02, // 2 registers
        ];
        append_crc(&mut other); // CRC
        assert_eq!(
            t.decode(&other),
            Err(ProtocolError::SlaveMismatch {
                expected: 1,
                received: 2
            }
            .into())
        );
        // Right slave, wrong echo (count 1 instead of 2).
        let mut echo = vec![
            0x01, // slave 1
            0x10, // FC16
            0x00, 0x00, // register 0
            0x00, 0x01, // 1 register (request wrote 2)
        ];
        append_crc(&mut echo); // CRC
        assert_eq!(
            t.decode(&echo),
            Err(ProtocolError::EchoMismatch {
                expected: [0, 0, 0, 2],
                received: [0, 0, 0, 1]
            }
            .into())
        );
        // Right slave, reply for FC06 to an FC16 request.
        let mut func = vec![
            0x01, // slave 1
            0x06, // FC06 (request was FC16)
            0x00, 0x00, // register 0
            0x00, 0x02, // value
        ];
        append_crc(&mut func); // CRC
        assert_eq!(
            t.decode(&func),
            Err(ProtocolError::FunctionMismatch {
                expected: 0x10,
                received: 0x06
            }
            .into())
        );
        let mut ok = vec![
            0x01, // slave 1
            0x10, // FC16
            0x00, 0x00, // register 0
            0x00, 0x02, // 2 registers written
        ];
        append_crc(&mut ok); // CRC
        assert_eq!(t.decode(&ok), Ok(Decoded::WriteAck));
        assert_eq!(
            t.decode(&ok[..4]),
            Err(ProtocolError::Truncated { len: 4 }.into())
        );
    }

    #[test]
    fn read_reply_with_wrong_byte_count_is_protocol_error() {
        let t = Transaction::read_input_registers(1, 0, 9).expect("build");
        let mut short = vec![
            0x01, // slave 1
            0x04, // FC04
            0x02, // 2 data bytes (9 registers need 18)
            0x00, 0x03, // one register
        ];
        append_crc(&mut short); // CRC
        assert_eq!(
            t.decode(&short),
            Err(ProtocolError::ByteCount {
                expected: 18,
                received: 2
            }
            .into())
        );
        assert!(matches!(
            t.reply_len(&[0x01, 0x2B, 0x00]),
            Err(ProtocolError::BadHeader { .. })
        ));
    }

    #[test]
    fn bad_request_counts_are_refused() {
        assert!(Transaction::read_input_registers(1, 0, 0).is_err());
        assert!(Transaction::read_input_registers(1, 0, 126).is_err());
        assert!(Transaction::write_multiple_registers(1, 0, &[]).is_err());
        assert!(Transaction::write_multiple_registers(1, 0, &[0; 124]).is_err());
    }
}
