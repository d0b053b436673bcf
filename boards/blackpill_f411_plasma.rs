//! WeAct "Black Pill" STM32F411CEU6 for a plasma table (`board-f411-plasma`): the default
//! Black Pill table (`blackpill_f411.rs`, whose clocks and other pins this one keeps) with the A
//! axis traded for the torch's three inputs. The F411 has no free pin (boards/README.md), and a
//! plasma table is a 3-axis machine (a second Y motor runs from Y's driver), so A's limit, step
//! and dir pins become arc-OK, THC up and THC down: polled inputs with pull-ups like every
//! switch (docs/laser-plasma.md "Plasma"). Wiring table: boards/README.md.
gantry_board! {
    name: "blackpill-f411-plasma",
    probe_chip: "STM32F411CEUx",
    clocks: {
        hse_hz: 25_000_000,
        hse_bypass: false,
        pll_m: 25,
        pll_n: 192,
        pll_p: 2,
        pll_q: 4,
        apb1_div: 2,
        apb2_div: 1,
    },
    // Axis order X Y Z. Step pins share one port (one BSRR write), so do dir pins.
    step: [PB12, PB13, PB14],
    dir: [PB6, PB7, PB8],
    stepper_enable: PB10,
    // One input per axis: min and max switches of an axis wired together (NC in series).
    limit: [PA4 EXTI4, PA5 EXTI5, PA6 EXTI6],
    feed_hold: PA9 EXTI9,
    abort: PA10 EXTI10,
    cycle_start: [PA0 EXTI0, PC15 EXTI15],
    fro_pot: PA1,
    joystick_axes: [PA2, PA3],
    joystick_switches: [],
    probe: PC14,
    // Arc-OK on A's limit pin, THC up and down on A's step and dir pins (polled every
    // millisecond, so PA7 needs no EXTI line here). 3.3 V logic: through the power source's
    // relay contact or an opto (docs/laser-plasma.md "Plasma").
    torch_inputs: [PA7, PB15, PB9],
    spindle_enable: PB0,
    spindle_dir: PB1,
    spindle_pwm: PA8 TIM1_CH1,
    coolant_flood: PB3,
    coolant_mist: PB4,
    outputs: [PB2, PB5, PC13, PA15],
}
