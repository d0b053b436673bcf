//! Pin-map glue: expands a `boards/*.rs` table into configured embassy drivers (the chosen table
//! itself is `main.rs`'s `pin_table` module).
//!
//! `gantry_board!` is invoked by the board file chosen with the `board-*` feature (see `main.rs`);
//! `gantry_boards::board_table!` reads the table (the same reader as the host check in
//! `boards/src/host.rs`) and hands it to `expand_board!` here, which produces the board's
//! constants (name, clocks, step/dir pin numbers) and `split()`, which moves every listed pin out
//! of `Peripherals` into a driver in its power-up state: outputs off, steppers disabled. (Why the
//! host check has its own expander: the doc of `board_table!` in `boards/src/table.rs`.) A pin listed twice fails to compile (use of a moved field), and a wrong EXTI channel,
//! a non-ADC1 analog pin or a step/dir pin on a second port fail too.

use embassy_stm32::pac;

/// Pins, clock numbers and the table reader are the boards crate's (shared with the host check).
pub use gantry_boards::{same_port, Clocks, Pin as PinId};

/// The pin named `name` (`"PB12"`); fails const evaluation on anything else.
pub const fn pin(name: &str) -> PinId {
    match PinId::parse(name) {
        Some(p) => p,
        None => panic!("pin name is P<port><0..15>"),
    }
}

/// GPIO register block of a port index (ports A-E exist on every supported chip).
pub const fn gpio_block(port: u8) -> pac::gpio::Gpio {
    match port {
        0 => pac::GPIOA,
        1 => pac::GPIOB,
        2 => pac::GPIOC,
        3 => pac::GPIOD,
        4 => pac::GPIOE,
        _ => panic!("step/dir port must be one of A-E"),
    }
}

/// BSRR words (ports A-E) that put `low` pins low and `high` pins high: one register write per
/// port reaches the safe output state from any context (the panic handler).
pub const fn safe_bsrr(low: &[PinId], high: &[PinId]) -> [u32; 5] {
    let mut words = [0u32; 5];
    let mut i = 0;
    while i < low.len() {
        assert!(low[i].port < 5, "outputs on ports A-E");
        words[low[i].port as usize] |= low[i].mask() << 16;
        i += 1;
    }
    let mut i = 0;
    while i < high.len() {
        assert!(high[i].port < 5, "outputs on ports A-E");
        words[high[i].port as usize] |= high[i].mask();
        i += 1;
    }
    words
}

embassy_stm32::bind_interrupts!(
    /// Interrupts serviced by embassy drivers (priorities are lowered in `main`).
    pub struct Irqs {
        OTG_FS => embassy_stm32::usb::InterruptHandler<embassy_stm32::peripherals::USB_OTG_FS>;
        FLASH => embassy_stm32::flash::InterruptHandler;
        EXTI0 => embassy_stm32::exti::InterruptHandler<embassy_stm32::interrupt::typelevel::EXTI0>;
        EXTI1 => embassy_stm32::exti::InterruptHandler<embassy_stm32::interrupt::typelevel::EXTI1>;
        EXTI2 => embassy_stm32::exti::InterruptHandler<embassy_stm32::interrupt::typelevel::EXTI2>;
        EXTI3 => embassy_stm32::exti::InterruptHandler<embassy_stm32::interrupt::typelevel::EXTI3>;
        EXTI4 => embassy_stm32::exti::InterruptHandler<embassy_stm32::interrupt::typelevel::EXTI4>;
        EXTI9_5 => embassy_stm32::exti::InterruptHandler<embassy_stm32::interrupt::typelevel::EXTI9_5>;
        EXTI15_10 => embassy_stm32::exti::InterruptHandler<embassy_stm32::interrupt::typelevel::EXTI15_10>;
    }
);

/// The timer peripheral type of a spindle PWM channel token (`TIM1_CH1` → `TIM1`).
macro_rules! pwm_timer {
    (TIM1_CH1) => {
        embassy_stm32::peripherals::TIM1
    };
    (TIM1_CH2) => {
        embassy_stm32::peripherals::TIM1
    };
    (TIM1_CH3) => {
        embassy_stm32::peripherals::TIM1
    };
    (TIM1_CH4) => {
        embassy_stm32::peripherals::TIM1
    };
    (TIM3_CH1) => {
        embassy_stm32::peripherals::TIM3
    };
    (TIM3_CH2) => {
        embassy_stm32::peripherals::TIM3
    };
    (TIM3_CH3) => {
        embassy_stm32::peripherals::TIM3
    };
    (TIM3_CH4) => {
        embassy_stm32::peripherals::TIM3
    };
}

