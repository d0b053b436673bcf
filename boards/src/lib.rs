//! Host-side reading of the board tables in `boards/*.rs`.
//!
//! The firmware expands each board file's `gantry_board!` invocation into embassy peripherals; this
//! crate expands the very same file into plain data ([`Board`]) so tests can check the table on
//! the host: no pin used twice, step pins on one port, dir pins on one port, EXTI channels matching
//! their pins and distinct, analog roles on ADC1 pins, reserved pins untouched, and clocks that
//! give exactly 48 MHz USB and a TIM2 clock within limits.

/// A GPIO pin such as `PB12`: port index (A = 0) and pin number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Pin {
    pub port: u8,
    pub pin: u8,
}

impl Pin {
    /// Parses an embassy pin name (`"PB12"`); `None` if it is not one.
    pub fn parse(name: &str) -> Option<Pin> {
        let b = name.as_bytes();
        if b.len() < 3 || b.len() > 4 || b[0] != b'P' || !(b'A'..=b'K').contains(&b[1]) {
            return None;
        }
        let pin: u8 = name[2..].parse().ok()?;
        (pin < 16).then_some(Pin {
            port: b[1] - b'A',
            pin,
        })
    }
}

impl core::fmt::Display for Pin {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "P{}{}", (b'A' + self.port) as char, self.pin)
    }
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
    pub fn vco_hz(&self) -> u32 {
        self.hse_hz / self.pll_m * self.pll_n
    }
    /// SYSCLK (= HCLK, AHB /1).
    pub fn sysclk_hz(&self) -> u32 {
        self.vco_hz() / self.pll_p
    }
    /// The 48 MHz domain (USB OTG FS) from PLL Q.
    pub fn usb_hz(&self) -> u32 {
        self.vco_hz() / self.pll_q
    }
    /// APB1 peripheral clock.
    pub fn pclk1_hz(&self) -> u32 {
        self.sysclk_hz() / self.apb1_div
    }
    /// Clock of the APB1 timers (TIM2 steps, TIM4 is embassy's time driver): ×2 unless APB1 is /1.
    pub fn tim_apb1_hz(&self) -> u32 {
        if self.apb1_div == 1 {
            self.pclk1_hz()
        } else {
            2 * self.pclk1_hz()
        }
    }
}

/// One board table, as plain data.
#[derive(Clone, Debug)]
pub struct Board {
    pub name: &'static str,
    pub probe_chip: &'static str,
    pub clocks: Clocks,
    pub step: Vec<&'static str>,
    pub dir: Vec<&'static str>,
    pub stepper_enable: &'static str,
    /// EXTI inputs as (role, pin, EXTI channel name).
    pub exti_inputs: Vec<(&'static str, &'static str, &'static str)>,
    pub analog: Vec<(&'static str, &'static str)>,
    pub joystick_switches: Vec<&'static str>,
    pub spindle_pwm: (&'static str, &'static str),
    /// Plain outputs as (role, pin).
    pub outputs: Vec<(&'static str, &'static str)>,
}

impl Board {
    /// Every (role, pin name) of the table, in table order.
    pub fn roles(&self) -> Vec<(String, &'static str)> {
        let mut v = Vec::new();
        for (i, p) in self.step.iter().enumerate() {
            v.push((format!("step{i}"), *p));
        }
        for (i, p) in self.dir.iter().enumerate() {
            v.push((format!("dir{i}"), *p));
        }
        v.push(("stepper_enable".into(), self.stepper_enable));
        for (role, p, _) in &self.exti_inputs {
            v.push(((*role).into(), *p));
        }
        for (role, p) in &self.analog {
            v.push(((*role).into(), *p));
        }
        for (i, p) in self.joystick_switches.iter().enumerate() {
            v.push((format!("joystick_switch{i}"), *p));
        }
        v.push(("spindle_pwm".into(), self.spindle_pwm.0));
        for (role, p) in &self.outputs {
            v.push(((*role).into(), *p));
        }
        v
    }
}

/// Expands a board file into a `pub fn board() -> Board`.
macro_rules! gantry_board {
    (
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
        spindle_enable: $sp_en:ident,
        spindle_dir: $sp_dir:ident,
        spindle_pwm: $sp_pwm:ident $sp_pwm_ch:ident,
        coolant_flood: $flood:ident,
        coolant_mist: $mist:ident,
        outputs: [$($out:ident),+ $(,)?] $(,)?
    ) => {
        /// This board's table as plain data.
        pub fn board() -> $crate::Board {
            let mut exti_inputs = vec![$(("limit", stringify!($lim), stringify!($lim_ch))),+];
            exti_inputs.push(("feed_hold", stringify!($hold), stringify!($hold_ch)));
            exti_inputs.push(("abort", stringify!($abort), stringify!($abort_ch)));
            exti_inputs.push(("cycle_start1", stringify!($cs1), stringify!($cs1_ch)));
            exti_inputs.push(("cycle_start2", stringify!($cs2), stringify!($cs2_ch)));
            $($(exti_inputs.push(("limit_max", stringify!($limx), stringify!($limx_ch)));)+)?
            let mut outputs = vec![
                ("spindle_enable", stringify!($sp_en)),
                ("spindle_dir", stringify!($sp_dir)),
                ("coolant_flood", stringify!($flood)),
                ("coolant_mist", stringify!($mist)),
            ];
            $(outputs.push(("user_output", stringify!($out)));)+
            $crate::Board {
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
                step: vec![$(stringify!($step)),+],
                dir: vec![$(stringify!($dir)),+],
                stepper_enable: stringify!($en),
                exti_inputs,
                analog: vec![
                    ("fro_pot", stringify!($fro)),
                    ("joystick_x", stringify!($jx)),
                    ("joystick_y", stringify!($jy)),
                ],
                joystick_switches: vec![$(stringify!($jsw)),*],
                spindle_pwm: (stringify!($sp_pwm), stringify!($sp_pwm_ch)),
                outputs,
            }
        }
    };
}

#[path = "../blackpill_f411.rs"]
pub mod blackpill_f411;
#[path = "../nucleo_f446.rs"]
pub mod nucleo_f446;

/// Every board table.
pub fn boards() -> Vec<Board> {
    vec![blackpill_f411::board(), nucleo_f446::board()]
}

#[cfg(test)]
mod tests;
