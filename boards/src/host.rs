//! The board tables as plain data ([`PinMap`]) for the host checks (`tests.rs`).

extern crate std;

use crate::Clocks;
use std::string::String;
use std::vec::Vec;
use std::{format, vec};

/// One board table's pin map (pins by role, clocks), as plain data.
#[derive(Clone, Debug)]
pub struct PinMap {
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
    /// Touch probe input (G38.x; polled, and read by the step interrupt every tick).
    pub probe: &'static str,
    /// Plasma torch inputs: arc-OK, THC up, THC down (polled; none on a board without pins).
    pub torch_inputs: Vec<&'static str>,
    pub spindle_pwm: (&'static str, &'static str),
    /// Plain outputs as (role, pin).
    pub outputs: Vec<(&'static str, &'static str)>,
}

impl PinMap {
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
        v.push(("probe".into(), self.probe));
        for (role, p) in ["arc_ok", "thc_up", "thc_down"]
            .iter()
            .zip(&self.torch_inputs)
        {
            v.push(((*role).into(), *p));
        }
        v.push(("spindle_pwm".into(), self.spindle_pwm.0));
        for (role, p) in &self.outputs {
            v.push(((*role).into(), *p));
        }
        v
    }
}

/// The board files call `gantry_board!`: read by [`board_table!`], expanded by
/// [`expand_board!`].
macro_rules! gantry_board {
    ($($table:tt)*) => {
        $crate::board_table!(expand_board; $($table)*);
    };
}

/// Expands a board table, as [`board_table!`] hands it over, into a `pub fn pin_map() -> PinMap`.
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
        /// This board's table as plain data.
        pub fn pin_map() -> $crate::PinMap {
            let mut exti_inputs = vec![$(("limit", stringify!($lim), stringify!($lim_ch))),+];
            exti_inputs.push(("feed_hold", stringify!($hold), stringify!($hold_ch)));
            exti_inputs.push(("abort", stringify!($abort), stringify!($abort_ch)));
            exti_inputs.push(("cycle_start1", stringify!($cs1), stringify!($cs1_ch)));
            exti_inputs.push(("cycle_start2", stringify!($cs2), stringify!($cs2_ch)));
            $(exti_inputs.push(("limit_max", stringify!($limx), stringify!($limx_ch)));)*
            let mut outputs = vec![
                ("spindle_enable", stringify!($sp_en)),
                ("spindle_dir", stringify!($sp_dir)),
                ("coolant_flood", stringify!($flood)),
                ("coolant_mist", stringify!($mist)),
            ];
            $(outputs.push(("user_output", stringify!($out)));)+
            $crate::PinMap {
                name: $name,
                probe_chip: $chip,
                clocks: $clocks,
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
                probe: stringify!($probe),
                torch_inputs: vec![$(stringify!($torch)),*],
                spindle_pwm: (stringify!($sp_pwm), stringify!($sp_pwm_ch)),
                outputs,
            }
        }
    };
}

#[path = "../blackpill_f411.rs"]
pub mod blackpill_f411;
#[path = "../blackpill_f411_plasma.rs"]
pub mod blackpill_f411_plasma;
#[path = "../nucleo_f446.rs"]
pub mod nucleo_f446;

/// Every board table's pin map.
pub fn pin_maps() -> Vec<PinMap> {
    vec![
        blackpill_f411::pin_map(),
        blackpill_f411_plasma::pin_map(),
        nucleo_f446::pin_map(),
    ]
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
