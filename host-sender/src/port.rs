//! Which board a command talks to: `--port PATH` (before or after the subcommand), else the
//! `GANTRY_PORT` environment variable, else the one Gantry board plugged in, found by its USB
//! vendor and product id (`firmware/src/usb.rs`); with none of these, the emulated board.

/// USB vendor and product id of the Gantry firmware (shared-proto/src/usb.rs).
pub(crate) use gantry_proto::usb::{PID as GANTRY_PID, VID as GANTRY_VID};

/// Where a command goes when neither `--port` nor `GANTRY_PORT` names a port.
#[derive(Debug, PartialEq, Eq)]
pub enum Found {
    /// Exactly one Gantry board is plugged in, on this port.
    One(String),
    /// None is plugged in.
    None,
}

/// The serial ports of plugged-in Gantry boards (by USB VID/PID).
pub(crate) fn gantry_ports() -> Vec<String> {
    let Ok(ports) = serialport::available_ports() else {
        return Vec::new();
    };
    ports
        .into_iter()
        .filter(|p| {
            matches!(&p.port_type, serialport::SerialPortType::UsbPort(u)
                if u.vid == GANTRY_VID && u.pid == GANTRY_PID)
        })
        .map(|p| p.port_name)
        .collect()
}

/// The plugged-in Gantry board, if exactly one is; an error naming them when several are.
pub fn discover() -> anyhow::Result<Found> {
    let mut ports = gantry_ports();
    match ports.len() {
        0 => Ok(Found::None),
        1 => Ok(Found::One(ports.remove(0))),
        _ => anyhow::bail!(
            "{} Gantry boards are plugged in ({}): choose one with --port PATH or GANTRY_PORT",
            ports.len(),
            ports.join(", ")
        ),
    }
}
