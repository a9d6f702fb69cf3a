//! The board links: CAN (mock, v2, vcan with `--features vcan`) and Modbus RTU over ptys.
//!
//! One module per test file.

mod can_mock;
mod can_v2;
mod can_vcan;
mod rtu_pty;
mod rtu_robust;
