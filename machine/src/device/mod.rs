//! The device's side of the wire and the one main-loop pass: the host link (framed protocol or
//! grbl text), the main loop that services it, the kernel and the inputs, and what only the step
//! kernel's owner knows (underruns, starvation). Everything here drives a [`crate::board::Board`];
//! nothing below imports it.

#[cfg(feature = "link")]
pub mod grbl;
pub mod kernel_view;
#[cfg(feature = "link")]
pub mod link;
#[cfg(feature = "link")]
pub mod main_loop;
#[cfg(feature = "link")]
mod starvation;
pub mod underruns;
