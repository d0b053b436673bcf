//! Table checks run by `cargo test` in boards/.

use super::*;
use crate::Pin;
use std::collections::BTreeMap;

fn pin(name: &str) -> Pin {
    Pin::parse(name).unwrap_or_else(|| panic!("{name} is not a pin name"))
}

/// Pins no board may use: USB D-/D+, SWD, HSE.
const RESERVED: &[&str] = &["PA11", "PA12", "PA13", "PA14", "PH0", "PH1"];

/// Extra pins to leave alone, per board.
fn board_reserved(b: &PinMap) -> &'static [&'static str] {
    match b.name {
        // PB11 is not bonded on the F411 UFQFPN48.
        "blackpill-f411" | "blackpill-f411-plasma" => &["PB11"],
        // ST-LINK VCP, SWO, LSE crystal.
        "nucleo-f446" => &["PA2", "PA3", "PB3", "PC14", "PC15", "PB11"],
        other => panic!("unknown board {other}: add its reserved pins"),
    }
}

/// ADC1 channel of a pin on STM32F4 (PA0-7 → 0-7, PB0-1 → 8-9, PC0-5 → 10-15).
fn adc1_channel(p: Pin) -> Option<u8> {
    match (p.port, p.pin) {
        (0, n @ 0..=7) => Some(n),
        (1, n @ 0..=1) => Some(8 + n),
        (2, n @ 0..=5) => Some(10 + n),
        _ => None,
    }
}

/// Timer channels a spindle PWM may use (TIM2 is the step timer, TIM4 embassy's time driver).
const PWM_PINS: &[(&str, &str)] = &[
    ("PA8", "TIM1_CH1"),
    ("PA9", "TIM1_CH2"),
    ("PA10", "TIM1_CH3"),
    ("PA6", "TIM3_CH1"),
    ("PA7", "TIM3_CH2"),
    ("PB0", "TIM3_CH3"),
    ("PB1", "TIM3_CH4"),
    ("PB4", "TIM3_CH1"),
    ("PB5", "TIM3_CH2"),
];

#[test]
fn no_pin_is_used_twice_or_reserved() {
    for b in pin_maps() {
        let mut seen: BTreeMap<Pin, String> = BTreeMap::new();
        for (role, name) in b.roles() {
            let p = pin(name);
            assert!(
                !RESERVED.contains(&name) && !board_reserved(&b).contains(&name),
                "{}: {role} uses reserved pin {name}",
                b.name
            );
            if let Some(first) = seen.insert(p, role.clone()) {
                panic!("{}: {name} used by both {first} and {role}", b.name);
            }
        }
    }
}

#[test]
fn step_and_dir_pins_each_share_one_port() {
    for b in pin_maps() {
        assert!(
            !b.step.is_empty() && b.step.len() <= 6,
            "{}: 1..=6 axes",
            b.name
        );
        assert_eq!(b.step.len(), b.dir.len(), "{}: one dir per step", b.name);
        let limits = b.exti_inputs.iter().filter(|i| i.0 == "limit").count();
        assert_eq!(b.step.len(), limits, "{}: one limit input per axis", b.name);
        let max = b.exti_inputs.iter().filter(|i| i.0 == "limit_max").count();
        assert!(
            max == 0 || max == limits,
            "{}: limit_max is per axis or absent",
            b.name
        );
        for group in [&b.step, &b.dir] {
            let port = pin(group[0]).port;
            for name in group.iter() {
                assert_eq!(
                    pin(name).port,
                    port,
                    "{}: {name} is on another port",
                    b.name
                );
            }
        }
    }
}

#[test]
fn exti_channels_match_their_pins_and_are_distinct() {
    for b in pin_maps() {
        let mut lines = BTreeMap::new();
        for (role, name, ch) in &b.exti_inputs {
            let p = pin(name);
            assert_eq!(
                *ch,
                format!("EXTI{}", p.pin),
                "{}: {role} on {name}",
                b.name
            );
            if let Some(other) = lines.insert(p.pin, *role) {
                panic!("{}: {role} and {other} share EXTI line {}", b.name, p.pin);
            }
        }
    }
}

#[test]
fn analog_roles_are_on_adc1_pins() {
    for b in pin_maps() {
        for (role, name) in &b.analog {
            assert!(
                adc1_channel(pin(name)).is_some(),
                "{}: {role} on {name} has no ADC1 channel",
                b.name
            );
        }
    }
}

