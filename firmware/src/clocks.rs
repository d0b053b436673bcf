//! Clock configuration: the board's clock numbers turned into embassy's RCC config.
//!
//! The numbers come from the board file; the conversions run in const context, so a value the
//! hardware cannot take fails the build. The step timer's prescaler is derived here too: TIM2 must
//! count at exactly the step kernel's `KERNEL_TIMER_HZ`.

use crate::pin_table::CLOCKS;
use embassy_stm32::rcc::{
    mux, AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv,
    PllSource, Sysclk,
};
use embassy_stm32::time::Hertz;
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;

const fn pll_m(m: u32) -> PllPreDiv {
    assert!(m >= 2 && m <= 63, "PLL M is 2..=63");
    PllPreDiv::from_bits(m as u8)
}

const fn pll_n(n: u32) -> PllMul {
    assert!(n >= 50 && n <= 432, "PLL N is 50..=432");
    PllMul::from_bits(n as u16)
}

const fn pll_p(p: u32) -> PllPDiv {
    assert!(
        p == 2 || p == 4 || p == 6 || p == 8,
        "PLL P is 2, 4, 6 or 8"
    );
    PllPDiv::from_bits((p / 2 - 1) as u8)
}

const fn pll_q(q: u32) -> PllQDiv {
    assert!(q >= 2 && q <= 15, "PLL Q is 2..=15");
    PllQDiv::from_bits(q as u8)
}

const fn apb(div: u32) -> APBPrescaler {
    match div {
        1 => APBPrescaler::DIV1,
        2 => APBPrescaler::DIV2,
        4 => APBPrescaler::DIV4,
        8 => APBPrescaler::DIV8,
        16 => APBPrescaler::DIV16,
        _ => panic!("APB divider is 1, 2, 4, 8 or 16"),
    }
}

const PLL: Pll = Pll {
    prediv: pll_m(CLOCKS.pll_m),
    mul: pll_n(CLOCKS.pll_n),
    divp: Some(pll_p(CLOCKS.pll_p)),
    divq: Some(pll_q(CLOCKS.pll_q)),
    divr: None,
};
const APB1: APBPrescaler = apb(CLOCKS.apb1_div);
const APB2: APBPrescaler = apb(CLOCKS.apb2_div);

const _: () = assert!(
    CLOCKS.hse_hz / CLOCKS.pll_m * CLOCKS.pll_n / CLOCKS.pll_q == 48_000_000,
    "USB needs exactly 48 MHz from PLL Q"
);
const _: () = assert!(
    CLOCKS.tim_apb1_hz().is_multiple_of(KERNEL_TIMER_HZ),
    "TIM2's clock must be a whole multiple of the step kernel's KERNEL_TIMER_HZ"
);

/// TIM2 prescaler register value: TIM2 then counts at `KERNEL_TIMER_HZ`.
pub const TIM2_PSC: u16 = (CLOCKS.tim_apb1_hz() / KERNEL_TIMER_HZ - 1) as u16;

/// SYSCLK in Hz, for the boot log.
pub const SYSCLK_HZ: u32 = CLOCKS.sysclk_hz();

/// embassy config: HSE → PLL → SYSCLK, USB 48 MHz from PLL Q; DMA interrupts below the step timer.
pub fn config() -> embassy_stm32::Config {
    let mut config = embassy_stm32::Config::default();
    // embassy defaults DMA interrupts to P0, which belongs to the step timer alone.
    config.dma_interrupt_priority = embassy_stm32::interrupt::Priority::P2;
    let rcc = &mut config.rcc;
    rcc.hse = Some(Hse {
        freq: Hertz(CLOCKS.hse_hz),
        mode: if CLOCKS.hse_bypass {
            HseMode::Bypass
        } else {
            HseMode::Oscillator
        },
    });
    rcc.pll_src = PllSource::HSE;
    rcc.pll = Some(PLL);
    rcc.sys = Sysclk::PLL1_P;
    rcc.ahb_pre = AHBPrescaler::DIV1;
    rcc.apb1_pre = APB1;
    rcc.apb2_pre = APB2;
    rcc.mux.clk48sel = mux::Clk48sel::PLL1_Q;
    config
}
