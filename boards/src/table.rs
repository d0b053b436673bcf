//! What the firmware and the host check share (no_std): pins, clock numbers, and
//! [`board_table!`], the one reader of the board files' `gantry_board!` grammar.

/// A GPIO pin such as `PB12`: port index (A = 0) and pin number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Pin {
    pub port: u8,
    pub pin: u8,
}

impl Pin {
    /// Parses an embassy pin name (`"PB12"`); `None` if it is not one. A `const fn`, so the
    /// firmware parses its tables at compile time.
    pub const fn parse(name: &str) -> Option<Pin> {
        let b = name.as_bytes();
        if b.len() < 3 || b.len() > 4 || b[0] != b'P' || b[1] < b'A' || b[1] > b'K' {
            return None;
        }
        let mut pin = 0u8;
        let mut i = 2;
        while i < b.len() {
            if !b[i].is_ascii_digit() {
                return None;
            }
            pin = pin * 10 + (b[i] - b'0');
            i += 1;
        }
        if pin >= 16 {
            return None;
        }
        Some(Pin {
            port: b[1] - b'A',
            pin,
        })
    }

    /// Single-bit mask of this pin in a 16-bit port.
    pub const fn mask(self) -> u32 {
        1 << self.pin
    }
}

impl core::fmt::Display for Pin {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "P{}{}", (b'A' + self.port) as char, self.pin)
    }
}

/// True if every pin of `pins` is on the port of the first one.
pub const fn same_port(pins: &[Pin]) -> bool {
    let mut i = 1;
    while i < pins.len() {
        if pins[i].port != pins[0].port {
            return false;
        }
        i += 1;
    }
    true
}

/// Clock tree numbers of a board (HSE → PLL → SYSCLK/USB, APB dividers).
#[derive(Clone, Copy, Debug)]
pub struct Clocks {
    pub hse_hz: u32,
    pub hse_bypass: bool,
    pub pll_m: u32,
    pub pll_n: u32,
    pub pll_p: u32,
    pub pll_q: u32,
    pub apb1_div: u32,
    pub apb2_div: u32,
}

impl Clocks {
    /// PLL VCO output frequency.
    pub const fn vco_hz(&self) -> u32 {
        self.hse_hz / self.pll_m * self.pll_n
    }
    /// SYSCLK (= HCLK, AHB /1).
    pub const fn sysclk_hz(&self) -> u32 {
        self.vco_hz() / self.pll_p
    }
    /// The 48 MHz domain (USB OTG FS) from PLL Q.
    pub const fn usb_hz(&self) -> u32 {
        self.vco_hz() / self.pll_q
    }
    /// APB1 peripheral clock.
    pub const fn pclk1_hz(&self) -> u32 {
        self.sysclk_hz() / self.apb1_div
    }
    /// Clock of the APB1 timers (TIM2 steps, TIM4 is embassy's time driver): ×2 unless APB1 is /1.
    pub const fn tim_apb1_hz(&self) -> u32 {
        if self.apb1_div == 1 {
            self.pclk1_hz()
        } else {
            2 * self.pclk1_hz()
        }
    }
}

/// Reads a board table (the body of a board file's `gantry_board! { .. }`, grammar in
/// boards/README.md) and hands it to the macro `$expand` in one fixed shape: every field in
/// table order, the clocks as a [`Clocks`] value, `limit_max` always present (empty when the
/// board has none). The firmware (`firmware/src/board.rs`) expands it into drivers, the host
/// check (`boards/src/host.rs`) into plain data; the grammar lives only here.
///
/// Why two expanders and not one: they share only the matcher of this normalised shape, their
/// outputs differ in kind. The firmware needs the pin *tokens*: `p.PB12` moves a field out of
/// embassy's `Peripherals` into a typed driver (so a pin listed twice is a compile error, a
/// use of a moved field), `p.EXTI4` must be the channel type of that pin, and `TIM1_CH1` picks a
/// timer type and a `SimplePwm` argument slot. The host check needs the same tokens as strings
/// in `std` vectors. Plain data from this crate (a `Pin` constant) cannot build the drivers: no
/// safe constructor turns a port and pin number back into a typed embassy pin (`AnyPin::steal`
/// is `unsafe` and loses the moved-field check). An expander generic over a callback macro is
/// what this macro already is (`$expand`), so a shared second layer would only pass the tokens
/// on once more.
#[macro_export]
macro_rules! board_table {
    (
        $($expand:ident)::+;
        name: $name:literal,
        probe_chip: $chip:literal,
        clocks: {
            hse_hz: $hse:expr,
            hse_bypass: $bypass:expr,
            pll_m: $m:expr,
            pll_n: $n:expr,
            pll_p: $p:expr,
            pll_q: $q:expr,
            apb1_div: $apb1:expr,
            apb2_div: $apb2:expr $(,)?
        },
        step: [$($step:ident),+ $(,)?],
        dir: [$($dir:ident),+ $(,)?],
        stepper_enable: $en:ident,
        limit: [$($lim:ident $lim_ch:ident),+ $(,)?],
        $(limit_max: [$($limx:ident $limx_ch:ident),+ $(,)?],)?
        feed_hold: $hold:ident $hold_ch:ident,
        abort: $abort:ident $abort_ch:ident,
        cycle_start: [$cs1:ident $cs1_ch:ident, $cs2:ident $cs2_ch:ident $(,)?],
        fro_pot: $fro:ident,
        joystick_axes: [$jx:ident, $jy:ident $(,)?],
        joystick_switches: [$($jsw:ident),* $(,)?],
        probe: $probe:ident,
        $(torch_inputs: [$($torch:ident),* $(,)?],)?
        spindle_enable: $sp_en:ident,
        spindle_dir: $sp_dir:ident,
        spindle_pwm: $sp_pwm:ident $sp_pwm_ch:ident,
        coolant_flood: $flood:ident,
        coolant_mist: $mist:ident,
        outputs: [$($out:ident),+ $(,)?] $(,)?
    ) => {
        $($expand)::+! {
            name: $name,
            probe_chip: $chip,
            clocks: $crate::Clocks {
                hse_hz: $hse,
                hse_bypass: $bypass,
                pll_m: $m,
                pll_n: $n,
                pll_p: $p,
                pll_q: $q,
                apb1_div: $apb1,
                apb2_div: $apb2,
            },
            step: [$($step),+],
            dir: [$($dir),+],
            stepper_enable: $en,
            limit: [$($lim $lim_ch),+],
            limit_max: [$($($limx $limx_ch),+)?],
            feed_hold: $hold $hold_ch,
            abort: $abort $abort_ch,
            cycle_start: [$cs1 $cs1_ch, $cs2 $cs2_ch],
            fro_pot: $fro,
            joystick_axes: [$jx, $jy],
            joystick_switches: [$($jsw),*],
            probe: $probe,
            torch_inputs: [$($($torch),*)?],
            spindle_enable: $sp_en,
            spindle_dir: $sp_dir,
            spindle_pwm: $sp_pwm $sp_pwm_ch,
            coolant_flood: $flood,
            coolant_mist: $mist,
            outputs: [$($out),+],
        }
    };
}