#[test]
fn spindle_pwm_is_a_free_timer_channel() {
    for b in pin_maps() {
        assert!(
            PWM_PINS.contains(&b.spindle_pwm),
            "{}: spindle PWM {:?}",
            b.name,
            b.spindle_pwm
        );
    }
}

#[test]
fn at_least_four_user_outputs() {
    for b in pin_maps() {
        let n = b.outputs.iter().filter(|o| o.0 == "user_output").count();
        assert!(n >= 4, "{}: {n} user outputs", b.name);
    }
}

#[test]
fn clocks_are_within_limits_and_usb_is_48_mhz() {
    for b in pin_maps() {
        let c = b.clocks;
        // (max SYSCLK, max PCLK1, max PCLK2) from the datasheets.
        let (sys_max, p1_max, p2_max) = match b.probe_chip {
            "STM32F411CEUx" => (100_000_000, 50_000_000, 100_000_000),
            "STM32F446RETx" => (180_000_000, 45_000_000, 90_000_000),
            other => panic!("unknown chip {other}"),
        };
        assert_eq!(c.hse_hz % c.pll_m, 0, "{}: PLL input not whole", b.name);
        let pll_in = c.hse_hz / c.pll_m;
        assert!(
            (1_000_000..=2_000_000).contains(&pll_in),
            "{}: PLL input {pll_in}",
            b.name
        );
        assert!(
            (100_000_000..=432_000_000).contains(&c.vco_hz()),
            "{}: VCO",
            b.name
        );
        assert_eq!(c.vco_hz() % c.pll_q, 0, "{}", b.name);
        assert_eq!(c.usb_hz(), 48_000_000, "{}: USB clock", b.name);
        assert!(
            c.sysclk_hz() <= sys_max,
            "{}: SYSCLK {}",
            b.name,
            c.sysclk_hz()
        );
        assert!(c.pclk1_hz() <= p1_max, "{}: PCLK1 {}", b.name, c.pclk1_hz());
        assert!(c.sysclk_hz() / c.apb2_div <= p2_max, "{}: PCLK2", b.name);
    }
}

#[test]
fn documented_clock_figures() {
    let f411 = blackpill_f411::pin_map().clocks;
    assert_eq!(
        (f411.sysclk_hz(), f411.tim_apb1_hz()),
        (96_000_000, 96_000_000)
    );
    assert!(!f411.hse_bypass);
    let f446 = nucleo_f446::pin_map().clocks;
    assert_eq!(
        (f446.sysclk_hz(), f446.tim_apb1_hz()),
        (168_000_000, 84_000_000)
    );
    assert!(f446.hse_bypass);
}

/// The F411's plasma table is the default one with the A axis's limit, step and dir pins (PA7,
/// PB15, PB9) as arc-OK, THC up and THC down, and every other role on its pin, the clocks the
/// same.
#[test]
fn the_f411_plasma_table_trades_the_a_axis_for_the_torch_inputs() {
    let base = blackpill_f411::pin_map();
    let plasma = blackpill_f411_plasma::pin_map();
    assert!(base.torch_inputs.is_empty());
    assert_eq!(plasma.torch_inputs, ["PA7", "PB15", "PB9"]);
    assert_eq!((base.step.len(), plasma.step.len()), (4, 3));
    let torch = ["arc_ok", "thc_up", "thc_down"];
    let others: Vec<(String, &str)> = base
        .roles()
        .into_iter()
        .filter(|(_, p)| !plasma.torch_inputs.contains(p))
        .collect();
    let kept: Vec<(String, &str)> = plasma
        .roles()
        .into_iter()
        .filter(|(r, _)| !torch.contains(&r.as_str()))
        .collect();
    assert_eq!(kept, others);
    assert_eq!(format!("{:?}", plasma.clocks), format!("{:?}", base.clocks));
    assert_eq!(plasma.probe_chip, base.probe_chip);
}

#[test]
fn pin_names_parse() {
    assert_eq!(Pin::parse("PB12"), Some(Pin { port: 1, pin: 12 }));
    assert_eq!(Pin::parse("PA0"), Some(Pin { port: 0, pin: 0 }));
    assert_eq!(Pin::parse("PA16"), None);
    assert_eq!(Pin::parse("TIM1"), None);
    assert_eq!(pin("PC13").to_string(), "PC13");
}
