//! ST Nucleo-F446RE (LQFP64), wired on the morpho headers.
//!
//! 8 MHz HSE bypass (ST-LINK MCO) → 168 MHz SYSCLK (/4 ×168 /2); USB 48 MHz from PLL Q (/7);
//! APB1 42 MHz (TIM2 clock 84 MHz = 7 × the step kernel's 12 MHz), APB2 84 MHz. USB D-/D+ are PA11/PA12 on
//! CN10 (the Nucleo has no user USB connector: wire one). Left alone: PA2/PA3 (ST-LINK virtual COM
//! port), PA13/PA14 (SWD), PB3 (SWO), PC14/PC15 (32 kHz crystal), PH0/PH1 (HSE). PC13 is the blue
//! B1 button (cycle start 1), PA5 the green LD2 LED (user output 4).
gantry_board! {
    name: "nucleo-f446",
    probe_chip: "STM32F446RETx",
    clocks: {
        hse_hz: 8_000_000,
        hse_bypass: true,
        pll_m: 4,
        pll_n: 168,
        pll_p: 2,
        pll_q: 7,
        apb1_div: 4,
        apb2_div: 2,
    },
    // Axis order X Y Z A. Step pins share one port (one BSRR write), so do dir pins.
    step: [PC6, PC7, PC8, PC9],
    dir: [PB12, PB13, PB14, PB15],
    stepper_enable: PB1,
    // Separate min and max limit inputs per axis.
    limit: [PC0 EXTI0, PC1 EXTI1, PC2 EXTI2, PC3 EXTI3],
    limit_max: [PA6 EXTI6, PA7 EXTI7, PA9 EXTI9, PA10 EXTI10],
    feed_hold: PC4 EXTI4,
    abort: PC5 EXTI5,
    cycle_start: [PC13 EXTI13, PA15 EXTI15],
    fro_pot: PA0,
    joystick_axes: [PA1, PA4],
    joystick_switches: [PC10, PC11],
    probe: PC12,
    // Plasma torch (docs/laser-plasma.md "Wiring"): arc-OK, THC up, THC down.
    torch_inputs: [PB0, PB2, PD2],
    spindle_enable: PB5,
    spindle_dir: PB4,
    spindle_pwm: PA8 TIM1_CH1,
    coolant_flood: PB8,
    coolant_mist: PB9,
    outputs: [PB6, PB7, PB10, PA5],
}
