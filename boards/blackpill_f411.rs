//! WeAct "Black Pill" STM32F411CEU6 (UFQFPN48): the default Gantry board.
//!
//! 25 MHz crystal → 96 MHz SYSCLK (/25 ×192 /2); USB 48 MHz from PLL Q (/4); APB1 48 MHz (TIM2
//! clock 96 MHz), APB2 96 MHz. All 30 free GPIOs are used: PA11/PA12 (USB), PA13/PA14 (SWD) and
//! PH0/PH1 (crystal) are left alone; PB11 is not bonded on this package. PA0 is the on-board KEY
//! button (cycle start 1), PC13 the on-board LED (user output 3, active-low LED). Wiring table:
//! boards/README.md. Pin roles are read by `gantry_board!` (firmware and the host check).
gantry_board! {
    name: "blackpill-f411",
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
    // Axis order X Y Z A. Step pins share one port (one BSRR write), so do dir pins.
    step: [PB12, PB13, PB14, PB15],
    dir: [PB6, PB7, PB8, PB9],
    stepper_enable: PB10,
    // One input per axis: min and max switches of an axis wired together (NC in series).
    limit: [PA4 EXTI4, PA5 EXTI5, PA6 EXTI6, PA7 EXTI7],
    feed_hold: PA9 EXTI9,
    abort: PA10 EXTI10,
    cycle_start: [PA0 EXTI0, PC15 EXTI15],
    fro_pot: PA1,
    joystick_axes: [PA2, PA3],
    // No free pin left: PC14 (the joystick's one switch on the other boards' layout) is the
    // touch probe here, which most machines need more than a joystick switch. The other ways
    // to free a pin, and what each costs: boards/README.md "Probe or joystick switch".
    joystick_switches: [],
    probe: PC14,
    // No pins left for the plasma torch's arc-OK and THC up/down inputs: a plasma table on this
    // board gives up the A axis for them (boards/README.md "Plasma torch inputs").
    torch_inputs: [],
    spindle_enable: PB0,
    spindle_dir: PB1,
    spindle_pwm: PA8 TIM1_CH1,
    coolant_flood: PB3,
    coolant_mist: PB4,
    outputs: [PB2, PB5, PC13, PA15],
}
