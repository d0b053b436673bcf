//! The speed colour scale: slow moves blue, fast moves red, with "nice" tick values for the legend.

/// An sRGB colour.
pub(crate) type Rgb = [u8; 3];

/// Colour stops from the slowest (0) to the fastest (1) speed.
pub(crate) const STOPS: [(f64, Rgb); 5] = [
    (0.0, [0x3b, 0x4c, 0xc0]),
    (0.25, [0x1c, 0x9a, 0xd6]),
    (0.5, [0x2f, 0x9e, 0x44]),
    (0.75, [0xf0, 0x8c, 0x00]),
    (1.0, [0xe0, 0x31, 0x31]),
];

/// `#rrggbb`.
pub(crate) fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// Maps speeds (mm/min) in `lo..=hi` onto [`STOPS`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SpeedScale {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
}

impl SpeedScale {
    /// The range of the given speeds; a single speed gets the range 0..=speed.
    pub(crate) fn from_speeds(speeds: impl IntoIterator<Item = f64>) -> Option<SpeedScale> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in speeds.into_iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo > hi {
            return None;
        }
        if hi - lo < 1e-9 {
            lo = 0.0;
            if hi <= 0.0 {
                hi = 1.0;
            }
        }
        Some(SpeedScale { lo, hi })
    }

    /// Position of `v` on the scale, 0..=1.
    pub(crate) fn fraction(&self, v: f64) -> f64 {
        ((v - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
    }

    pub(crate) fn colour(&self, v: f64) -> Rgb {
        colour_at(self.fraction(v))
    }

    /// Round tick values inside the range (the ends are labelled separately by the legend).
    pub(crate) fn ticks(&self) -> Vec<f64> {
        let step = nice_step((self.hi - self.lo) / 5.0);
        let mut t = (self.lo / step).ceil() * step;
        let mut out = Vec::new();
        while t <= self.hi + step * 1e-9 {
            out.push(t);
            t += step;
        }
        out
    }
}

/// The colour at fraction `f` (0..=1) of the scale.
pub(crate) fn colour_at(f: f64) -> Rgb {
    let f = f.clamp(0.0, 1.0);
    for w in STOPS.windows(2) {
        let ((f0, c0), (f1, c1)) = (w[0], w[1]);
        if f <= f1 {
            let t = (f - f0) / (f1 - f0);
            let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * t).round() as u8;
            return [mix(c0[0], c1[0]), mix(c0[1], c1[1]), mix(c0[2], c1[2])];
        }
    }
    STOPS[STOPS.len() - 1].1
}

/// The smallest of 1, 2, 5 × 10ⁿ that is at least `raw` (for grid lines and ticks).
pub(crate) fn nice_step(raw: f64) -> f64 {
    if raw.is_nan() || raw <= 0.0 || !raw.is_finite() {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    for m in [1.0, 2.0, 5.0, 10.0] {
        if m * mag >= raw * (1.0 - 1e-9) {
            return m * mag;
        }
    }
    10.0 * mag
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_ends_and_ticks() {
        let s = SpeedScale::from_speeds([300.0, 1200.0, 900.0]).unwrap();
        assert_eq!(s.colour(300.0), STOPS[0].1);
        assert_eq!(s.colour(1200.0), STOPS[4].1);
        assert_eq!(s.ticks(), vec![400.0, 600.0, 800.0, 1000.0, 1200.0]);
        let single = SpeedScale::from_speeds([500.0]).unwrap();
        assert_eq!((single.lo, single.hi), (0.0, 500.0));
        assert!(SpeedScale::from_speeds([]).is_none());
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(0.7), 1.0);
        assert_eq!(nice_step(1.2), 2.0);
        assert_eq!(nice_step(3.0), 5.0);
        assert_eq!(nice_step(50.0), 50.0);
        assert_eq!(nice_step(0.013), 0.02);
    }
}
