//! The board's USB identity, which the firmware announces (`firmware/src/usb.rs`) and the host
//! looks for among the plugged-in serial ports (`host-sender/src/port.rs`).

/// Vendor id: pid.codes, the open-source hardware vendor id.
pub const VID: u16 = 0x1209;
/// Product id: pid.codes' test id; replace with an allocated one before anything ships.
pub const PID: u16 = 0x0001;