/// Spindle PWM at [`SPINDLE_PWM_HZ`] on the board's timer channel, duty 0, channel enabled.
macro_rules! pwm_channel {
    ($p:ident, $pin:ident, $tim:ident, $ch:ident, $slot:tt) => {{
        use embassy_stm32::gpio::OutputType;
        use embassy_stm32::timer::low_level::CountingMode;
        use embassy_stm32::timer::simple_pwm::{PwmPin, SimplePwm};
        let pin = Some(PwmPin::new($p.$pin, OutputType::PushPull));
        let pwm = pwm_channel!(@new $p, $tim, pin, $slot);
        let mut ch = pwm.split().$ch;
        ch.set_duty_cycle_fully_off();
        ch.enable();
        ch
    }};
    (@new $p:ident, $tim:ident, $pin:ident, 1) => {
        SimplePwm::new($p.$tim, $pin, None, None, None, embassy_stm32::time::Hertz($crate::pin_map::SPINDLE_PWM_HZ), CountingMode::EdgeAlignedUp)
    };
    (@new $p:ident, $tim:ident, $pin:ident, 2) => {
        SimplePwm::new($p.$tim, None, $pin, None, None, embassy_stm32::time::Hertz($crate::pin_map::SPINDLE_PWM_HZ), CountingMode::EdgeAlignedUp)
    };
    (@new $p:ident, $tim:ident, $pin:ident, 3) => {
        SimplePwm::new($p.$tim, None, None, $pin, None, embassy_stm32::time::Hertz($crate::pin_map::SPINDLE_PWM_HZ), CountingMode::EdgeAlignedUp)
    };
    (@new $p:ident, $tim:ident, $pin:ident, 4) => {
        SimplePwm::new($p.$tim, None, None, None, $pin, embassy_stm32::time::Hertz($crate::pin_map::SPINDLE_PWM_HZ), CountingMode::EdgeAlignedUp)
    };
}

/// Builds the spindle PWM channel from the board table's channel token.
macro_rules! spindle_pwm {
    ($p:ident, $pin:ident, TIM1_CH1) => {
        pwm_channel!($p, $pin, TIM1, ch1, 1)
    };
    ($p:ident, $pin:ident, TIM1_CH2) => {
        pwm_channel!($p, $pin, TIM1, ch2, 2)
    };
    ($p:ident, $pin:ident, TIM1_CH3) => {
        pwm_channel!($p, $pin, TIM1, ch3, 3)
    };
    ($p:ident, $pin:ident, TIM1_CH4) => {
        pwm_channel!($p, $pin, TIM1, ch4, 4)
    };
    ($p:ident, $pin:ident, TIM3_CH1) => {
        pwm_channel!($p, $pin, TIM3, ch1, 1)
    };
    ($p:ident, $pin:ident, TIM3_CH2) => {
        pwm_channel!($p, $pin, TIM3, ch2, 2)
    };
    ($p:ident, $pin:ident, TIM3_CH3) => {
        pwm_channel!($p, $pin, TIM3, ch3, 3)
    };
    ($p:ident, $pin:ident, TIM3_CH4) => {
        pwm_channel!($p, $pin, TIM3, ch4, 4)
    };
}

/// The spindle PWM's timer registers and channel index from the board table's channel token
/// (laser mode: the step interrupt writes the compare register itself).
macro_rules! spindle_timer {
    (TIM1_CH1) => {
        (embassy_stm32::pac::TIM1, 0usize)
    };
    (TIM1_CH2) => {
        (embassy_stm32::pac::TIM1, 1usize)
    };
    (TIM1_CH3) => {
        (embassy_stm32::pac::TIM1, 2usize)
    };
    (TIM1_CH4) => {
        (embassy_stm32::pac::TIM1, 3usize)
    };
    (TIM3_CH1) => {
        (embassy_stm32::pac::TIM3, 0usize)
    };
    (TIM3_CH2) => {
        (embassy_stm32::pac::TIM3, 1usize)
    };
    (TIM3_CH3) => {
        (embassy_stm32::pac::TIM3, 2usize)
    };
    (TIM3_CH4) => {
        (embassy_stm32::pac::TIM3, 3usize)
    };
}

/// Spindle PWM frequency (VFD 0-10 V converters and laser drivers take 1 kHz).
pub const SPINDLE_PWM_HZ: u32 = 1_000;

