//! USB OTG FS device: one CDC-ACM port ("Gantry CNC controller") carrying the host link.
//!
//! Three small tasks move bytes between the CDC endpoints and two pipes; the main loop
//! (`control.rs`) feeds received bytes to `BoardLink::on_bytes` and writes the frames of
//! `BoardLink::poll_transmit` into the transmit pipe. DTR changes are published for the host-loss
//! policy. The USB interrupt runs below the step timer (see `main`).

use crate::pin_map::Irqs;
use core::sync::atomic::{AtomicBool, Ordering};
use embassy_stm32::peripherals::{PA11, PA12, USB_OTG_FS};
use embassy_stm32::usb::Driver;
use embassy_stm32::Peri;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_sync::signal::Signal;
use embassy_usb::class::cdc_acm::{CdcAcmClass, ControlChanged, Receiver, Sender, State};
use embassy_usb::{Builder, UsbDevice};
// The USB identity the host looks for (shared-proto/src/usb.rs).
use gantry_proto::usb::{PID, VID};
use static_cell::StaticCell;

/// The OTG FS driver type.
pub type UsbDriver = Driver<'static, USB_OTG_FS>;

/// Full-speed bulk packet size.
const PACKET: u16 = 64;

/// Builds the USB device and its CDC-ACM class.
pub fn build(
    usb: Peri<'static, USB_OTG_FS>,
    dp: Peri<'static, PA12>,
    dm: Peri<'static, PA11>,
) -> (
    UsbDevice<'static, UsbDriver>,
    CdcAcmClass<'static, UsbDriver>,
) {
    static EP_OUT: StaticCell<[u8; 256]> = StaticCell::new();
    static CONFIG_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static CONTROL: StaticCell<[u8; 64]> = StaticCell::new();
    static CDC_STATE: StaticCell<State> = StaticCell::new();

    let mut otg = embassy_stm32::usb::Config::default();
    // Bus-powered board: VBUS is not wired to PA9, so don't sense it.
    otg.vbus_detection = false;
    let driver = Driver::new_fs(usb, Irqs, dp, dm, EP_OUT.init([0; 256]), otg);

    let mut config = embassy_usb::Config::new(VID, PID);
    config.manufacturer = Some("Gantry");
    config.product = Some("Gantry CNC controller");
    config.serial_number = Some(embassy_stm32::uid::uid_hex());
    config.max_power = 100;
    config.max_packet_size_0 = 64;

    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESC.init([0; 256]),
        BOS_DESC.init([0; 256]),
        &mut [],
        CONTROL.init([0; 64]),
    );
    let class = CdcAcmClass::new(&mut builder, CDC_STATE.init(State::new()), PACKET);
    (builder.build(), class)
}

#[embassy_executor::task]
pub async fn run_device(mut device: UsbDevice<'static, UsbDriver>) -> ! {
    device.run().await
}

/// Bytes between the USB tasks and the main loop. All of them run on the thread-mode executor,
/// so the pipes need no lock (and no critical section that would delay the step interrupt).
pub type LinkPipe = Pipe<NoopRawMutex, PIPE_LEN>;
/// Room in each direction: two of the largest frames, so a slow host throttles the board's link
/// (which keeps unsent frames queued and retransmits) instead of stalling the main loop. The main
/// loop reads the receive pipe in a pass for every packet (`RxWake`) and at every tick, at most
/// 512 bytes a pass, so host → board the USB's full-speed rate is the ceiling, not the tick.
pub const PIPE_LEN: usize = 512;

/// Raised by the receive task after each packet it put into the receive pipe: the main loop
/// (`control.rs`) runs a pass for it at once instead of at the next 1 ms tick, so a grbl line is
/// answered when it arrives (machine/src/device/main_loop.rs `MainLoop::host_bytes_pass`).
pub type RxWake = Signal<NoopRawMutex, ()>;

/// Data terminal ready as the host last set it (a terminal or sender has the port open).
pub static DTR: AtomicBool = AtomicBool::new(false);

/// Host → board: every packet into the receive pipe. The main loop takes from the pipe only what
/// the link has room for (`BoardLink::rx_room`: a grbl sender's receive buffer), so a burst
/// fills the pipe; a full pipe stops this task reading the endpoint, the USB core NAKs and the
/// host waits: no byte is dropped (machine/src/device/main_loop.rs,
/// `a_full_receive_buffer_leaves_the_port_unread`).
#[embassy_executor::task]
pub async fn run_rx(
    mut rx: Receiver<'static, UsbDriver>,
    pipe: &'static LinkPipe,
    wake: &'static RxWake,
) -> ! {
    // At least the packet size: a smaller buffer fails with BufferOverflow and keeps the packet.
    let mut buf = [0u8; PACKET as usize];
    loop {
        rx.wait_connection().await;
        defmt::info!("usb: configured");
        // Err: disabled (unplugged, bus reset) or BufferOverflow: wait for the next connection.
        while let Ok(n) = rx.read_packet(&mut buf).await {
            // (`get`: the driver never reports more than the buffer; no panic path for it.)
            pipe.write_all(buf.get(..n).unwrap_or_default()).await;
            wake.signal(());
        }
        defmt::info!("usb: disconnected");
    }
}

/// Board → host: the transmit pipe in packets of at most 64 bytes. A transfer whose last packet
/// is exactly 64 bytes is ended with a zero-length packet, or some hosts hold the data back until
/// the next short packet (frames also end with the COBS delimiter, so nothing depends on it).
/// Bytes queued while no host is configured are dropped at connection: the link repeats what
/// matters, and a half frame would only be discarded by the host's decoder.
#[embassy_executor::task]
pub async fn run_tx(mut tx: Sender<'static, UsbDriver>, pipe: &'static LinkPipe) -> ! {
    let mut buf = [0u8; PACKET as usize];
    loop {
        tx.wait_connection().await;
        pipe.clear();
        loop {
            let n = pipe.read(&mut buf).await;
            if tx
                .write_packet(buf.get(..n).unwrap_or_default())
                .await
                .is_err()
            {
                break;
            }
            if n == PACKET as usize && pipe.is_empty() && tx.write_packet(&[]).await.is_err() {
                break;
            }
        }
    }
}

/// Follows the host's DTR line (line state requests on the control pipe).
#[embassy_executor::task]
pub async fn run_control(control: ControlChanged<'static>) -> ! {
    loop {
        control.control_changed().await;
        let dtr = control.dtr();
        DTR.store(dtr, Ordering::Relaxed);
        defmt::info!("usb: DTR {}", dtr);
    }
}
