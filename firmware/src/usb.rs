//! USB OTG FS device: one CDC-ACM port ("Gantry CNC controller") carrying the host link.
//!
//! For now the link task echoes what it receives; the framed protocol (gantry-proto) replaces the
//! echo later. The USB interrupt runs below the step timer (see `main`).

use crate::board::Irqs;
use embassy_stm32::peripherals::{PA11, PA12, USB_OTG_FS};
use embassy_stm32::usb::Driver;
use embassy_stm32::Peri;
use embassy_usb::class::cdc_acm::{CdcAcmClass, State};
use embassy_usb::driver::EndpointError;
use embassy_usb::{Builder, UsbDevice};
use static_cell::StaticCell;

/// The OTG FS driver type.
pub type UsbDriver = Driver<'static, USB_OTG_FS>;

/// pid.codes test VID/PID; replace with an allocated PID before anything ships.
const VID: u16 = 0x1209;
const PID: u16 = 0x0001;
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

/// Link task: echoes packets until the protocol lands.
#[embassy_executor::task]
pub async fn run_link(mut class: CdcAcmClass<'static, UsbDriver>) -> ! {
    let mut buf = [0u8; PACKET as usize];
    loop {
        class.wait_connection().await;
        defmt::info!("host connected");
        while let Ok(n) = echo(&mut class, &mut buf).await {
            defmt::trace!("echoed {} bytes", n);
        }
        defmt::info!("host disconnected");
    }
}

async fn echo(
    class: &mut CdcAcmClass<'static, UsbDriver>,
    buf: &mut [u8],
) -> Result<usize, EndpointError> {
    let n = class.read_packet(buf).await?;
    class.write_packet(&buf[..n]).await?;
    Ok(n)
}
