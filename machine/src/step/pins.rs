//! The step and dir pins as GPIO BSRR words, tabled per 6-bit step and dir byte.

/// GPIO BSRR words for the step and dir pins, indexed by the kernel's 6-bit step and dir bytes:
/// one table lookup and one register write each, no loop in the interrupt.
pub struct PinWords {
    /// Raises the step pins of each step mask.
    pub step_set: [u32; 64],
    /// Drops every step pin (the pulse end, and the step word of an unprepared update).
    pub step_reset: u32,
    /// Sets every dir pin for each dir mask (bit set = negative = pin high).
    pub dir: [u32; 64],
}

impl PinWords {
    /// Words for step and dir pins with these masks (bit n of a port = pin n), axis order; the
    /// step pins share one port and so do the dir pins.
    pub const fn new(step: &[u32], dir: &[u32]) -> Self {
        let mut words = PinWords {
            step_set: [0; 64],
            step_reset: 0,
            dir: [0; 64],
        };
        let mut axis = 0;
        while axis < step.len() {
            words.step_reset |= step[axis] << 16;
            axis += 1;
        }
        let mut bits = 0;
        while bits < 64 {
            let mut axis = 0;
            while axis < step.len() {
                if bits & (1 << axis) != 0 {
                    words.step_set[bits] |= step[axis];
                }
                axis += 1;
            }
            let mut axis = 0;
            while axis < dir.len() {
                words.dir[bits] |= if bits & (1 << axis) != 0 {
                    dir[axis]
                } else {
                    dir[axis] << 16
                };
                axis += 1;
            }
            bits += 1;
        }
        words
    }
}