/// The board files call `gantry_board!`: read by `gantry_boards::board_table!`, expanded by
/// [`expand_board!`].
macro_rules! gantry_board {
    ($($table:tt)*) => {
        gantry_boards::board_table!(expand_board; $($table)*);
    };
}

/// Expands a board table, as `board_table!` hands it over, into constants, driver structs and
/// `split()`.
macro_rules! expand_board {
    (
        name: $name:literal,
        probe_chip: $chip:literal,
        clocks: $clocks:expr,
        step: [$($step:ident),+],
        dir: [$($dir:ident),+],
        stepper_enable: $en:ident,
        limit: [$($lim:ident $lim_ch:ident),+],
        limit_max: [$($limx:ident $limx_ch:ident),*],
        feed_hold: $hold:ident $hold_ch:ident,
        abort: $abort:ident $abort_ch:ident,
        cycle_start: [$cs1:ident $cs1_ch:ident, $cs2:ident $cs2_ch:ident],
        fro_pot: $fro:ident,
        joystick_axes: [$jx:ident, $jy:ident],
        joystick_switches: [$($jsw:ident),*],
        probe: $probe:ident,
        torch_inputs: [$($torch:ident),*],
        spindle_enable: $sp_en:ident,
        spindle_dir: $sp_dir:ident,
        spindle_pwm: $sp_pwm:ident $sp_pwm_ch:ident,
        coolant_flood: $flood:ident,
        coolant_mist: $mist:ident,
        outputs: [$($out:ident),+],
    ) => {
        use embassy_stm32::adc::{AdcChannel as _, AnyAdcChannel};
        use embassy_stm32::exti::ExtiInput;
        use embassy_stm32::gpio::{Input, Level, Output, Pull, Speed};
        use embassy_stm32::mode::Async;
        use embassy_stm32::{peripherals, Peri};
        use $crate::pin_map::PinId;

        /// Board name (as in boards/README.md).
        pub const NAME: &str = $name;
        /// probe-rs chip name for flashing.
        pub const PROBE_CHIP: &str = $chip;
        /// Clock tree numbers.
        pub const CLOCKS: $crate::pin_map::Clocks = $clocks;
        /// Number of stepper axes wired (X Y Z A ... order).
        pub const AXES: usize = [$(stringify!($step)),+].len();
        /// Step pins, axis order.
        pub const STEP: [PinId; AXES] = [$($crate::pin_map::pin(stringify!($step))),+];
        /// Dir pins, axis order.
        pub const DIR: [PinId; AXES] = [$($crate::pin_map::pin(stringify!($dir))),+];
        /// Number of user outputs.
        pub const USER_OUTPUTS: usize = [$(stringify!($out)),+].len();
        /// User output pins, output 0 first (the step ISR switches them by register for the
        /// on-the-fly events).
        pub const USER_PINS: [PinId; USER_OUTPUTS] = [$($crate::pin_map::pin(stringify!($out))),+];
        /// Outputs that are low in the safe state: spindle enable/dir/PWM, coolant, user outputs.
        pub const SAFE_LOW: [PinId; 5 + USER_OUTPUTS] = [
            $crate::pin_map::pin(stringify!($sp_en)),
            $crate::pin_map::pin(stringify!($sp_dir)),
            $crate::pin_map::pin(stringify!($sp_pwm)),
            $crate::pin_map::pin(stringify!($flood)),
            $crate::pin_map::pin(stringify!($mist)),
            $($crate::pin_map::pin(stringify!($out))),+
        ];
        /// Laser mode: sets the spindle PWM's compare register to `duty` timer counts (one
        /// store; the step interrupt's `write_power`, docs/laser-plasma.md).
        #[inline(always)]
        pub fn spindle_pwm_compare(duty: u16) {
            let (tim, ch) = spindle_timer!($sp_pwm_ch);
            tim.ccr(ch)
                .write_value(embassy_stm32::pac::timer::regs::Ccr1ch(u32::from(duty)));
        }

        /// Laser mode: makes the spindle PWM's period `counts` timer counts (the setup's
        /// `pwm_range[1]`, so a duty count is a compare count) at about
        /// [`SPINDLE_PWM_HZ`](crate::pin_map::SPINDLE_PWM_HZ), keeping its timer clock (read
        /// back from the prescaler and period set for that frequency at start-up). Nothing is
        /// written when the period is that already.
        pub fn spindle_pwm_period(counts: u16) {
            let (tim, _) = spindle_timer!($sp_pwm_ch);
            let counts = u32::from(counts.max(2));
            let (psc, arr) = (u32::from(tim.psc().read()), tim.arr().read().0);
            if arr + 1 == counts {
                return;
            }
            let hz = $crate::pin_map::SPINDLE_PWM_HZ;
            let clock = hz * (psc + 1) * (arr + 1);
            let psc = (clock / (hz * counts)).clamp(1, 65_536) - 1;
            tim.psc().write_value(psc as u16);
            tim.arr()
                .write_value(embassy_stm32::pac::timer::regs::ArrCore(counts - 1));
        }

        /// Touch probe input (pull-up, the probe closes to ground): the step interrupt reads
        /// its pin every tick (`step::PROBE_GPIO`), the input task samples it for the status.
        pub const PROBE: PinId = $crate::pin_map::pin(stringify!($probe));
        /// Stepper enable pin (active low: high = steppers disabled, the safe state).
        pub const STEPPER_ENABLE: PinId = $crate::pin_map::pin(stringify!($en));

        const _: () = assert!(AXES <= 6, "the step tables cover 6 axes");
        const _: () = assert!($crate::pin_map::same_port(&STEP), "step pins must share one port");
        const _: () = assert!($crate::pin_map::same_port(&DIR), "dir pins must share one port");
        const _: () = assert!(USER_OUTPUTS >= 4, "at least four user outputs");
        const _: () = assert!(USER_OUTPUTS <= 16, "the core switches at most 16 user outputs");
        const _: () = assert!(
            LIMIT_MAX_INPUTS == 0 || LIMIT_MAX_INPUTS == AXES,
            "limit_max lists one input per axis, or is left out"
        );

        /// Index in [`Inputs::exti`] of the first limit input: one per axis, axis order; the min
        /// switch, or min and max wired together when the board has no `limit_max` inputs.
        pub const LIMIT0: usize = 0;
        /// Index in [`Inputs::exti`] of the feed hold input.
        pub const FEED_HOLD: usize = AXES;
        /// Index in [`Inputs::exti`] of the abort input.
        pub const ABORT: usize = AXES + 1;
        /// Index in [`Inputs::exti`] of the first of the two cycle start inputs.
        pub const CYCLE_START0: usize = AXES + 2;
        /// Index in [`Inputs::exti`] of the first separate max-limit input (if any).
        pub const LIMIT_MAX0: usize = AXES + 4;
        /// Number of separate max-limit inputs: 0 or one per axis.
        pub const LIMIT_MAX_INPUTS: usize = <[&str]>::len(&[$(stringify!($limx)),*]);
        /// Number of EXTI inputs.
        pub const EXTI_INPUTS: usize = AXES + 4 + LIMIT_MAX_INPUTS;
        /// Number of joystick switches.
        pub const JOYSTICK_SWITCHES: usize = <[&str]>::len(&[$(stringify!($jsw)),*]);
        /// Number of plasma torch inputs (arc-OK, THC up, THC down; 0 or 3).
        pub const TORCH_INPUTS: usize = <[&str]>::len(&[$(stringify!($torch)),*]);
        const _: () = assert!(
            TORCH_INPUTS == 0 || TORCH_INPUTS == 3,
            "torch_inputs lists arc-OK, THC up and THC down, or nothing"
        );

        /// Every input of the board, configured with pull-ups (switches close to ground).
        pub struct Inputs {
            /// Limits, feed hold, abort, cycle start ×2, max limits (see [`LIMIT0`] and friends).
            pub exti: [ExtiInput<'static, Async>; EXTI_INPUTS],
            pub joystick_switches: [Input<'static>; JOYSTICK_SWITCHES],
            pub probe: Input<'static>,
            /// Plasma: arc-OK, THC up, THC down (polled; docs/laser-plasma.md "Wiring").
            pub torch: [Input<'static>; TORCH_INPUTS],
        }

        /// Analog inputs on ADC1.
        pub struct Analog {
            pub fro_pot: AnyAdcChannel<'static, peripherals::ADC1>,
            pub joystick: [AnyAdcChannel<'static, peripherals::ADC1>; 2],
        }

        /// Every output of the board except step/dir (which the step ISR drives by register).
        pub struct Outputs {
            /// Stepper driver enable, active low: starts high (steppers disabled). The main loop
            /// enables the drivers with the first motion; a stop leaves them on (holding torque).
            pub stepper_enable: Output<'static>,
            pub spindle_enable: Output<'static>,
            pub spindle_dir: Output<'static>,
            /// Spindle speed: PWM at `SPINDLE_PWM_HZ`, duty 0 at power-up.
            pub spindle_pwm: embassy_stm32::timer::simple_pwm::SimplePwmChannel<'static, pwm_timer!($sp_pwm_ch)>,
            pub coolant_flood: Output<'static>,
            pub coolant_mist: Output<'static>,
            /// User outputs, low; kept so the pins stay configured. They are driven by register
            /// writes only (`step`: on-the-fly events in the step ISR, and `sync_user_outputs`),
            /// never through these drivers, so no main-loop write can undo an ISR write.
            #[allow(dead_code)]
            pub user: [Output<'static>; USER_OUTPUTS],
        }

        /// The board's pins as configured drivers.
        pub struct Pins {
            /// Step then dir outputs, low; kept only so the pins stay configured.
            pub step_dir: [Output<'static>; 2 * AXES],
            pub inputs: Inputs,
            pub analog: Analog,
            pub outputs: Outputs,
        }

        /// Peripherals the firmware uses besides the board's pins.
        pub struct Rest {
            pub usb: Peri<'static, peripherals::USB_OTG_FS>,
            pub usb_dp: Peri<'static, peripherals::PA12>,
            pub usb_dm: Peri<'static, peripherals::PA11>,
            pub tim2: Peri<'static, peripherals::TIM2>,
            /// DMA1 streams 1, 5 and 6: TIM2's update, compare 1 and compare 2 requests make the
            /// step pulses (`step_dma.rs`).
            pub step_dma: $crate::step_dma::StepDma,
            pub adc1: Peri<'static, peripherals::ADC1>,
            pub flash: Peri<'static, peripherals::FLASH>,
        }

        /// Moves the board's pins out of `p` into drivers in their power-up state.
        pub fn split(p: embassy_stm32::Peripherals) -> (Pins, Rest) {
            // Step/dir edges fast; everything else slow (less EMI, and PC13-PC15 allow 2 MHz only).
            let fast = |pin: Peri<'static, embassy_stm32::gpio::AnyPin>| {
                Output::new(pin, Level::Low, Speed::VeryHigh)
            };
            let out = |pin: Peri<'static, embassy_stm32::gpio::AnyPin>, level| {
                Output::new(pin, level, Speed::Low)
            };
            let irqs = $crate::pin_map::Irqs;
            let pins = Pins {
                step_dir: [
                    $(fast(p.$step.into()),)+
                    $(fast(p.$dir.into()),)+
                ],
                inputs: Inputs {
                    exti: [
                        $(ExtiInput::new(p.$lim, p.$lim_ch, Pull::Up, irqs),)+
                        ExtiInput::new(p.$hold, p.$hold_ch, Pull::Up, irqs),
                        ExtiInput::new(p.$abort, p.$abort_ch, Pull::Up, irqs),
                        ExtiInput::new(p.$cs1, p.$cs1_ch, Pull::Up, irqs),
                        ExtiInput::new(p.$cs2, p.$cs2_ch, Pull::Up, irqs),
                        $(ExtiInput::new(p.$limx, p.$limx_ch, Pull::Up, irqs),)*
                    ],
                    joystick_switches: [$(Input::new(p.$jsw, Pull::Up)),*],
                    probe: Input::new(p.$probe, Pull::Up),
                    torch: [$(Input::new(p.$torch, Pull::Up)),*],
                },
                analog: Analog {
                    fro_pot: p.$fro.degrade_adc(),
                    joystick: [p.$jx.degrade_adc(), p.$jy.degrade_adc()],
                },
                outputs: Outputs {
                    stepper_enable: out(p.$en.into(), Level::High),
                    spindle_enable: out(p.$sp_en.into(), Level::Low),
                    spindle_dir: out(p.$sp_dir.into(), Level::Low),
                    spindle_pwm: spindle_pwm!(p, $sp_pwm, $sp_pwm_ch),
                    coolant_flood: out(p.$flood.into(), Level::Low),
                    coolant_mist: out(p.$mist.into(), Level::Low),
                    user: [$(out(p.$out.into(), Level::Low)),+],
                },
            };
            let rest = Rest {
                usb: p.USB_OTG_FS,
                usb_dp: p.PA12,
                usb_dm: p.PA11,
                tim2: p.TIM2,
                step_dma: $crate::step_dma::StepDma {
                    update: p.DMA1_CH1,
                    pulse_end: p.DMA1_CH5,
                    clear: p.DMA1_CH6,
                },
                adc1: p.ADC1,
                flash: p.FLASH,
            };
            (pins, rest)
        }
    };
}
