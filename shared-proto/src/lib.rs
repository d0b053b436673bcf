//! Gantry wire protocol shared by the firmware and the host sender (no_std).
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]

/// Protocol version exchanged in the handshake; bumped on any incompatible change.
pub const PROTOCOL_VERSION: u16 = 1;
